"""BehaviorTree.CPP's FileLogger2 log (``.btlog``, what Groot2 replays), read back.

The file is ``BTCPP4-FileLogger2``, a protocol byte (1), the tree's XML (a little-endian 32-bit
length, then the text, every node with its ``_uid``), the time of the first transition (64 bits,
microseconds), then one 9-byte record per status change: 48 bits of microseconds since that first
time, the node's 16-bit ``_uid`` and its new status (0 idle, 1 running, 2 success, 3 failure, 4
skipped). :func:`read_btlog` checks every part and says in one line what is wrong with a file.

A log holds one tree. A run whose re-plans swap trees writes one log per tree
(:func:`btlog_paths`): the first tree's at the path asked for (``run.btlog``), the tree of the k-th
re-plan beside it with ``.k`` before the suffix (``run.1.btlog``, ``run.2.btlog``, ...).
"""

from __future__ import annotations

import struct
import xml.etree.ElementTree as ET
from dataclasses import dataclass
from pathlib import Path

from hbtp.errors import InputError
from hbtp.files import InputKind, read_bytes

__all__ = ["MAGIC", "BtLog", "Transition", "btlog_paths", "read_btlog"]

MAGIC = b"BTCPP4-FileLogger2"
_RECORD = 9
_STATUSES = ("idle", "running", "success", "failure", "skipped")


@dataclass(frozen=True)
class Transition:
    """A node's status change: microseconds since the first, the node's ``_uid``, name and new status."""

    time_us: int
    uid: int
    name: str
    status: str


@dataclass(frozen=True)
class BtLog:
    """A FileLogger2 log: the tree's XML as logged, and its transitions in order."""

    xml: str
    first_time_us: int
    transitions: tuple[Transition, ...]

    def started(self) -> list[str]:
        """The names of the nodes that went RUNNING, in order (control nodes and the actions run)."""
        return [t.name for t in self.transitions if t.status == "running"]


def btlog_paths(path: Path, trees: int) -> list[Path]:
    """Where the logs of a run's ``trees`` trees go: ``path`` for the first, then ``path`` with the
    number of the re-plan before its suffix (``run.btlog``, ``run.1.btlog``, ``run.2.btlog``)."""
    return [path, *(path.with_name(f"{path.stem}.{k}{path.suffix}") for k in range(1, trees))]


def read_btlog(path: str | Path) -> BtLog:
    """Read a ``.btlog`` file (:class:`InputError` with the reason when it is not one)."""
    where = Path(path)
    data = read_bytes(where, InputKind.TRACE)
    if not data.startswith(MAGIC) or len(data) < len(MAGIC) + 5:
        raise InputError(f"{where}: not a BehaviorTree.CPP FileLogger2 log (no {MAGIC.decode()} header)")
    position = len(MAGIC) + 1
    (size,) = struct.unpack_from("<I", data, position)
    position += 4
    if position + size + 8 > len(data):
        raise InputError(f"{where}: the log is truncated inside its tree XML")
    xml_text = data[position : position + size].decode("utf-8", errors="replace")
    position += size
    (first,) = struct.unpack_from("<Q", data, position)
    position += 8
    records = data[position:]
    if len(records) % _RECORD:
        raise InputError(f"{where}: the log ends inside a transition record")
    names = _names(xml_text, where)
    transitions = []
    for offset in range(0, len(records), _RECORD):
        uid = int.from_bytes(records[offset + 6 : offset + 8], "little")
        status = records[offset + 8]
        if uid not in names or status >= len(_STATUSES):
            raise InputError(f"{where}: transition {offset // _RECORD} names node {uid} or status {status}, unknown")
        time_us = int.from_bytes(records[offset : offset + 6], "little")
        transitions.append(Transition(time_us, uid, names[uid], _STATUSES[status]))
    return BtLog(xml_text, first, tuple(transitions))


def _names(xml_text: str, where: Path) -> dict[int, str]:
    """Each node's ``_uid`` and name (its ``name`` attribute, else its element name)."""
    try:
        root = ET.fromstring(xml_text)
    except ET.ParseError as error:
        raise InputError(f"{where}: the logged tree XML does not parse: {error}") from None
    return {int(e.attrib["_uid"]): e.attrib.get("name", e.tag) for e in root.iter() if "_uid" in e.attrib}
