"""Scenarios: a grounded task with its mutexes and metadata, from the shipped data or a user's PDDL.

The four published scenarios (``robowaiter``, ``virtualhome``, ``robothow-small``, ``robothow``) are
PDDL files inside the package, described by ``data/scenarios.toml``.
"""

from __future__ import annotations

import dataclasses
import functools
import hashlib
import logging
import os
import pickle
import sys
import time
import tomllib
from collections.abc import Iterable, Mapping, Sequence
from dataclasses import dataclass
from importlib import resources
from pathlib import Path
from typing import Any

from hbtp import __version__
from hbtp.domains.grounding import ground
from hbtp.domains.lifted import Problem
from hbtp.domains.mutex import Mutexes, infer_mutexes
from hbtp.domains.pddl_reader import read_domain_file, read_problem_file
from hbtp.errors import InputError
from hbtp.logic.task import GroundTask

log = logging.getLogger(__name__)

DATA = resources.files("hbtp.domains") / "data"


@dataclass(frozen=True)
class Scenario:
    """A planning scenario: the grounded task, its mutexes, and where it came from."""

    name: str
    title: str
    description: str
    task: GroundTask
    mutexes: Mutexes
    domain_file: Path
    problem_file: Path
    fewshot: str | None = None
    test_set: str | None = None
    load_seconds: float = 0.0

    def summary(self) -> dict[str, Any]:
        """The figures ``hbtp scenarios`` prints."""
        return {
            "name": self.name,
            "title": self.title,
            "actions": len(self.task.actions),
            "action_predicates": len(self.task.action_predicates),
            "objects": len(self.task.objects),
            "s0": len(self.task.initial_state),
            "atoms": len(self.task.atoms),
            "mutex_groups": len(self.mutexes.groups),
            "declared_nogoods": len(self.mutexes.nogoods),
        }


@functools.cache
def _manifest() -> dict[str, dict[str, Any]]:
    with (DATA / "scenarios.toml").open("rb") as handle:
        return tomllib.load(handle)


def manifest_entry(name: str) -> dict[str, Any]:
    """A shipped scenario's entry in ``scenarios.toml``."""
    if name not in _manifest():
        raise InputError(f"unknown scenario {name!r}; choose one of: {', '.join(scenario_names())}")
    return dict(_manifest()[name])


def scenario_names() -> tuple[str, ...]:
    """Names of the shipped scenarios, in the paper's order."""
    return tuple(_manifest())


def load_scenario(name: str) -> Scenario:
    """Load (parse, ground, infer mutexes) a shipped scenario; cached per process and on disk
    (see :func:`cache_dir`; the cache is keyed by the data files' content and the hbtp version)."""
    if name not in _manifest():
        raise InputError(f"unknown scenario {name!r}; choose one of: {', '.join(scenario_names())}")
    return _load_shipped(name)


@functools.cache
def _load_shipped(name: str) -> Scenario:
    entry = _manifest()[name]
    with resources.as_file(DATA) as folder:
        cache = _cache_file(name, folder, entry)
        cached = _read_cache(cache)
        if cached is not None:
            return cached
        mutex = entry.get("mutex", {})
        scenario = load_pddl_scenario(
            folder / entry["domain"],
            folder / entry["problem"],
            name=name,
            title=entry.get("title", name),
            description=entry.get("description", ""),
            keep_fluent=entry.get("keep_fluent", ()),
            objects=entry.get("objects", ()),
            mutex_groups=mutex.get("groups", ()),
            mutex_nogoods=mutex.get("nogoods", ()),
            fewshot=entry.get("fewshot"),
            test_set=entry.get("test"),
        )
        _write_cache(cache, scenario)
        return scenario


# ----------------------------------------------------------------- disk cache
def cache_dir() -> Path | None:
    """Where loaded scenarios are cached: ``$HBTP_CACHE_DIR``, else ``$XDG_CACHE_HOME/hbtp`` or
    ``~/.cache/hbtp``; ``None`` when ``HBTP_NO_CACHE`` is set."""
    if os.environ.get("HBTP_NO_CACHE"):
        return None
    explicit = os.environ.get("HBTP_CACHE_DIR")
    if explicit:
        return Path(explicit)
    base = os.environ.get("XDG_CACHE_HOME") or str(Path.home() / ".cache")
    return Path(base) / "hbtp"


def _cache_file(name: str, folder: Path, entry: dict[str, Any]) -> Path | None:
    """A cache file named by the hash of everything the scenario is built from."""
    directory = cache_dir()
    if directory is None:
        return None
    digest = hashlib.sha256(f"{__version__}|{sys.version_info[:2]}|{name}|{sorted(entry.items())!r}".encode())
    for file_name in (entry["domain"], entry["problem"], "scenarios.toml"):
        digest.update((folder / file_name).read_bytes())
    # The code that builds a scenario is part of the key too, so a changed grounder never reads a
    # stale cache.
    package = Path(__file__).resolve().parents[1]
    for source in sorted([*package.glob("domains/*.py"), *package.glob("logic/*.py")]):
        digest.update(source.read_bytes())
    return directory / f"{name}-{digest.hexdigest()[:16]}.pickle"


def _read_cache(path: Path | None) -> Scenario | None:
    if path is None or not path.exists():
        return None
    started = time.perf_counter()
    try:
        with path.open("rb") as handle:
            scenario = pickle.load(handle)
    except Exception as error:  # a stale or broken cache file is rebuilt, never fatal
        log.warning("ignoring unreadable scenario cache %s: %s", path, error)
        return None
    if not isinstance(scenario, Scenario):
        return None
    return dataclasses.replace(scenario, load_seconds=time.perf_counter() - started)


def _write_cache(path: Path | None, scenario: Scenario) -> None:
    if path is None:
        return
    try:
        path.parent.mkdir(parents=True, exist_ok=True)
        temporary = path.with_suffix(f".{os.getpid()}.tmp")
        with temporary.open("wb") as handle:
            pickle.dump(scenario, handle, protocol=pickle.HIGHEST_PROTOCOL)
        os.replace(temporary, path)
    except OSError as error:
        log.info("could not write the scenario cache %s: %s", path, error)


def load_pddl_scenario(
    domain_file: str | Path,
    problem_file: str | Path,
    *,
    name: str | None = None,
    title: str | None = None,
    description: str = "",
    keep_fluent: Iterable[str] = (),
    objects: Iterable[str] = (),
    mutex_groups: Sequence[Sequence[str]] = (),
    mutex_nogoods: Sequence[Sequence[str]] = (),
    fewshot: str | None = None,
    test_set: str | None = None,
    problem: Problem | None = None,
) -> Scenario:
    """Load a scenario from a user's PDDL domain and problem files (``problem``, when given, replaces
    the problem file's content, e.g. a generated larger problem)."""
    started = time.perf_counter()
    domain_path, problem_path = Path(domain_file), Path(problem_file)
    domain = read_domain_file(domain_path)
    if problem is None:
        problem = read_problem_file(problem_path, domain)
    task_name = name or problem.name
    task = ground(domain, problem, keep_fluent=keep_fluent, object_categories=objects, name=task_name)
    mutexes = infer_mutexes(task, mutex_groups, mutex_nogoods)
    elapsed = time.perf_counter() - started
    log.info("loaded %s: %d actions in %.3f s", task_name, len(task.actions), elapsed)
    return Scenario(
        name=task_name,
        title=title or task_name,
        description=description,
        task=task,
        mutexes=mutexes,
        domain_file=domain_path,
        problem_file=problem_path,
        fewshot=fewshot,
        test_set=test_set,
        load_seconds=elapsed,
    )


def read_mutex_file(path: str | Path) -> Mapping[str, Sequence[Sequence[str]]]:
    """Read declared mutexes (``groups = [[...]]``, ``nogoods = [[...]]``) from a TOML file."""
    path = Path(path)
    try:
        with path.open("rb") as handle:
            data = tomllib.load(handle)
    except OSError as error:
        raise InputError(f"{path}: cannot read mutex file: {error.strerror or error}") from None
    except tomllib.TOMLDecodeError as error:
        raise InputError(f"{path}: not valid TOML: {error}") from None
    unknown = set(data) - {"groups", "nogoods"}
    if unknown:
        raise InputError(f"{path}: unknown key(s) {', '.join(sorted(unknown))} (expected groups, nogoods)")
    return {"groups": data.get("groups", []), "nogoods": data.get("nogoods", [])}
