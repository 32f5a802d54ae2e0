"""The on-disk cache of loaded scenarios: plain data (JSON), checked strictly when read.

A cache file holds a grounded task and its mutexes as lists of strings and integers, never code:
reading one cannot run anything. It records the scenario's name and the full cache key; a file that
names another scenario or key, or that breaks the format in any way (types, index ranges, missing
fields), is ignored with a warning, and the caller rebuilds the scenario and rewrites the file.

Files are written to a fresh temporary file in the cache folder (``tempfile.mkstemp``: exclusive
creation, a random name, no symbolic link followed) and then renamed over the entry. Files are read
without following a symbolic link, and only when they are regular files. A cache folder that
belongs to another user, or that other users may write to, is not used (one warning; the scenario
is then built from its PDDL), as ssh does with its own files.
"""

from __future__ import annotations

import functools
import hashlib
import json
import logging
import os
import stat
import sys
import tempfile
from collections.abc import Iterable, Mapping, Sequence
from dataclasses import dataclass
from itertools import chain
from pathlib import Path
from typing import Any, NoReturn

from hbtp import __version__
from hbtp.collector import collector_paused
from hbtp.domains.mutex import Mutexes, MutexGroup
from hbtp.logic.atoms import NEGATION, Atom
from hbtp.logic.task import GroundAction, GroundTask

log = logging.getLogger(__name__)

FORMAT = "hbtp-scenario-cache"
VERSION = 1
SUFFIX = ".json"
MAX_BYTES = 256 * 1024 * 1024  # RobotHow's entry is about 1 MB; anything near this is not ours


@dataclass(frozen=True, slots=True)
class CachedScenario:
    """What a cache entry holds: everything of a :class:`~hbtp.domains.scenarios.Scenario` that is
    not known from the shipped data's paths."""

    task: GroundTask
    mutexes: Mutexes
    title: str
    description: str
    fewshot: str | None
    test_set: str | None


@dataclass(frozen=True, slots=True)
class CacheEntry:
    """Where the scenario ``name`` built under ``key`` is cached."""

    directory: Path
    name: str
    key: str

    @property
    def path(self) -> Path:
        return self.directory / f"{self.name}-{self.key[:16]}{SUFFIX}"


class CacheFormatError(ValueError):
    """A cache file that is not a valid entry for the scenario asked for."""


# ------------------------------------------------------------------------------ where
def cache_dir() -> Path | None:
    """Where loaded scenarios are cached: ``$HBTP_CACHE_DIR``, else ``$XDG_CACHE_HOME/hbtp`` or
    ``~/.cache/hbtp``; ``None`` when ``HBTP_NO_CACHE`` is set."""
    if os.environ.get("HBTP_NO_CACHE"):
        return None
    explicit = os.environ.get("HBTP_CACHE_DIR")
    if explicit:
        return Path(explicit).expanduser()
    base = os.environ.get("XDG_CACHE_HOME") or str(Path.home() / ".cache")
    return Path(base) / "hbtp"


def scenario_key(name: str, entry: Mapping[str, Any], files: Iterable[Path]) -> str:
    """The hash of everything a shipped scenario is built from: its manifest entry, its data files,
    the hbtp and Python versions and the source of ``hbtp.domains`` and ``hbtp.logic`` (so a changed
    grounder never reads a stale entry)."""
    digest = hashlib.sha256(f"{__version__}|{sys.version_info[:2]}|{name}|{sorted(entry.items())!r}".encode())
    for file in files:
        digest.update(file.read_bytes())
    package = Path(__file__).resolve().parents[1]
    for source in sorted([*package.glob("domains/*.py"), *package.glob("logic/*.py")]):
        digest.update(source.read_bytes())
    return digest.hexdigest()


def cache_entry(name: str, key: str) -> CacheEntry | None:
    """The cache entry of scenario ``name`` under ``key``, or ``None`` when caching is off or the
    cache folder is not safe to use."""
    directory = cache_dir()
    if directory is None:
        return None
    problem = _unsafe_directory(directory)
    if problem is not None:
        _warn_once(f"not using the scenario cache {directory}: {problem}; scenarios are built from their PDDL")
        return None
    return CacheEntry(directory, name, key)


def _unsafe_directory(directory: Path) -> str | None:
    """Why ``directory`` must not hold the cache (``None``: it is safe, or does not exist yet)."""
    try:
        info = directory.stat()
    except FileNotFoundError:
        return None
    except OSError as error:
        return f"cannot inspect it ({error.strerror or error})"
    if not stat.S_ISDIR(info.st_mode):
        return "it is not a folder"
    if not hasattr(os, "geteuid"):  # no Unix owners and modes to check
        return None
    if info.st_uid != os.geteuid():
        return f"it belongs to user id {info.st_uid}, not to you (user id {os.geteuid()})"
    if info.st_mode & (stat.S_IWGRP | stat.S_IWOTH):
        return f"other users may write to it (mode {stat.S_IMODE(info.st_mode):o}; chmod go-w {directory})"
    return None


@functools.lru_cache(maxsize=64)  # the messages said once (a process meets one or two)
def _warn_once(message: str) -> None:
    log.warning("%s", message)


# ------------------------------------------------------------------------------ read and write
def read_cached(entry: CacheEntry) -> CachedScenario | None:
    """The scenario cached at ``entry``, or ``None`` (no file, or an invalid one: warned and ignored)."""
    data = read_entry_bytes(entry, "scenario cache")
    if data is None:
        return None
    try:
        return decode(data, entry.name, entry.key)
    except ValueError as error:  # CacheFormatError, bad JSON or bad UTF-8
        log.warning("ignoring the scenario cache %s: %s; rebuilding it", entry.path, error)
        return None


def read_entry_bytes(entry: CacheEntry, what: str) -> bytes | None:
    """The bytes of the regular file at ``entry`` (no symbolic link followed), or ``None``: no file,
    or one that cannot be read (warned, naming it as ``what``)."""
    try:
        return _read_regular_file(entry.path)
    except FileNotFoundError:
        return None
    except OSError as error:
        log.warning("ignoring the %s %s: %s", what, entry.path, error.strerror or error)
        return None


def _read_regular_file(path: Path) -> bytes:
    flags = os.O_RDONLY | getattr(os, "O_NOFOLLOW", 0) | getattr(os, "O_NONBLOCK", 0) | getattr(os, "O_BINARY", 0)
    try:
        descriptor = os.open(path, flags)
    except OSError as error:
        if os.path.islink(path):
            raise OSError(f"it is a symbolic link ({error.strerror or error})") from None
        raise
    try:
        info = os.fstat(descriptor)
        if not stat.S_ISREG(info.st_mode):
            raise OSError("it is not a regular file")
        if info.st_size > MAX_BYTES:
            raise OSError(f"it is too large ({info.st_size} bytes)")
    except BaseException:
        os.close(descriptor)
        raise
    with os.fdopen(descriptor, "rb") as handle:
        return handle.read(MAX_BYTES + 1)


def write_cached(entry: CacheEntry, scenario: CachedScenario) -> None:
    """Write ``scenario`` at ``entry`` through a fresh temporary file; failures are logged, never
    raised (the cache only saves time)."""
    try:
        data = encode(scenario, entry.name, entry.key)
    except ValueError as error:
        log.info("could not write the scenario cache %s: %s", entry.path, error)
        return
    write_entry_bytes(entry, data, "scenario cache")


def write_entry_bytes(entry: CacheEntry, data: bytes, what: str) -> None:
    """Write ``data`` at ``entry`` through a fresh temporary file in a safe cache folder; failures
    are logged (naming the file as ``what``), never raised."""
    path = entry.path
    try:
        entry.directory.mkdir(mode=0o700, parents=True, exist_ok=True)
        problem = _unsafe_directory(entry.directory)
        if problem is not None:
            _warn_once(f"not writing the {what} {entry.directory}: {problem}")
            return
        descriptor, temporary = tempfile.mkstemp(prefix=f".{entry.name}-", suffix=".tmp", dir=entry.directory)
        try:
            with os.fdopen(descriptor, "wb") as handle:
                handle.write(data)
            os.replace(temporary, path)
        except BaseException:
            Path(temporary).unlink(missing_ok=True)
            raise
    except OSError as error:
        log.info("could not write the %s %s: %s", what, path, error)


# ------------------------------------------------------------------------------ encode
def encode(scenario: CachedScenario, name: str, key: str) -> bytes:
    """The cache file's bytes: compact JSON, atoms and actions as lists of integers."""
    task, mutexes = scenario.task, scenario.mutexes
    symbols: dict[str, int] = {}

    def symbol(text: str) -> int:
        return symbols.setdefault(text, len(symbols))

    def atom(value: Atom) -> list[int]:  # a negated twin's predicate is written with its mark
        return [symbol((NEGATION if value.negated else "") + value.predicate), *map(symbol, value.args)]

    def ids(values: Iterable[int]) -> list[int]:
        return sorted(values)

    if any(action.index != position for position, action in enumerate(task.actions)):
        raise ValueError("the task's action indices are not their positions")  # never from the grounder
    actions = task.actions
    document = {
        "format": FORMAT,
        "version": VERSION,
        "name": name,
        "key": key,
        "title": scenario.title,
        "description": scenario.description,
        "fewshot": scenario.fewshot,
        "test_set": scenario.test_set,
        "task": {
            "name": task.name,
            "atoms": [atom(a) for a in task.atoms],
            "actions": {
                "signature": [atom(a.signature) for a in actions],
                "pre": [ids(a.pre) for a in actions],
                "add": [ids(a.add) for a in actions],
                "delete": [ids(a.delete) for a in actions],
                "cost": [a.cost for a in actions],
            },
            "initial_state": ids(task.initial_state),
            "objects": [symbol(o) for o in task.objects],
            "constants": [symbol(c) for c in task.constants],
            "predicate_names": [symbol(p) for p in task.predicates],
            "predicate_arities": list(task.predicates.values()),
            "static_facts": [atom(f) for f in sorted(task.static_facts)],
            "static_predicate_names": [symbol(p) for p in task.static_predicates],
            "static_predicate_arities": list(task.static_predicates.values()),
        },
        "mutexes": {
            "atom_count": mutexes.atom_count,
            "group_atoms": [ids(g.atoms) for g in mutexes.groups],
            "group_patterns": [g.pattern for g in mutexes.groups],
            "group_proved": [g.proved for g in mutexes.groups],
            "nogoods": [ids(n) for n in mutexes.nogoods],
        },
    }
    document["symbols"] = list(symbols)
    return json.dumps(document, ensure_ascii=False, separators=(",", ":")).encode()


# ------------------------------------------------------------------------------ decode
def _fail(message: str) -> NoReturn:
    raise CacheFormatError(message)


def _reject_number(text: str) -> NoReturn:
    _fail(f"unexpected number {text[:20]!r}")


def _object(value: object, what: str) -> dict[str, Any]:
    if type(value) is not dict:
        _fail(f"{what} is not an object")
    return value


def _field(document: Mapping[str, Any], name: str, kind: type, what: str) -> Any:
    if name not in document:
        _fail(f"{what} has no {name!r}")
    value = document[name]
    if type(value) is not kind:
        _fail(f"{what}.{name} is not a {kind.__name__}")
    return value


def _optional_text(document: Mapping[str, Any], name: str) -> str | None:
    value = document.get(name)
    if value is not None and type(value) is not str:
        _fail(f"{name} is neither text nor null")
    return value


def _texts(value: object, what: str) -> list[str]:
    if type(value) is not list or not set(map(type, value)) <= {str}:
        _fail(f"{what} is not a list of text")
    return value


def _ints(value: object, what: str, bound: int, *, low: int = 0) -> list[int]:
    """A list of integers in ``low .. bound - 1`` (booleans are not integers here)."""
    if type(value) is not list or not set(map(type, value)) <= {int}:
        _fail(f"{what} is not a list of integers")
    if value and (min(value) < low or max(value) >= bound):
        _fail(f"{what} holds a value outside {low}..{bound - 1}")
    return value


def _int_lists(
    value: object, what: str, bound: int, *, count: int | None = None, nonempty: bool = False
) -> list[list[int]]:
    """A list of lists of integers in ``0 .. bound - 1``."""
    if type(value) is not list or not set(map(type, value)) <= {list}:
        _fail(f"{what} is not a list of lists")
    if count is not None and len(value) != count:
        _fail(f"{what} has {len(value)} entries, expected {count}")
    if nonempty and not all(value):
        _fail(f"{what} has an empty entry")
    _ints(list(chain.from_iterable(value)), what, bound)
    return value


def _atoms(rows: object, symbols: Sequence[str], what: str, *, unique: bool = False) -> list[Atom]:
    """Atoms as lists of symbol indices (``symbols`` holds no repeats, so equal rows are equal atoms)."""
    checked = _int_lists(rows, what, len(symbols), nonempty=True)
    if unique and len(set(map(tuple, checked))) != len(checked):
        _fail(f"{what} repeats an entry")
    name = symbols.__getitem__
    atoms = [Atom(name(row[0]), tuple(map(name, row[1:]))) for row in checked]
    return [Atom(a.predicate[len(NEGATION) :], a.args, True) if a.predicate.startswith(NEGATION) else a for a in atoms]


def decode(data: bytes, name: str, key: str) -> CachedScenario:
    """Read a cache file's bytes back; raises :class:`CacheFormatError` (a :class:`ValueError`) unless
    they are a well-formed entry for scenario ``name`` under ``key``."""
    # Decoding makes some 100,000 objects (RobotHow: about 90 ms with the collector, 45 without).
    with collector_paused():
        return _decode(data, name, key)


def _decode(data: bytes, name: str, key: str) -> CachedScenario:
    try:
        loaded = json.loads(data, parse_float=_reject_number, parse_constant=_reject_number)
    except RecursionError:
        _fail("it is nested too deeply")
    document = _object(loaded, "the file")
    if document.get("format") != FORMAT or document.get("version") != VERSION:
        _fail(f"not an hbtp scenario cache of format version {VERSION}")
    if document.get("name") != name:
        _fail(f"it holds scenario {str(document.get('name'))[:80]!r}, not {name!r}")
    if document.get("key") != key:
        _fail("it was built from other data or another version of hbtp (cache key differs)")
    symbols = _texts(document.get("symbols"), "symbols")
    if len(set(symbols)) != len(symbols):
        _fail("symbols repeats a name")
    task = _decode_task(_object(document.get("task"), "task"), symbols)
    return CachedScenario(
        task=task,
        mutexes=_decode_mutexes(_object(document.get("mutexes"), "mutexes"), len(task.atoms)),
        title=_field(document, "title", str, "the file"),
        description=_field(document, "description", str, "the file"),
        fewshot=_optional_text(document, "fewshot"),
        test_set=_optional_text(document, "test_set"),
    )


def _decode_task(raw_task: Mapping[str, Any], symbols: Sequence[str]) -> GroundTask:
    atoms = _atoms(raw_task.get("atoms"), symbols, "task.atoms", unique=True)
    actions = _decode_actions(_object(raw_task.get("actions"), "task.actions"), symbols, len(atoms))
    symbol_count = len(symbols)
    predicate_names = _ints(raw_task.get("predicate_names"), "task.predicate_names", symbol_count)
    arities = _ints(raw_task.get("predicate_arities"), "task.predicate_arities", sys.maxsize)
    if len(arities) != len(predicate_names) or len(set(predicate_names)) != len(predicate_names):
        _fail("task.predicate_names and task.predicate_arities do not match")
    static_names = _ints(raw_task.get("static_predicate_names"), "task.static_predicate_names", symbol_count)
    static_arities = _ints(raw_task.get("static_predicate_arities"), "task.static_predicate_arities", sys.maxsize)
    if len(static_arities) != len(static_names):
        _fail("task.static_predicate_names and task.static_predicate_arities do not match")
    return GroundTask(
        name=_field(raw_task, "name", str, "task"),
        atoms=tuple(atoms),
        actions=actions,
        initial_state=frozenset(_ints(raw_task.get("initial_state"), "task.initial_state", len(atoms))),
        objects=tuple(symbols[i] for i in _ints(raw_task.get("objects"), "task.objects", symbol_count)),
        constants=tuple(symbols[i] for i in _ints(raw_task.get("constants"), "task.constants", symbol_count)),
        predicates={symbols[i]: arity for i, arity in zip(predicate_names, arities, strict=True)},
        static_facts=frozenset(_atoms(raw_task.get("static_facts"), symbols, "task.static_facts")),
        static_predicates={symbols[i]: arity for i, arity in zip(static_names, static_arities, strict=True)},
    )


def _decode_actions(
    raw_actions: Mapping[str, Any], symbols: Sequence[str], atom_count: int
) -> tuple[GroundAction, ...]:
    signatures = _atoms(raw_actions.get("signature"), symbols, "task.actions.signature", unique=True)
    count = len(signatures)
    pre = _int_lists(raw_actions.get("pre"), "task.actions.pre", atom_count, count=count)
    add = _int_lists(raw_actions.get("add"), "task.actions.add", atom_count, count=count)
    delete = _int_lists(raw_actions.get("delete"), "task.actions.delete", atom_count, count=count)
    costs = _ints(raw_actions.get("cost"), "task.actions.cost", sys.maxsize)
    if len(costs) != count:
        _fail(f"task.actions.cost has {len(costs)} entries, expected {count}")
    return tuple(
        GroundAction(index, signature, frozenset(p), frozenset(a), frozenset(d), cost)
        for index, (signature, p, a, d, cost) in enumerate(zip(signatures, pre, add, delete, costs, strict=True))
    )


def _decode_mutexes(raw_mutexes: Mapping[str, Any], atom_count: int) -> Mutexes:
    if _field(raw_mutexes, "atom_count", int, "mutexes") != atom_count:
        _fail("mutexes.atom_count is not the number of atoms")
    group_atoms = _int_lists(raw_mutexes.get("group_atoms"), "mutexes.group_atoms", atom_count)
    patterns = _texts(raw_mutexes.get("group_patterns"), "mutexes.group_patterns")
    proved = raw_mutexes.get("group_proved")
    if type(proved) is not list or not set(map(type, proved)) <= {bool}:
        _fail("mutexes.group_proved is not a list of true/false")
    if not len(group_atoms) == len(patterns) == len(proved):
        _fail("mutexes.group_atoms, group_patterns and group_proved differ in length")
    nogoods = _int_lists(raw_mutexes.get("nogoods"), "mutexes.nogoods", atom_count, nonempty=True)
    return Mutexes(
        tuple(
            MutexGroup(frozenset(members), pattern, flag)
            for members, pattern, flag in zip(group_atoms, patterns, proved, strict=True)
        ),
        tuple(frozenset(n) for n in nogoods),
        atom_count,
    )
