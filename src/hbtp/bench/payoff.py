"""When does the LLM pay? End-to-end time to a verified tree, LLM-guided against LLM-free.

Every run plans one task in one world with one configuration and measures what a user waits for:

- ``load_s``: building or loading the world. A shipped scenario comes from hbtp's disk cache (the
  first load in a process; ``load_kind`` ``"shipped (disk cache)"``); RobotHow grown with
  :mod:`hbtp.domains.scale` is parsed, cloned, grounded and analysed for mutexes every time
  (``"scaled (built)"``: scaled worlds are not cached). Both kinds of configuration need the whole
  grounded task (the LLM-guided loop for its prompt vocabulary, its grammar check and its fallback),
  so the load is the same for both and counts for both;
- ``model_s``: the LLM's own time (``local``, ``openai``); zero for ``oracle`` and ``noisy-oracle``,
  whose "model" is an optimal planner (its time is not a model's and is left out: the oracles are
  the upper bound of what guidance can buy);
- ``planning_s``: everything else of the planning call: for the LLM-guided loop its wall time minus
  the backend's time (prompts, grammar checks, pruning, every round's search, the fallback), for
  the LLM-free planners the search with the landmark heuristic (building the heuristic included);
- ``verify_s``: :func:`hbtp.bt.verify.verify` from the initial state, then a run of the tree in the
  simulator, which must reach the goal (``verified``).

``total_s`` is their sum (one task per load, as ``hbtp plan`` pays it) and ``solve_s`` the same
without the load (a process that keeps the world loaded). Configurations: ``obtea+lm`` and
``hbtp-s+lm`` (no hints; per task the faster verified one is "best LLM-free") and ``hbtp:<backend>``
(:func:`hbtp.pipeline.run_hbtp`: HBTP-S in the LLM's pruned space, feedback, full-space fallback).
Axes: ``set`` (the first tasks of the Table II test sets, in order of their mean |p*|), ``level``
(RobotHow goals generated at a difficulty level by :mod:`hbtp.planning.generate`, seed 0: easy,
medium, hard, and beyond, expert) and ``size`` (the first valid Table I tasks in RobotHow grown
``x`` times).
"""

from __future__ import annotations

import functools
import math
import time
from collections.abc import Sequence
from dataclasses import dataclass, field, replace
from pathlib import Path
from typing import Any

from hbtp.bench.paper import paper_options, paper_scaled, paper_scenario
from hbtp.bench.plots import plot_payoff
from hbtp.bench.report import PAYOFF_PHASES, payoff_section, write_report
from hbtp.bench.results import JsonObject, ResultsFile, Row, median, optional, write_json
from hbtp.bench.runner import DEFAULT_EXECUTION, Execution, Work, run_work
from hbtp.bench.table2 import BackendRecipe
from hbtp.bt import tree_of
from hbtp.bt.simulate import simulate
from hbtp.bt.verify import verify
from hbtp.datasets import load_dataset, validate_records
from hbtp.datasets.records import Record
from hbtp.domains.cache import cache_dir
from hbtp.domains.pruned import PrunedWorld
from hbtp.domains.scale import clone_objects
from hbtp.domains.scenarios import Scenario
from hbtp.errors import InputError
from hbtp.llm.backend import Backend
from hbtp.llm.backends.registry import BackendOptions, LlmSpec
from hbtp.llm.pool import example_pool
from hbtp.logic.task import Goal, GroundTask
from hbtp.memory import peak_resident_mb, resident_mb
from hbtp.pipeline import LoopOptions, run_hbtp
from hbtp.planning import Limits, PlanResult, plan, release_search_memory
from hbtp.planning.generate import LEVELS, Sampling, generate_records
from hbtp.planning.heuristic_names import HeuristicName

SIZE_DATASET = "table1_robothow_100"
#: The Table II sets in order of difficulty (mean |p*| 2.46, 4.54, 6.50, 8.70).
SETS = ("robowaiter", "robothow-small", "virtualhome", "robothow")
LLM_FREE = ("obtea+lm", "hbtp-s+lm")
#: The prefix of a configuration that prunes the world before grounding it.
PRUNED = "hbtp-pruned:"


@dataclass(frozen=True)
class PayoffConfig:
    backends: tuple[str, ...] = ("oracle", "noisy-oracle")
    sets: tuple[str, ...] = SETS
    scales: tuple[float, ...] = (1.0, 3.0, 6.0)
    #: Generated RobotHow tasks (:mod:`hbtp.planning.generate`) of these levels, seed 0.
    levels: tuple[str, ...] = ("easy", "medium", "hard")
    tasks: int = 5
    #: Also run each backend with the world pruned before it is grounded (``hbtp-pruned:<backend>``:
    #: the loop grounds only the hints' space, and the whole world only for its fallback).
    pruned: bool = False
    #: Seconds for an LLM-free search, and for the loop's fallback.
    time_limit: float = 60.0
    loop: LoopOptions = field(default_factory=LoopOptions)

    def __post_init__(self) -> None:
        if not self.backends:
            raise InputError("give at least one LLM backend")
        unknown = [level for level in self.levels if level not in LEVELS]
        if unknown:
            raise InputError(f"unknown level(s) {', '.join(unknown)}; choose from {', '.join(LEVELS)}")
        if any(not s >= 1.0 for s in self.scales):
            raise InputError("every scale must be at least 1")
        if not (self.time_limit > 0 and math.isfinite(self.time_limit)):
            raise InputError(f"the time limit must be a positive number of seconds, not {self.time_limit}")

    @property
    def configs(self) -> tuple[str, ...]:
        pruned = tuple(f"{PRUNED}{b}" for b in self.backends) if self.pruned else ()
        return (*LLM_FREE, *(f"hbtp:{b}" for b in self.backends), *pruned)


@dataclass(frozen=True, kw_only=True)
class PayoffRow(Row):
    """One task in one world with one configuration. The HBTP loop's rows also have ``backend_s``,
    ``backend_setup_s``, ``outcome`` and ``rounds``, those of a world pruned before grounding
    ``grounded_whole``. A killed run's row has the fields known before it ran, with ``status`` and
    ``time_s``."""

    KEY = ("axis", "cell", "task", "config")

    axis: str
    cell: str
    scale: float
    scenario: str
    task: str
    p_star: int
    config: str
    status: str
    solved: bool
    cost: int | None = None
    actions: int | None = optional()
    load_kind: str | None = optional()
    verified: bool | None = optional()
    explored: int | None = optional()
    load_s: float | None = optional()
    model_s: float | None = optional()
    planning_s: float | None = optional()
    verify_s: float | None = optional()
    solve_s: float | None = optional()
    total_s: float | None = optional()
    backend_s: float | None = optional()
    backend_setup_s: float | None = optional()
    outcome: str | None = optional()
    rounds: int | None = optional()
    grounded_whole: bool | None = optional()
    resident_mb: int | None = optional()
    #: The worker process's peak resident memory so far: the run's own with ``--fresh-workers``.
    peak_mb: int | None = optional()
    time_s: float | None = optional()

    @property
    def phases(self) -> dict[str, float | None]:
        """The seconds of each of :data:`~hbtp.bench.report.PAYOFF_PHASES`."""
        return {
            "total_s": self.total_s,
            "solve_s": self.solve_s,
            "load_s": self.load_s,
            "model_s": self.model_s,
            "planning_s": self.planning_s,
            "verify_s": self.verify_s,
        }


def _guided(config: str) -> bool:
    return config not in LLM_FREE


@dataclass(frozen=True)
class World:
    """Where a cell's tasks are planned: a shipped scenario, or RobotHow grown ``scale`` times."""

    axis: str
    cell: str
    scenario: str
    scale: float = 1.0


@dataclass(frozen=True)
class PayoffRun:
    """One task in one world with one configuration (the spec a worker runs)."""

    world: World
    record: Record
    config: str
    recipe: BackendRecipe | None
    loop: LoopOptions
    time_limit: float


@functools.lru_cache(maxsize=1)
def _world(scenario: str, scale: float) -> tuple[Scenario, float, str]:
    """The world, the seconds it took to load, and how it was loaded (kept while runs use it)."""
    if math.isclose(scale, 1.0):
        loaded = paper_scenario(scenario)
        return loaded, loaded.load_seconds, "shipped (disk cache)" if cache_dir() else "shipped (built: no cache)"
    started = time.perf_counter()
    loaded = paper_scaled(scenario, scale)
    return loaded, time.perf_counter() - started, "scaled (built)"


@functools.lru_cache(maxsize=1)
def _names_of_world(scenario: str, scale: float) -> tuple[PrunedWorld, float]:
    """The world pruned before grounding (its action names listed, nothing grounded) and the seconds
    that took: the shipped PDDL read, grown ``scale`` times."""
    base = paper_scenario(scenario)
    started = time.perf_counter()
    options, parsed = paper_options(scenario), base.pddl
    if not math.isclose(scale, 1.0):
        options = replace(options, name=f"{scenario}-x{scale:g}")
        parsed = replace(parsed, problem=clone_objects(parsed.problem, scale))
    world = PrunedWorld.load(base.domain_file, base.problem_file, options, parsed=parsed)
    return world, time.perf_counter() - started


@functools.lru_cache(maxsize=8)
def _pool(scenario: str) -> list[Record]:
    """Demonstrations: the shipped scenario's pool (valid in its grown worlds: clones add, never change)."""
    return example_pool(paper_scenario(scenario))


#: The backend of the world being run, with the seconds it took to build (a local model's load: it is
#: loaded before the first task, and its time is ``backend_setup_s``, not ``model_s``).
_BACKEND: dict[tuple[BackendRecipe, str], tuple[Backend, float]] = {}


def _backend(recipe: BackendRecipe, scenario: Scenario) -> tuple[Backend, float]:
    key = (recipe, scenario.name)
    if key not in _BACKEND:
        close_backend()
        started = time.perf_counter()
        backend = recipe.make(scenario, 0)
        load = getattr(backend, "load", None)
        if callable(load):  # a local model loads here, not in the first task's time
            load()
        _BACKEND[key] = (backend, time.perf_counter() - started)
    return _BACKEND[key]


def close_backend() -> None:
    while _BACKEND:
        _BACKEND.popitem()[1][0].close()


def verified_tree(result: PlanResult, task: GroundTask, goal: Goal) -> bool:
    """The full tree of ``result`` passes the static verifier from s0 and, run, reaches the goal."""
    if not result.solved:
        return False
    tree = tree_of(result)
    check = verify(tree, task, goal, from_initial_state=True)
    return check.ok and simulate(tree, task).reached(goal)


@dataclass(frozen=True)
class Planned:
    """A planning call: its result, its seconds without the model's, and the model's; for the HBTP
    loop also the backend's seconds (an oracle's included), its setup's, the outcome and the rounds."""

    result: PlanResult
    planning_s: float
    model_s: float
    backend_s: float | None = None
    backend_setup_s: float | None = None
    outcome: str | None = None
    rounds: int | None = None


@dataclass(frozen=True)
class Loaded:
    """Where a run planned: the scenario of its tree and its goal, the world's grounded (or listed)
    actions, the seconds the world took to load and how it was loaded; for a world pruned before
    grounding, whether the whole world was grounded after all (the fallback)."""

    scenario: Scenario
    goal: Goal
    actions: int
    load_s: float
    load_kind: str
    grounded_whole: bool | None = None


def _plan(run: PayoffRun, scenario: Scenario, goal: Goal) -> Planned:
    """Plan with the run's configuration."""
    started = time.perf_counter()
    if run.recipe is None:
        planner = run.config.removesuffix("+lm")
        limits = Limits(time_s=run.time_limit)
        result = plan(scenario.task, goal, planner, mutexes=scenario.mutexes, heuristic=HeuristicName.LM, limits=limits)
        return Planned(result, planning_s=time.perf_counter() - started, model_s=0.0)
    return _guide(run, scenario, scenario, goal)[0]


def _guide(
    run: PayoffRun, world: Scenario | PrunedWorld, backend_world: Scenario, goal: Goal | str
) -> tuple[Planned, Scenario]:
    """The HBTP loop in ``world``: the planning call, and the scenario of its tree."""
    assert run.recipe is not None
    backend, setup = _backend(run.recipe, backend_world)
    started = time.perf_counter()
    loop = run_hbtp(world, goal, backend, _pool(run.world.scenario), run.loop)
    wall = time.perf_counter() - started
    planned = Planned(
        loop.result,
        planning_s=wall - loop.llm_seconds,
        model_s=0.0 if run.recipe.answers_by_planning else loop.llm_seconds,
        backend_s=loop.llm_seconds,
        backend_setup_s=setup,
        outcome=loop.outcome.label,
        rounds=len(loop.rounds),
    )
    return planned, loop.scenario


def _run_pruned(run: PayoffRun) -> tuple[Planned, Loaded]:
    """The loop in the world pruned before grounding, with none of an earlier task's groundings kept."""
    listed, load = _names_of_world(run.world.scenario, run.world.scale)
    world = replace(listed, _whole=None, _parts={})
    assert run.recipe is not None
    # An oracle answers from an optimal plan in the whole world (its time is not counted); a model
    # needs no world at all.
    oracle = run.recipe.answers_by_planning
    if not oracle:  # the grounded world of the other configurations would only take memory here
        _world.cache_clear()
    backend_world = _world(run.world.scenario, run.world.scale)[0] if oracle else world.part(frozenset(), frozenset())
    planned, scenario = _guide(run, world, backend_world, run.record.goal)
    goal = scenario.task.resolve_goal(run.record.goal)
    kind = "names listed, pruned before grounding"
    return planned, Loaded(scenario, goal, len(world.names.actions), load, kind, grounded_whole=world.grounded)


def _run_whole(run: PayoffRun) -> tuple[Planned, Loaded]:
    """Plan in the grounded world (loaded from the cache, or grown and built)."""
    scenario, load, kind = _world(run.world.scenario, run.world.scale)
    goal = scenario.task.resolve_goal(run.record.goal)
    planned = _plan(run, scenario, goal)
    return planned, Loaded(scenario, goal, len(scenario.task.actions), load, kind)


def run_one(run: PayoffRun) -> PayoffRow:
    """One task, one configuration: every phase's seconds and whether the tree is verified."""
    planned, loaded = _run_pruned(run) if run.config.startswith(PRUNED) else _run_whole(run)
    started = time.perf_counter()
    verified = verified_tree(planned.result, loaded.scenario.task, loaded.goal)
    verify = time.perf_counter() - started
    release_search_memory()
    solve = planned.model_s + planned.planning_s + verify
    world, record, result = run.world, run.record, planned.result
    return PayoffRow(
        axis=world.axis,
        cell=world.cell,
        scale=world.scale,
        scenario=world.scenario,
        task=record.id,
        p_star=len(record.optimal_actions),
        config=run.config,
        actions=loaded.actions,
        planning_s=round(planned.planning_s, 6),
        model_s=round(planned.model_s, 6),
        backend_s=_round(planned.backend_s),
        backend_setup_s=_round(planned.backend_setup_s),
        outcome=planned.outcome,
        rounds=planned.rounds,
        load_s=round(loaded.load_s, 6),
        grounded_whole=loaded.grounded_whole,
        verify_s=round(verify, 6),
        load_kind=loaded.load_kind,
        status=result.status.value,
        solved=result.solved,
        verified=verified,
        explored=result.stats.explored,
        cost=result.cost,
        solve_s=round(solve, 6),
        total_s=round(solve + loaded.load_s, 6),
        resident_mb=round(resident_mb()),
        peak_mb=round(peak_resident_mb()),
    )


def _round(seconds: float | None) -> float | None:
    return None if seconds is None else round(seconds, 6)


def _known(world: World, record: Record, config: str) -> JsonObject:
    """The JSON fields of a run's row known before it runs."""
    return {
        "axis": world.axis,
        "cell": world.cell,
        "scale": world.scale,
        "scenario": world.scenario,
        "task": record.id,
        "p_star": len(record.optimal_actions),
        "config": config,
    }


def worlds(config: PayoffConfig) -> list[tuple[World, list[Record]]]:
    """Each cell's world and tasks: the Table II sets, then RobotHow at every scale."""
    cells = []
    for world in _cells_of(config):
        if world.axis == "set":
            test_set = paper_scenario(world.scenario).test_set
            if test_set is None:
                raise InputError(f"scenario {world.scenario} has no test set")
            cells.append((world, load_dataset(test_set)[: config.tasks]))
        elif world.axis == "level":
            cells.append((world, _generated(world.cell, config.tasks)))
        else:
            cells.append((world, _size_tasks(config.tasks)))
    return cells


def _generated(level: str, count: int) -> list[Record]:
    """``count`` RobotHow goals of ``level``, sampled with seed 0 and labelled with optimal plans."""
    base = paper_scenario("robothow")
    return generate_records(base.task, level, count, Sampling(seed=0), base.mutexes)


@functools.lru_cache(maxsize=4)
def _size_tasks(count: int) -> list[Record]:
    """The first ``count`` Table I tasks that are valid in RobotHow."""
    records = load_dataset(SIZE_DATASET)
    invalid = set(validate_records(records, paper_scenario("robothow").task).invalid_ids)
    return [r for r in records if r.id not in invalid][:count]


def kill_after(config: PayoffConfig, llm_timeout: float) -> float:
    """A generous hard limit for one run: a scaled world's build, every LLM call and round, the
    fallback (or the LLM-free search), and slack."""
    loop = config.loop
    rounds = loop.feedback_rounds + 1
    llm = rounds * (loop.grammar_retries + 1) * llm_timeout
    return 600.0 + llm + rounds * loop.round_time_limit + 2 * config.time_limit


def run_payoff(
    config: PayoffConfig, options: BackendOptions, out: Path, execution: Execution = DEFAULT_EXECUTION
) -> dict[str, Any]:
    """Run (or resume) the payoff benchmark into ``out``, the backends built with ``options``."""
    loop = replace(
        config.loop,
        fallback_time_limit=config.time_limit,
        prompt=replace(config.loop.prompt, exclude_same_goal=True),
    )
    recipes = {b: BackendRecipe(LlmSpec.parse(b), options) for b in config.backends}
    work = [
        Work(
            (world.axis, world.cell, record.id, name),
            PayoffRun(world, record, name, recipes.get(name.partition(":")[2]), loop, config.time_limit),
            _known(world, record, name),
            stage=f"{world.cell} {name}",
        )
        for world, records in worlds(config)
        for name in config.configs
        for record in records
    ]
    results = ResultsFile(out / "results.jsonl", PayoffRow)
    try:
        limit = kill_after(config, options.timeout)
        run_work(run_one, work, results, execution, kill_after=limit, description="payoff")
    finally:
        close_backend()
    summary = summarise(list(results.ordered(w.key for w in work)), config)
    write_json(out / "summary.json", summary)
    plot_payoff(summary, out / "payoff.png")
    write_report(out / "report.md", "When does the LLM pay?", [payoff_section(summary)])
    return summary


BEST_FREE = "best LLM-free"


def _times(row: PayoffRow | None) -> tuple[float, float]:
    """The row's total and solve seconds, infinite when it did not produce a verified tree."""
    if row is None or not row.verified or row.total_s is None or row.solve_s is None:
        return math.inf, math.inf
    return float(row.total_s), float(row.solve_s)


def _stats(rows: Sequence[PayoffRow]) -> dict[str, Any]:
    good = [r for r in rows if r.verified]
    stats: dict[str, Any] = {"tasks": len(rows), "verified": len(good)}
    phases = [r.phases for r in good]
    stats.update({f"median_{phase}": median(p[phase] for p in phases) for phase in PAYOFF_PHASES})
    peaks = [r.peak_mb for r in rows if r.peak_mb is not None]
    stats["max_peak_mb"] = max(peaks) if peaks else None
    return stats


#: Per task, its rows by configuration.
Tasks = dict[str, dict[str, PayoffRow]]


def _best_free(tasks: Tasks) -> list[PayoffRow]:
    """Per task, the LLM-free row with the shortest total time (the first one if none is verified)."""
    best = []
    for by_config in tasks.values():
        free = [by_config[name] for name in LLM_FREE if name in by_config]
        if free:
            best.append(min(free, key=lambda r: _times(r)[0]))
    return best


def _against(guided: str, tasks: Tasks) -> dict[str, Any]:
    """How an LLM-guided configuration fares against the best LLM-free one, task by task."""
    pairs = []
    for by_config in tasks.values():
        free = [_times(by_config.get(name)) for name in LLM_FREE]
        total, solve = _times(by_config.get(guided))
        pairs.append((total, min(t for t, _ in free), solve, min(s for _, s in free)))
    finite = [(g, f, gs, fs) for g, f, gs, fs in pairs if math.isfinite(g) and math.isfinite(f) and f > 0 and fs > 0]
    return {
        "wins_total": sum(g < f for g, f, _, _ in pairs),
        "wins_solve": sum(gs < fs for _, _, gs, fs in pairs),
        "median_ratio_total": median([g / f for g, f, _, _ in finite]),
        "median_ratio_solve": median([gs / fs for _, _, gs, fs in finite]),
    }


def _cell(rows: Sequence[PayoffRow], config: PayoffConfig) -> dict[str, Any]:
    tasks: Tasks = {}
    for row in rows:
        tasks.setdefault(row.task, {})[row.config] = row
    first = rows[0]
    configs = {name: _stats([r for r in rows if r.config == name]) for name in config.configs}
    configs[BEST_FREE] = _stats(_best_free(tasks))
    return {
        "axis": first.axis,
        "cell": first.cell,
        "scale": first.scale,
        "scenario": first.scenario,
        "actions": next((r.actions for r in rows if r.actions is not None), None),
        "load_kind": next((r.load_kind for r in rows if r.load_kind is not None), None),
        "tasks": len(tasks),
        "median_p_star": median(r.p_star for r in rows),
        "configs": configs,
        "against": {name: _against(name, tasks) for name in config.configs if _guided(name)},
    }


def crossings(cells: Sequence[dict[str, Any]], guided: str, measure: str) -> dict[str, Any]:
    """Along one axis: the cells where ``guided``'s median ``measure`` beats the best LLM-free one,
    and the pairs of neighbouring cells between which the order flips (where the curves cross)."""
    faster: list[str] = []
    flips: list[str] = []
    previous: tuple[str, bool] | None = None
    for cell in cells:
        mine = cell["configs"].get(guided, {}).get(f"median_{measure}")
        free = cell["configs"][BEST_FREE].get(f"median_{measure}")
        if mine is None or free is None:
            continue
        wins = mine < free
        if wins:
            faster.append(cell["cell"])
        if previous is not None and previous[1] != wins:
            flips.append(f"{previous[0]} → {cell['cell']}")
        previous = (cell["cell"], wins)
    return {"faster_in": faster, "crosses": flips}


def summarise(rows: Sequence[PayoffRow], config: PayoffConfig) -> dict[str, Any]:
    cells = []
    for world in _cells_of(config):
        mine = [r for r in rows if (r.axis, r.cell) == (world.axis, world.cell)]
        if mine:
            cells.append(_cell(mine, config))
    guided = [name for name in config.configs if _guided(name)]
    return {
        "config": {
            "backends": list(config.backends),
            "sets": list(config.sets),
            "scales": list(config.scales),
            "levels": list(config.levels),
            "tasks": config.tasks,
            "time_limit": config.time_limit,
            "round_time_limit": config.loop.round_time_limit,
            "feedback_rounds": config.loop.feedback_rounds,
            "pruned": config.pruned,
        },
        "runs": len(rows),
        "unverified": sum(not r.verified for r in rows),
        "cells": cells,
        "crossings": {
            axis: {
                name: {m: crossings([c for c in cells if c["axis"] == axis], name, m) for m in ("total_s", "solve_s")}
                for name in guided
            }
            for axis in ("set", "level", "size")
        },
    }


def _cells_of(config: PayoffConfig) -> list[World]:
    """The cells in axis order: the sets, then the sizes."""
    cells = [World("set", name, name) for name in config.sets]
    cells += [World("level", level, "robothow") for level in config.levels]
    return cells + [World("size", f"x{s:g}", "robothow", s) for s in config.scales]
