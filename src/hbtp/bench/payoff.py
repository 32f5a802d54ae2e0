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
from hbtp.bench.report import _table, write_report
from hbtp.bench.results import ResultsFile, median, write_json
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
from hbtp.llm.backends.registry import BackendOptions
from hbtp.llm.pool import example_pool
from hbtp.logic.task import Goal, GroundTask
from hbtp.memory import resident_mb
from hbtp.pipeline import LoopOptions, run_hbtp
from hbtp.planning import Limits, PlanResult, plan, release_search_memory
from hbtp.planning.generate import LEVELS, Sampling, generate_records

SIZE_DATASET = "table1_robothow_100"
#: The Table II sets in order of difficulty (mean |p*| 2.46, 4.54, 6.50, 8.70).
SETS = ("robowaiter", "robothow-small", "virtualhome", "robothow")
LLM_FREE = ("obtea+lm", "hbtp-s+lm")
#: Backends whose answers come from a planner, not a model: their time is not model time.
ORACLES = ("oracle", "noisy-oracle")
KEY = ("axis", "cell", "task", "config")
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


def _plan(run: PayoffRun, scenario: Scenario, goal: Goal) -> tuple[PlanResult, dict[str, Any]]:
    """Plan with the run's configuration: the result and its time and LLM fields."""
    started = time.perf_counter()
    if run.recipe is None:
        planner = run.config.removesuffix("+lm")
        limits = Limits(time_s=run.time_limit)
        result = plan(scenario.task, goal, planner, mutexes=scenario.mutexes, heuristic="lm", limits=limits)
        return result, {"planning_s": time.perf_counter() - started, "model_s": 0.0}
    result, fields, _ = _guide(run, scenario, scenario, goal)
    return result, fields


def _guide(
    run: PayoffRun, world: Scenario | PrunedWorld, backend_world: Scenario, goal: Goal | str
) -> tuple[PlanResult, dict[str, Any], Scenario]:
    """The HBTP loop in ``world``: the result, its time and LLM fields, and the scenario of its tree."""
    assert run.recipe is not None
    backend, setup = _backend(run.recipe, backend_world)
    started = time.perf_counter()
    loop = run_hbtp(world, goal, backend, _pool(run.world.scenario), run.loop)
    wall = time.perf_counter() - started
    model = 0.0 if run.recipe.llm in ORACLES else loop.llm_seconds
    fields = {
        "planning_s": wall - loop.llm_seconds,
        "model_s": model,
        "backend_s": loop.llm_seconds,
        "backend_setup_s": setup,
        "outcome": loop.outcome.label,
        "rounds": len(loop.rounds),
    }
    return loop.result, fields, loop.scenario


def _run_pruned(run: PayoffRun) -> tuple[PlanResult, dict[str, Any], Scenario, Goal, int]:
    """The loop in the world pruned before grounding, with none of an earlier task's groundings kept."""
    listed, load = _names_of_world(run.world.scenario, run.world.scale)
    world = replace(listed, _whole=None, _parts={})
    assert run.recipe is not None
    # An oracle answers from an optimal plan in the whole world (its time is not counted); a model
    # needs no world at all.
    oracle = run.recipe.llm in ORACLES
    if not oracle:  # the grounded world of the other configurations would only take memory here
        _world.cache_clear()
    backend_world = _world(run.world.scenario, run.world.scale)[0] if oracle else world.part(frozenset(), frozenset())
    result, fields, scenario = _guide(run, world, backend_world, run.record.goal)
    fields.update(load_s=load, grounded_whole=world.grounded)
    return result, fields, scenario, scenario.task.resolve_goal(run.record.goal), len(world.names.actions)


def run_one(run: PayoffRun) -> dict[str, Any]:
    """One task, one configuration: every phase's seconds and whether the tree is verified."""
    if run.config.startswith(PRUNED):
        result, fields, scenario, goal, actions = _run_pruned(run)
        load_kind = "names listed, pruned before grounding"
    else:
        scenario, load, load_kind = _world(run.world.scenario, run.world.scale)
        goal = scenario.task.resolve_goal(run.record.goal)
        result, fields = _plan(run, scenario, goal)
        fields["load_s"] = load
        actions = len(scenario.task.actions)
    load = fields["load_s"]
    started = time.perf_counter()
    verified = verified_tree(result, scenario.task, goal)
    fields["verify_s"] = time.perf_counter() - started
    release_search_memory()
    solve = fields["model_s"] + fields["planning_s"] + fields["verify_s"]
    times = {name: round(value, 6) for name, value in fields.items() if name.endswith("_s")}
    return {
        **_known(run.world, run.record, run.config, actions),
        **fields,
        **times,
        "load_kind": load_kind,
        "status": result.status.value,
        "solved": result.solved,
        "verified": verified,
        "explored": result.stats.explored,
        "cost": result.cost,
        "solve_s": round(solve, 6),
        "total_s": round(solve + load, 6),
        "resident_mb": round(resident_mb()),
    }


def _known(world: World, record: Record, config: str, actions: int | None = None) -> dict[str, Any]:
    return {
        "axis": world.axis,
        "cell": world.cell,
        "scale": world.scale,
        "scenario": world.scenario,
        "task": record.id,
        "p_star": len(record.optimal_actions),
        "config": config,
        **({"actions": actions} if actions is not None else {}),
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
    recipes = {b: BackendRecipe(b, options) for b in config.backends}
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
    results = ResultsFile(out / "results.jsonl", KEY)
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


PHASES = ("total_s", "solve_s", "load_s", "model_s", "planning_s", "verify_s")
BEST_FREE = "best LLM-free"


def _time(row: dict[str, Any] | None, measure: str) -> float:
    """The row's time, infinite when it did not produce a verified tree."""
    return float(row[measure]) if row is not None and row.get("verified") else math.inf


def _stats(rows: Sequence[dict[str, Any]]) -> dict[str, Any]:
    good = [r for r in rows if r.get("verified")]
    stats: dict[str, Any] = {"tasks": len(rows), "verified": len(good)}
    stats.update({f"median_{phase}": median([r[phase] for r in good if phase in r]) for phase in PHASES})
    return stats


def _best_free(tasks: dict[str, dict[str, dict[str, Any]]]) -> list[dict[str, Any]]:
    """Per task, the LLM-free row with the shortest total time (the first one if none is verified)."""
    best = []
    for by_config in tasks.values():
        free = [by_config[name] for name in LLM_FREE if name in by_config]
        if free:
            best.append(min(free, key=lambda r: _time(r, "total_s")))
    return best


def _against(guided: str, tasks: dict[str, dict[str, dict[str, Any]]]) -> dict[str, Any]:
    """How an LLM-guided configuration fares against the best LLM-free one, task by task."""
    pairs = []
    for by_config in tasks.values():
        free = min((_time(by_config.get(name), "total_s") for name in LLM_FREE), default=math.inf)
        free_solve = min((_time(by_config.get(name), "solve_s") for name in LLM_FREE), default=math.inf)
        row = by_config.get(guided)
        pairs.append((_time(row, "total_s"), free, _time(row, "solve_s"), free_solve))
    finite = [(g, f, gs, fs) for g, f, gs, fs in pairs if math.isfinite(g) and math.isfinite(f) and f > 0 and fs > 0]
    return {
        "wins_total": sum(g < f for g, f, _, _ in pairs),
        "wins_solve": sum(gs < fs for _, _, gs, fs in pairs),
        "median_ratio_total": median([g / f for g, f, _, _ in finite]),
        "median_ratio_solve": median([gs / fs for _, _, gs, fs in finite]),
    }


def _cell(rows: Sequence[dict[str, Any]], config: PayoffConfig) -> dict[str, Any]:
    tasks: dict[str, dict[str, dict[str, Any]]] = {}
    for row in rows:
        tasks.setdefault(row["task"], {})[row["config"]] = row
    first = rows[0]
    configs = {name: _stats([r for r in rows if r["config"] == name]) for name in config.configs}
    configs[BEST_FREE] = _stats(_best_free(tasks))
    return {
        "axis": first["axis"],
        "cell": first["cell"],
        "scale": first["scale"],
        "scenario": first["scenario"],
        "actions": next((r["actions"] for r in rows if "actions" in r), None),
        "load_kind": next((r["load_kind"] for r in rows if "load_kind" in r), None),
        "tasks": len(tasks),
        "median_p_star": median([r["p_star"] for r in rows]),
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


def summarise(rows: Sequence[dict[str, Any]], config: PayoffConfig) -> dict[str, Any]:
    cells = []
    for world in _cells_of(config):
        mine = [r for r in rows if r["axis"] == world.axis and r["cell"] == world.cell]
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
        "unverified": sum(not r.get("verified") for r in rows),
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


def _s(value: float | None) -> str:
    return "–" if value is None else f"{value:.3f}"


def payoff_section(summary: dict[str, Any]) -> str:
    """The per-cell medians, the guided/LLM-free ratios and where the curves cross."""
    rows = []
    for cell in summary["cells"]:
        for name, stats in cell["configs"].items():
            against = cell["against"].get(name, {})
            rows.append(
                [
                    cell["axis"],
                    cell["cell"],
                    cell["actions"],
                    name,
                    f"{stats['verified']}/{stats['tasks']}",
                    *(_s(stats[f"median_{phase}"]) for phase in PHASES),
                    _s(against.get("median_ratio_total")),
                    _s(against.get("median_ratio_solve")),
                    against.get("wins_total", "–"),
                ]
            )
    header = ["axis", "cell", "|A|", "configuration", "verified", "total s", "solve s", "load s", "model s"]
    header += ["planning s", "verify s", "ratio total", "ratio solve", "wins"]
    cross = [
        [axis, name, measure, ", ".join(c["faster_in"]) or "nowhere", ", ".join(c["crosses"]) or "–"]
        for axis, by_name in summary["crossings"].items()
        for name, by_measure in by_name.items()
        for measure, c in by_measure.items()
    ]
    config = summary["config"]
    return "\n\n".join(
        [
            "## End-to-end time to a verified tree: LLM-guided HBTP against the best LLM-free planner",
            f"{config['tasks']} tasks per cell; LLM-free: OBTEA and HBTP-S with the landmark heuristic, no hints, "
            f"{config['time_limit']:g} s; LLM-guided: HBTP-S rounds of {config['round_time_limit']:g} s, "
            f"{config['feedback_rounds']} feedback rounds, the full-space fallback. Medians over the verified "
            "trees; total = load + model + planning + verification, solve = total without the load; ratios are "
            "medians over the tasks of guided / best LLM-free (below 1: the LLM pays); wins: tasks where "
            f"guidance reached a verified tree first. Runs: {summary['runs']}, unverified: {summary['unverified']}.",
            _table(header, rows),
            "Where the curves cross (medians, LLM-guided against best LLM-free):",
            _table(["axis", "configuration", "measure", "guided faster in", "order flips between"], cross),
            "![payoff](payoff.png)",
        ]
    )
