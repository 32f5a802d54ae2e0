"""The reference text format of the datasets.

Records are separated by blank lines. Each starts with its id and continues with ``Key: value``
lines::

    3
    Environment:1
    Instruction: Ensure the milk is refrigerated before you go to bed.
    Goals: IsIn_milk_fridge
    Optimal Actions: Walk_milk, RightGrab_milk, Walk_fridge, PlugIn_fridge, Open_fridge, RightPutIn_milk_fridge
    Vital Action Predicates: Walk, RightGrab, PlugIn, Open, RightPutIn
    Vital Objects: milk, fridge
    cost: 42

``Goals``, ``Optimal Actions``, ``Vital Action Predicates`` and ``Vital Objects`` are required (the
lists may be empty: an empty ``Optimal Actions`` means the goal already holds); ``Environment``
(default ``1``), ``Instruction`` (default empty) and ``cost`` (ASCII digits ``0-9``, at most 18
significant ones) are optional. The reader accepts the keys in any order; the writer uses the order
above.

Round trip: one space after the colon separates key and value; everything after it is the value.
``Goals`` and ``Instruction`` are kept verbatim, so the shipped files' stray spaces (``Instruction:  ``
in the RoboWaiter files, ``Goals:  IsClean_sofa`` in ``table2_robothow_50``) survive, and writing the
records of a shipped file gives the file back byte for byte, except at its very end: the shipped
files end with zero, one or two newlines, and :func:`write_text` always ends with exactly one.

Any malformed record raises :class:`~hbtp.errors.DatasetError` with the source and the line.
"""

from __future__ import annotations

import re
from collections.abc import Iterable
from pathlib import Path

from hbtp.datasets.records import MAX_COST, Record
from hbtp.datasets.reply import ACTIONS, OBJECTS, PREDICATES, reply_lines
from hbtp.errors import DatasetError, InputError, SourceError
from hbtp.files import InputKind
from hbtp.files import read_text as read_file_text
from hbtp.logic.atoms import parse_conjunction

ENVIRONMENT = "Environment"
INSTRUCTION = "Instruction"
GOALS = "Goals"
COST = "cost"

#: The keys in the order the writer uses.
KEYS = (ENVIRONMENT, INSTRUCTION, GOALS, ACTIONS, PREDICATES, OBJECTS, COST)
REQUIRED = (GOALS, ACTIONS, PREDICATES, OBJECTS)

_KEY_LINE = re.compile(r"^([A-Za-z][A-Za-z ]*?):(.*)$")
_TOKEN = re.compile(r"[^\s:,]+")
_NAME = re.compile(r"[A-Za-z0-9][A-Za-z0-9_\-]*")
#: ASCII digits only: ``re``'s ``\d`` and ``int()`` also take other scripts' digits (``٣``), and
#: ``int()`` takes ``1_0``.
_COST = re.compile(r"[0-9]+")
#: Longer costs are refused (as in JSONL: ``MAX_COST``; ``int()`` refuses more than 4300 digits).
MAX_COST_DIGITS = len(str(MAX_COST - 1))


# ------------------------------------------------------------------ reading
def read_text(text: str, source: str = "<string>") -> list[Record]:
    """Read every record of a text in the reference format.

    Raises :class:`DatasetError` (with ``source`` and the 1-based line) on a malformed record or a
    repeated record id.
    """
    records: list[Record] = []
    first_line: dict[str, int] = {}
    for block in _blocks(text):
        record = _read_block(block, source)
        if record.id in first_line:
            raise DatasetError(
                f"duplicate record id {record.id!r} (first at line {first_line[record.id]})", source, record.line
            )
        first_line[record.id] = record.line
        records.append(record)
    return records


def read_text_file(path: str | Path) -> list[Record]:
    """Read a dataset file in the reference format; unreadable files raise :class:`DatasetError`."""
    return read_text(read_source(path), str(path))


def read_source(path: str | Path) -> str:
    """The UTF-8 text of a file, with :class:`DatasetError` (not ``OSError``) when it cannot be read."""
    try:
        return read_file_text(path, InputKind.DATASET)
    except SourceError as error:
        raise DatasetError(error.message, error.source, error.line, error.column) from None


def _blocks(text: str) -> list[list[tuple[int, str]]]:
    """Split a text into blocks of ``(line number, line)`` separated by blank lines."""
    text = text.removeprefix("\ufeff")
    blocks: list[list[tuple[int, str]]] = []
    current: list[tuple[int, str]] = []
    for number, raw in enumerate(text.split("\n"), start=1):
        line = raw.removesuffix("\r")
        if line.strip():
            current.append((number, line))
        elif current:
            blocks.append(current)
            current = []
    if current:
        blocks.append(current)
    return blocks


def _read_block(block: list[tuple[int, str]], source: str) -> Record:
    start = block[0][0]
    record_id = _read_id(block[0], source)
    values = _key_values(record_id, block, source)
    number = start
    try:
        number, goal = values[GOALS]
        _check_goal(goal)
        lists: list[tuple[str, ...]] = []
        for key in (ACTIONS, PREDICATES, OBJECTS):
            number, value = values[key]
            lists.append(_parse_list(value, key))
        number, environment = values.get(ENVIRONMENT, (start, "1"))
        environment = environment.strip()
        _check_token(environment, ENVIRONMENT)
        cost: int | None = None
        if COST in values:
            number, text = values[COST]
            cost = _parse_cost(text)
    except InputError as error:
        raise DatasetError(f"record {record_id}: {error}", source, number) from None
    return Record(
        id=record_id,
        goal=goal,
        optimal_actions=lists[0],
        vital_predicates=lists[1],
        vital_objects=lists[2],
        instruction=values.get(INSTRUCTION, (start, ""))[1],
        environment=environment,
        cost=cost,
        line=start,
    )


def _read_id(first: tuple[int, str], source: str) -> str:
    """The record id of a block's first line."""
    start, id_line = first
    if _KEY_LINE.match(id_line):
        raise DatasetError(
            f"expected a record id, got {id_line.strip()!r} (no id line, or a stray blank line in a record?)",
            source,
            start,
        )
    if not _TOKEN.fullmatch(id_line.strip()):
        raise DatasetError(f"expected a record id (one word), got {id_line.strip()!r}", source, start)
    return id_line.strip()


def _key_values(record_id: str, block: list[tuple[int, str]], source: str) -> dict[str, tuple[int, str]]:
    """``key -> (line number, value)`` of the ``Key: value`` lines after the id; every required key present."""
    values: dict[str, tuple[int, str]] = {}
    for number, line in block[1:]:
        match = _KEY_LINE.match(line)
        if not match:
            raise DatasetError(
                f"record {record_id}: cannot read {line.strip()!r} (expected 'Key: value' or a blank line)",
                source,
                number,
            )
        key, value = match.group(1), match.group(2).removeprefix(" ")
        if key not in KEYS:
            raise DatasetError(
                f"record {record_id}: unknown key {key!r} (expected one of: {', '.join(KEYS)})", source, number
            )
        if key in values:
            raise DatasetError(
                f"record {record_id}: duplicate {key!r} line (first at line {values[key][0]})", source, number
            )
        values[key] = (number, value)
    missing = [key for key in REQUIRED if key not in values]
    if missing:
        raise DatasetError(
            f"record {record_id}: missing {', '.join(repr(k + ':') for k in missing)} line", source, block[0][0]
        )
    return values


def _parse_list(value: str, key: str) -> tuple[str, ...]:
    if not value.strip():
        return ()
    items = tuple(item.strip() for item in value.split(","))
    for item in items:
        _check_name(item, key)
    return items


def _parse_cost(text: str) -> int:
    digits = text.strip()
    if not _COST.fullmatch(digits):
        shown = digits if len(digits) <= 40 else digits[:40] + "..."
        raise InputError(f"cost must be a non-negative integer in ASCII digits, got {shown!r}")
    significant = digits.lstrip("0") or "0"
    if len(significant) > MAX_COST_DIGITS:
        raise InputError(f"cost has {len(significant)} digits; at most {MAX_COST_DIGITS} are allowed")
    return int(significant)


# ------------------------------------------------------------------ checks
def _check_goal(goal: str) -> None:
    if "\n" in goal or "\r" in goal:
        raise InputError("goal spans several lines")
    try:
        parse_conjunction(goal)
    except InputError as error:
        raise InputError(f"bad goal: {error}") from None


def _check_name(item: str, key: str) -> None:
    if not item:
        raise InputError(f"empty item in {key!r}")
    if not _NAME.fullmatch(item):
        raise InputError(f"malformed name {item!r} in {key!r}")


def _check_token(value: str, key: str) -> None:
    if not _TOKEN.fullmatch(value):
        raise InputError(f"{key} must be one word without spaces, ':' or ',', got {value!r}")


# ------------------------------------------------------------------ writing
def write_text(records: Iterable[Record]) -> str:
    """Write records in the reference format, blank-line separated, ending with one newline.

    Raises :class:`~hbtp.errors.InputError` for a record the format cannot hold (a multi-line
    instruction, a name with a comma…), so that ``read_text(write_text(rs)) == rs`` always holds.
    """
    blocks = [_write_record(record) for record in records]
    return "\n\n".join(blocks) + "\n" if blocks else ""


def _write_record(record: Record) -> str:
    try:
        _check_token(record.id, "record id")
        _check_token(record.environment, ENVIRONMENT)
        _check_goal(record.goal)
        if "\n" in record.instruction or "\r" in record.instruction:
            raise InputError("instruction spans several lines")
        for key, items in (
            (ACTIONS, record.optimal_actions),
            (PREDICATES, record.vital_predicates),
            (OBJECTS, record.vital_objects),
        ):
            for item in items:
                _check_name(item, key)
        if record.cost is not None and record.cost < 0:
            raise InputError(f"negative cost {record.cost}")
    except InputError as error:
        raise InputError(f"record {record.id!r} cannot be written in the text format: {error}") from None
    lines = [
        record.id,
        f"{ENVIRONMENT}:{record.environment}",
        f"{INSTRUCTION}: {record.instruction}",
        f"{GOALS}: {record.goal}",
        *reply_lines(record.optimal_actions, record.vital_predicates, record.vital_objects),
    ]
    if record.cost is not None:
        lines.append(f"{COST}: {record.cost}")
    return "\n".join(lines)
