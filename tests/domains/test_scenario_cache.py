"""The on-disk scenario cache: plain data that gives back the same scenario, never runs code, never
follows a planted link, and is rebuilt whenever it is not exactly the entry asked for."""

from __future__ import annotations

import gc
import json
import logging
import os
import pickle
import stat
from collections.abc import Callable, Iterator
from pathlib import Path
from typing import Any

import pytest

from hbtp.bt import tree_of
from hbtp.bt.jsonio import tree_to_json
from hbtp.domains import cache, scenarios
from hbtp.planning import plan

SMALL = ("robowaiter", "robothow-small")


@pytest.fixture
def cache_folder(tmp_path: Path, monkeypatch: pytest.MonkeyPatch) -> Iterator[Path]:
    """A private cache folder (not created yet: hbtp creates it) for the duration of one test."""
    folder = tmp_path / "cache"
    monkeypatch.delenv("HBTP_NO_CACHE", raising=False)
    monkeypatch.setenv("HBTP_CACHE_DIR", str(folder))
    scenarios._load_shipped.cache_clear()
    yield folder
    scenarios._load_shipped.cache_clear()


def _load(name: str) -> scenarios.Scenario:
    scenarios._load_shipped.cache_clear()
    return scenarios.load_scenario(name)


def _uncached(name: str, monkeypatch: pytest.MonkeyPatch) -> scenarios.Scenario:
    with monkeypatch.context() as patch:
        patch.setenv("HBTP_NO_CACHE", "1")
        return _load(name)


def _entry_file(folder: Path, name: str) -> Path:
    """The one cache file of scenario ``name`` in ``folder``."""
    files = [p for p in folder.iterdir() if p.name.startswith(f"{name}-") and not p.name.endswith(".tmp")]
    assert len(files) == 1, files
    return files[0]


def _fields(scenario: scenarios.Scenario) -> dict[str, Any]:
    """Everything of a scenario that planning, prompts and reports read."""
    task, mutexes = scenario.task, scenario.mutexes
    return {
        "scenario": (scenario.name, scenario.title, scenario.description, scenario.fewshot, scenario.test_set),
        "files": (scenario.domain_file, scenario.problem_file),
        "task": (task.name, task.atoms, task.actions, task.initial_state, task.objects, task.constants),
        "predicates": list(task.predicates.items()),
        "static_facts": task.static_facts,
        "derived": (task.action_predicates, task.categories, task.achievers, task.symbols),
        "mutexes": (mutexes.groups, mutexes.nogoods, mutexes.atom_count, mutexes.partners),
    }


def _warnings(caplog: pytest.LogCaptureFixture) -> list[str]:
    return [r.getMessage() for r in caplog.records if r.levelno >= logging.WARNING]


# ------------------------------------------------------------------------------ round trip
@pytest.mark.parametrize("name", SMALL)
def test_round_trip_equals_a_fresh_grounding(
    name: str, cache_folder: Path, monkeypatch: pytest.MonkeyPatch, caplog: pytest.LogCaptureFixture
) -> None:
    fresh = _uncached(name, monkeypatch)
    built = _load(name)
    path = _entry_file(cache_folder, name)
    assert path.suffix == ".json"
    written = path.read_bytes()
    document = json.loads(written)
    assert (document["name"], document["format"]) == (name, cache.FORMAT)
    assert len(document["key"]) == 64
    caplog.set_level(logging.WARNING)
    cached = _load(name)
    assert cached.task is not built.task  # read back from the file
    assert not _warnings(caplog)
    assert _fields(cached) == _fields(fresh) == _fields(built)
    _load(name)
    assert path.read_bytes() == written  # deterministic, and a valid entry is not rewritten


def test_cached_scenario_plans_identically(cache_folder: Path, monkeypatch: pytest.MonkeyPatch) -> None:
    fresh = _uncached("robothow-small", monkeypatch)
    _load("robothow-small")
    cached = _load("robothow-small")
    assert cached.task is not fresh.task
    for goal in ("IsIn_apple_fridge & IsClose_fridge", "IsSwitchedOn_tv"):
        trees = []
        for loaded in (fresh, cached):
            result = plan(loaded.task, goal, "obtea", mutexes=loaded.mutexes, heuristic="lm")
            assert result.solved, goal
            trees.append(tree_to_json(tree_of(result), loaded.task, scenario=loaded.name, goal=goal))
        assert trees[0] == trees[1]


def test_no_cache_when_disabled(tmp_path: Path, monkeypatch: pytest.MonkeyPatch) -> None:
    monkeypatch.setenv("HBTP_NO_CACHE", "1")
    monkeypatch.setenv("HBTP_CACHE_DIR", str(tmp_path))
    _load("robowaiter")
    assert not list(tmp_path.iterdir())
    scenarios._load_shipped.cache_clear()


def test_cache_folder_is_created_private(cache_folder: Path) -> None:
    _load("robowaiter")
    assert stat.S_IMODE(cache_folder.stat().st_mode) & 0o077 == 0
    assert stat.S_IMODE(_entry_file(cache_folder, "robowaiter").stat().st_mode) & 0o077 == 0


# ------------------------------------------------------------------------------ code never runs
class _Payload:
    """Unpickling this creates ``marker`` (a stand-in for any code an attacker would run)."""

    def __init__(self, marker: Path) -> None:
        self.marker = marker

    def __reduce__(self) -> tuple[Callable[..., object], tuple[str, str]]:
        return open, (str(self.marker), "w")


def test_planted_pickle_never_runs(
    cache_folder: Path, tmp_path: Path, monkeypatch: pytest.MonkeyPatch, caplog: pytest.LogCaptureFixture
) -> None:
    fresh = _uncached("robowaiter", monkeypatch)
    _load("robowaiter")
    path = _entry_file(cache_folder, "robowaiter")
    marker = tmp_path / "PWNED"
    payload = pickle.dumps(_Payload(marker))
    path.with_suffix(".pickle").write_bytes(payload)  # where earlier versions kept a pickle cache
    path.write_bytes(payload)  # and the current entry
    caplog.set_level(logging.WARNING)
    loaded = _load("robowaiter")
    assert not marker.exists()
    assert _fields(loaded) == _fields(fresh)
    assert any("ignoring the scenario cache" in w for w in _warnings(caplog))
    assert json.loads(path.read_bytes())["name"] == "robowaiter"  # rebuilt and rewritten


# ------------------------------------------------------------------------------ planted links
def test_planted_symlinks_are_not_followed(
    cache_folder: Path, tmp_path: Path, monkeypatch: pytest.MonkeyPatch, caplog: pytest.LogCaptureFixture
) -> None:
    fresh = _uncached("robowaiter", monkeypatch)
    _load("robowaiter")
    path = _entry_file(cache_folder, "robowaiter")
    path.unlink()
    victims = [tmp_path / "victim-entry.txt", tmp_path / "victim-temporary.txt"]
    for victim in victims:
        victim.write_text("precious\n", encoding="utf-8")
    path.symlink_to(victims[0])
    path.with_suffix(f".{os.getpid()}.tmp").symlink_to(victims[1])  # the predictable name earlier versions used
    dangling = tmp_path / "created-through-a-link"
    (cache_folder / f".robowaiter-{'x' * 8}.tmp").symlink_to(dangling)
    caplog.set_level(logging.WARNING)
    loaded = _load("robowaiter")
    assert _fields(loaded) == _fields(fresh)
    assert [v.read_text(encoding="utf-8") for v in victims] == ["precious\n", "precious\n"]
    assert not dangling.exists()
    assert not path.is_symlink()  # the link itself was replaced by the new entry
    assert json.loads(path.read_bytes())["name"] == "robowaiter"
    assert any("symbolic link" in w for w in _warnings(caplog))


@pytest.mark.parametrize("kind", ["folder", "fifo"])
def test_entry_that_is_not_a_file_is_ignored(kind: str, cache_folder: Path, caplog: pytest.LogCaptureFixture) -> None:
    _load("robowaiter")
    path = _entry_file(cache_folder, "robowaiter")
    path.unlink()
    if kind == "folder":
        path.mkdir()
    else:
        if not hasattr(os, "mkfifo"):
            pytest.skip("no named pipes here")
        os.mkfifo(path)
    caplog.set_level(logging.WARNING)
    loaded = _load("robowaiter")  # must neither hang on the pipe nor fail
    assert len(loaded.task.actions) == 174
    assert any("not a regular file" in w for w in _warnings(caplog))
    assert not [p for p in cache_folder.iterdir() if p.name.endswith(".tmp")]  # a failed write cleans up


# ------------------------------------------------------------------------------ wrong entries
def test_another_scenarios_cache_is_rejected(
    cache_folder: Path, monkeypatch: pytest.MonkeyPatch, caplog: pytest.LogCaptureFixture
) -> None:
    fresh = _uncached("robothow-small", monkeypatch)
    _load("robowaiter")
    _load("robothow-small")
    target = _entry_file(cache_folder, "robothow-small")
    target.write_bytes(_entry_file(cache_folder, "robowaiter").read_bytes())
    caplog.set_level(logging.WARNING)
    loaded = _load("robothow-small")
    assert _fields(loaded) == _fields(fresh)
    assert any("holds scenario 'robowaiter'" in w for w in _warnings(caplog))
    assert json.loads(target.read_bytes())["name"] == "robothow-small"


def test_entry_with_another_key_is_rejected(cache_folder: Path, caplog: pytest.LogCaptureFixture) -> None:
    _load("robowaiter")
    path = _entry_file(cache_folder, "robowaiter")
    document = json.loads(path.read_bytes())
    document["key"] = "0" * 64
    path.write_text(json.dumps(document), encoding="utf-8")
    caplog.set_level(logging.WARNING)
    _load("robowaiter")
    assert any("cache key differs" in w for w in _warnings(caplog))
    assert json.loads(path.read_bytes())["key"] != "0" * 64


@pytest.mark.parametrize("cut", [0, 1, 1000, -1])
def test_truncated_entry_is_ignored_with_a_warning(
    cut: int, cache_folder: Path, monkeypatch: pytest.MonkeyPatch, caplog: pytest.LogCaptureFixture
) -> None:
    fresh = _uncached("robowaiter", monkeypatch)
    _load("robowaiter")
    path = _entry_file(cache_folder, "robowaiter")
    whole = path.read_bytes()
    path.write_bytes(whole[:cut])
    caplog.set_level(logging.WARNING)
    loaded = _load("robowaiter")
    assert _fields(loaded) == _fields(fresh)
    assert any("ignoring the scenario cache" in w for w in _warnings(caplog))
    assert path.read_bytes() == whole


# Each breaks one rule of the format; decoding must refuse it with CacheFormatError (never another
# exception, never a scenario that fails later).
def _set(path: str, value: object) -> Callable[[dict[str, Any]], None]:
    def change(document: dict[str, Any]) -> None:
        *parents, last = path.split(".")
        target: Any = document
        for part in parents:
            target = target[int(part)] if isinstance(target, list) else target[part]
        if isinstance(target, list):
            target[int(last)] = value
        else:
            target[last] = value

    return change


def _drop(path: str) -> Callable[[dict[str, Any]], None]:
    def change(document: dict[str, Any]) -> None:
        *parents, last = path.split(".")
        target: Any = document
        for part in parents:
            target = target[part]
        del target[last]

    return change


MUTATIONS: dict[str, Callable[[dict[str, Any]], None]] = {
    "format": _set("format", "pickle"),
    "version": _set("version", 2),
    "name": _set("name", "robothow"),
    "atom index out of range": _set("task.actions.pre.0", [10**6]),
    "negative atom index": _set("task.actions.add.0", [-1]),
    "float index": _set("task.actions.pre.0", [1.0]),
    "boolean index": _set("task.actions.delete.0", [True]),
    "text index": _set("task.initial_state", ["0"]),
    "symbol out of range": _set("task.atoms.0", [10**6]),
    "empty atom": _set("task.atoms.0", []),
    "duplicate atom": lambda d: d["task"]["atoms"].__setitem__(1, d["task"]["atoms"][0]),
    "duplicate action": lambda d: d["task"]["actions"]["signature"].__setitem__(
        1, d["task"]["actions"]["signature"][0]
    ),
    "duplicate symbol": lambda d: d["symbols"].__setitem__(1, d["symbols"][0]),
    "action count": lambda d: d["task"]["actions"]["pre"].pop(),
    "cost type": _set("task.actions.cost.0", "15"),
    "negative cost": _set("task.actions.cost.0", -1),
    "symbols type": _set("symbols", {"a": 1}),
    "symbol type": _set("symbols.0", 7),
    "task type": _set("task", []),
    "task name": _set("task.name", None),
    "missing actions": _drop("task.actions"),
    "missing static facts": _drop("task.static_facts"),
    "predicate arities": lambda d: d["task"]["predicate_arities"].append(1),
    "atom count": _set("mutexes.atom_count", 3),
    "group atoms": _set("mutexes.group_atoms.0", [10**6]),
    "group proved": _set("mutexes.group_proved.0", 1),
    "group lengths": lambda d: d["mutexes"]["group_patterns"].append("x"),
    "empty nogood": _set("mutexes.nogoods", [[]]),
    "title": _set("title", 3),
    "fewshot": _set("fewshot", ["x"]),
    "infinity": _set("mutexes.atom_count", float("inf")),
}


@pytest.mark.parametrize("mutation", MUTATIONS)
def test_malformed_entries_are_refused(mutation: str, cache_folder: Path) -> None:
    _load("robowaiter")
    path = _entry_file(cache_folder, "robowaiter")
    key = json.loads(path.read_bytes())["key"]
    cache.decode(path.read_bytes(), "robowaiter", key)  # the unchanged entry is fine
    document = json.loads(path.read_bytes())
    MUTATIONS[mutation](document)
    data = json.dumps(document).encode()
    with pytest.raises(cache.CacheFormatError):
        cache.decode(data, "robowaiter", key)


@pytest.mark.parametrize(
    "data",
    [b"", b"\xff\xfe\x00garbage", b"[1, 2]", b"null", b"[" * 100_000, b'{"format": NaN}', b"{}" * 3],
    ids=["empty", "binary", "list", "null", "deep", "nan", "trailing"],
)
def test_unreadable_bytes_are_refused(data: bytes) -> None:
    with pytest.raises(ValueError, match=r"\w"):  # CacheFormatError, bad JSON or bad UTF-8
        cache.decode(data, "robowaiter", "0" * 64)
    assert gc.isenabled()  # decoding pauses the cyclic garbage collector, and always restarts it


# ------------------------------------------------------------------------------ unsafe folders
def test_folder_writable_by_others_is_not_used(
    cache_folder: Path, monkeypatch: pytest.MonkeyPatch, caplog: pytest.LogCaptureFixture
) -> None:
    fresh = _uncached("robowaiter", monkeypatch)
    cache_folder.mkdir()
    cache_folder.chmod(0o777)
    caplog.set_level(logging.WARNING)
    assert _fields(_load("robowaiter")) == _fields(fresh)
    _load("robothow-small")
    assert not list(cache_folder.iterdir())
    warnings = _warnings(caplog)
    assert len(warnings) == 1, warnings
    assert "other users may write to it" in warnings[0]


@pytest.mark.skipif(not hasattr(os, "geteuid") or os.geteuid() != 0, reason="needs root to give a folder away")
def test_folder_of_another_user_is_not_used(cache_folder: Path, caplog: pytest.LogCaptureFixture) -> None:
    cache_folder.mkdir(mode=0o700)
    os.chown(cache_folder, 4321, 4321)
    caplog.set_level(logging.WARNING)
    _load("robowaiter")
    assert not list(cache_folder.iterdir())
    assert any("belongs to user id 4321" in w for w in _warnings(caplog))
