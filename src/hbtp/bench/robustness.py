"""Robustness under perturbations: the full tree against the path-only tree on the Table II sets.

For every task of the four Table II test sets, a tree is planned with HBTP-S in the action space
pruned by the record's hints (the landmark heuristic on; OBTEA in the full space when that fails).
Both its trees, the *full* tree (every expanded condition) and the *path* tree (the solution path
only, as the reference implementation outputs), are then run ``runs`` times from s0 with random
external events of probability ``p`` per tick (:mod:`hbtp.bt.disturb`), with the same seeds for
both trees. A row of ``results.jsonl`` holds one (task, p, tree) combination; ``summary.json``
averages them per scenario, p and tree and counts the tasks where the full tree did better.
"""

from __future__ import annotations

import logging
import time
from collections import Counter
from collections.abc import Iterable, Sequence
from dataclasses import dataclass, replace
from pathlib import Path
from typing import Any

from hbtp.bench.paper import paper_scenario
from hbtp.bench.plots import plot_robustness
from hbtp.bench.report import robustness_section, write_report
from hbtp.bench.results import JsonObject, ResultsFile, Row, mean, median, optional, write_json
from hbtp.bench.runner import DEFAULT_EXECUTION, Execution, RunFailure, Work, hard_limit, run_work
from hbtp.bt import tree_of
from hbtp.bt.disturb import perturbation_stats
from hbtp.bt.nodes import Node, size
from hbtp.bt.simulate import condition_checks
from hbtp.datasets import load_dataset
from hbtp.datasets.records import Record
from hbtp.domains import Scenario
from hbtp.errors import InputError
from hbtp.llm.parse import hints_from_record
from hbtp.logic.task import Goal
from hbtp.planning import PLANNERS, Limits, PlanResult, plan
from hbtp.planning.heuristic_names import HEURISTICS, HeuristicName
from hbtp.planning.hints import Hints
from hbtp.planning.planners import Space
from hbtp.replanning import ReplanOptions, replanning_stats

log = logging.getLogger(__name__)

SCENARIOS = ("robowaiter", "virtualhome", "robothow-small", "robothow")
TREES = ("full", "path")
#: The same trees run with re-planning (:mod:`hbtp.runtime`) when the benchmark is asked to.
REPLANNED = ("full+replan", "path+replan")
MAX_TICKS = 500
TIME_LIMIT = 30.0


def dataset_of(scenario: str) -> str:
    """``table2_robothow_small_50`` for ``robothow-small``."""
    return f"table2_{scenario.replace('-', '_')}_50"


def task_seed(seed: int, scenario: str, task: str) -> int:
    """A per-task seed that does not depend on the order or the subset of tasks run."""
    value = seed
    for char in f"{scenario}/{task}":
        value = (value * 1_000_003 + ord(char)) % (2**61 - 1)
    return value


def plan_record(
    scenario: Scenario,
    record: Record,
    time_limit: float = TIME_LIMIT,
    planner: str = "hbtp-s",
    heuristic: HeuristicName = HeuristicName.LM,
    robust: int = 0,
) -> tuple[PlanResult, str]:
    """HBTP-S (or ``planner``) in the pruned space with the record's hints and the landmark
    heuristic (or ``heuristic``); OBTEA in the full space with the landmark heuristic if that fails.

    Returns the result and a label of the configuration that produced it.
    """
    hints = hints_from_record(record)
    limits = Limits(time_s=time_limit)
    result = plan(
        scenario.task,
        record.goal,
        planner,
        hints=hints,
        space=Space.PRUNED,
        mutexes=scenario.mutexes,
        heuristic=heuristic,
        limits=limits,
        extra_expansions=robust,
    )
    if result.solved:
        return result, f"{planner}/pruned"
    log.info(
        "%s %s: %s in the pruned space: %s; trying obtea in the full space",
        scenario.name,
        record.id,
        planner,
        result.status.value,
    )
    result = plan(
        scenario.task, record.goal, "obtea", mutexes=scenario.mutexes, heuristic=HeuristicName.LM, limits=limits
    )
    return result, "obtea/full"


@dataclass(frozen=True, kw_only=True)
class RobustnessRow(Row):
    """One task's tree of one kind under perturbations of probability ``p``. A tree that was not run
    (the task not solved) has no run figures but ``success_rate`` 0, and a killed task's rows have
    neither its planning's (``plan_cost``, ``plan_time_s``, ``condition_checks``), but ``status``
    and ``time_s``."""

    KEY = ("scenario", "task", "planner", "heuristic", "robust", "p", "tree", "runs", "seed", "max_ticks")

    scenario: str
    dataset: str
    task: str
    goal: str
    planner: str
    heuristic: str
    robust: int
    p: float
    tree: str
    runs: int
    seed: int
    max_ticks: int
    planned_with: str
    solved: bool
    explored: int | None
    nodes: int | None
    success_rate: float
    successes: int
    mean_extra_ticks: float | None
    mean_extra_cost: float | None
    plan_cost: int | None = None
    condition_checks: int | None = None
    plan_time_s: float | None = optional()
    #: The figures of the perturbed runs (:func:`hbtp.bt.disturb.perturbation_stats`).
    mean_ticks: float | None = None
    mean_cost: float | None = None
    mean_events: float | None = optional()
    limit_hits: int | None = optional()
    base_reached: bool | None = optional()
    base_ticks: int | None = optional()
    base_cost: int | None = optional()
    #: And with re-planning (:func:`hbtp.replanning.replanning_stats`).
    replans: int | None = optional()
    mean_replans: float | None = None
    median_replan_ms: float | None = None
    max_replan_ms: float | None = None
    #: Re-plans answered by an earlier search from the same state (:meth:`hbtp.replanning.KeptSearch.recall`),
    #: and the median time of the others.
    recalled_replans: int | None = optional()
    median_searched_replan_ms: float | None = optional()
    unsolvable_runs: int | None = optional()
    budget_runs: int | None = optional()
    #: Re-plans the hints' space answered; of those checked, how many found the full space's optimum,
    #: and the cost they added over it in all.
    pruned_replans: int | None = optional()
    optimal_replans: int | None = optional()
    replan_extra_cost: int | None = optional()
    success_rate_reachable: float | None = None
    status: str | None = optional()
    time_s: float | None = optional()


@dataclass(frozen=True)
class RobustnessConfig:
    """What to run: ``planner`` plans in the pruned space with ``heuristic`` (default HBTP-S with the
    landmark heuristic), exploring ``robust`` more conditions after each solution (``hbtp plan
    --robust``); each tree runs ``runs`` times per probability of ``p_values`` for at most
    ``max_ticks`` ticks; ``limit`` keeps the first tasks of each test set."""

    p_values: tuple[float, ...] = (0.1, 0.2)
    runs: int = 20
    seed: int = 0
    scenarios: tuple[str, ...] = SCENARIOS
    limit: int | None = None
    max_ticks: int = MAX_TICKS
    planner: str = "hbtp-s"
    heuristic: HeuristicName = HeuristicName.LM
    robust: int = 0
    #: Also run each tree with re-planning (OBTEA from the state the tree fails in:
    #: :class:`hbtp.replanning.ReplanOptions`' defaults): the ``full+replan`` and ``path+replan`` rows.
    replan: bool = False
    #: Re-plans continue the last re-plan's search (:mod:`hbtp.planning.repair`); ``False``: from scratch.
    repair: bool = True
    #: Re-plans search the hints' space first (the record's hints, when the tree was planned in their
    #: space: :attr:`hbtp.replanning.ReplanOptions.hints`); ``False``: the full space only.
    replan_hints: bool = True
    #: Check each re-plan the hints' space answered against a fresh search of the full space from
    #: its state (the optimum): the rows' ``optimal_replans`` and ``replan_extra_cost``.
    check_replans: bool = False

    @property
    def trees(self) -> tuple[str, ...]:
        return (*TREES, *REPLANNED) if self.replan else TREES

    def __post_init__(self) -> None:
        unknown = [s for s in self.scenarios if s not in SCENARIOS]
        if unknown or not self.scenarios:
            raise InputError(
                f"unknown scenario(s) {', '.join(unknown) or '(none)'}; choose from {', '.join(SCENARIOS)}"
            )
        if self.runs < 1:
            raise InputError(f"runs must be at least 1, not {self.runs}")
        if self.planner not in PLANNERS:
            raise InputError(f"unknown planner {self.planner!r}; choose one of: {', '.join(PLANNERS)}")
        if self.heuristic not in HEURISTICS:
            raise InputError(f"unknown heuristic {self.heuristic!r}; choose one of: {', '.join(HEURISTICS)}")
        object.__setattr__(self, "p_values", tuple(float(p) for p in self.p_values))
        object.__setattr__(self, "scenarios", tuple(self.scenarios))

    def to_dict(self) -> dict[str, Any]:
        return {
            "p_values": list(self.p_values),
            "runs": self.runs,
            "seed": self.seed,
            "max_ticks": self.max_ticks,
            "tasks_per_scenario": self.limit,
            "scenarios": list(self.scenarios),
            "planner": self.planner,
            "heuristic": self.heuristic,
            "robust": self.robust,
            "trees": list(self.trees),
            "repair": self.repair,
            "replan_hints": self.replan_hints,
            "check_replans": self.check_replans,
        }


def run_robustness(
    config: RobustnessConfig, out_dir: Path | str, execution: Execution = DEFAULT_EXECUTION
) -> dict[str, Any]:
    """Run (or resume) the benchmark into ``out_dir``; returns the summary (also ``summary.json``)."""
    out = Path(out_dir)
    started = time.perf_counter()
    results = ResultsFile(out / "results.jsonl", RobustnessRow)
    work = [
        Work((name, record.id), RobustnessRun(name, record, config), _killed_rows(name, record, config), stage=name)
        for name in config.scenarios
        for record in load_dataset(dataset_of(name))[: config.limit]
    ]
    keys = [results.key(row) for item in work for row in item.rows]
    run_work(
        run_one, work, results, execution, kill_after=hard_limit(TIME_LIMIT, slack=120.0), description="robustness"
    )
    summary = summarise(list(results.ordered(keys)), config.scenarios, config.p_values, config.trees)
    summary["config"] = config.to_dict()
    summary["elapsed_s"] = round(time.perf_counter() - started, 3)
    write_json(out / "summary.json", summary)
    plot_robustness(summary, out / "robustness.png")
    write_report(out / "report.md", "Robustness", [robustness_section(summary)])
    return summary


@dataclass(frozen=True)
class RobustnessRun:
    """One task: plan it, then run both trees under perturbations (the spec a worker runs)."""

    scenario: str
    record: Record
    config: RobustnessConfig


#: The run figures a tree's rows have only when it was run, and that may be ``null`` then.
_FIGURES = frozenset(
    {"mean_ticks", "mean_cost", "mean_replans", "median_replan_ms", "max_replan_ms", "success_rate_reachable"}
)
#: The fields a task's rows have only once it was planned, and that may be ``null`` then.
_PLANNED = frozenset({"plan_cost", "condition_checks"})


def _not_run(scenario: str, record: Record, config: RobustnessConfig, p: float, kind: str) -> RobustnessRow:
    """The row of a tree not run at ``p``: the task's fields, not planned (as a killed task's rows)."""
    return RobustnessRow(
        scenario=scenario,
        dataset=dataset_of(scenario),
        task=record.id,
        goal=record.goal.strip(),
        planner=config.planner,
        heuristic=config.heuristic,
        robust=config.robust,
        p=p,
        tree=kind,
        runs=config.runs,
        seed=config.seed,
        max_ticks=config.max_ticks,
        planned_with=RunFailure.KILLED.value,
        solved=False,
        explored=None,
        nodes=None,
        success_rate=0.0,
        successes=0,
        mean_extra_ticks=None,
        mean_extra_cost=None,
        absent=_PLANNED | _FIGURES,
    )


def _killed_rows(scenario: str, record: Record, config: RobustnessConfig) -> tuple[JsonObject, ...]:
    """The rows of a task whose worker was killed, one per (p, tree): the JSON fields known before it ran."""
    return tuple(
        _not_run(scenario, record, config, p, kind).to_json() for p in config.p_values for kind in config.trees
    )


def run_one(run: RobustnessRun) -> list[RobustnessRow]:
    """The rows of one task: one per (p, tree)."""
    return _run_task(paper_scenario(run.scenario), run.record, run.config)


def _run_task(scenario: Scenario, record: Record, config: RobustnessConfig) -> list[RobustnessRow]:
    started = time.perf_counter()
    result, how = plan_record(
        scenario, record, planner=config.planner, heuristic=config.heuristic, robust=config.robust
    )
    seconds = round(time.perf_counter() - started, 6)
    goal = scenario.task.resolve_goal(record.goal)
    hints = hints_from_record(record) if how.endswith("/pruned") and config.replan_hints else None
    rows: list[RobustnessRow] = []
    for kind in config.trees:
        tree = tree_of(result, kind.removesuffix("+replan")) if result.solved else None
        planned = replace(
            _not_run(scenario.name, record, config, 0.0, kind),  # its p is set per row by _tree_rows
            planned_with=how,
            solved=result.solved,
            explored=result.stats.explored,
            plan_cost=result.cost,
            plan_time_s=seconds,
            absent=_FIGURES,
        )
        rows += _tree_rows(scenario, goal, tree, config, planned, hints)
    return rows


def _tree_rows(
    scenario: Scenario,
    goal: Goal,
    tree: Node | None,
    config: RobustnessConfig,
    planned: RobustnessRow,
    hints: Hints | None = None,
) -> list[RobustnessRow]:
    """One row per p for one tree (``None`` for a task not solved; ``planned`` the rows' fields known
    from planning; ``hints`` those re-plans search first): its size, its condition checks
    undisturbed, and its figures under perturbations (:func:`hbtp.bt.disturb.perturbation_stats`)."""
    if tree is not None:
        checks = condition_checks(tree, scenario.task, max_ticks=config.max_ticks)
        planned = replace(planned, nodes=size(tree).nodes, condition_checks=checks)
    seed = task_seed(config.seed, scenario.name, planned.task)
    rows: list[RobustnessRow] = []
    for p in config.p_values:
        row = replace(planned, p=p)
        if tree is not None:
            stats = _stats(scenario, goal, planned.tree, tree, p, seed, config, hints)
            row = row.updated({k: v for k, v in stats.items() if k not in ("p", "seed")})
        rows.append(row)
    return rows


def _stats(
    scenario: Scenario,
    goal: Goal,
    kind: str,
    tree: Node,
    p: float,
    seed: int,
    config: RobustnessConfig,
    hints: Hints | None = None,
) -> dict[str, Any]:
    if kind not in REPLANNED:
        return perturbation_stats(tree, scenario.task, goal, scenario.mutexes, p, config.runs, seed, config.max_ticks)
    options = ReplanOptions(repair=config.repair, hints=hints)
    return replanning_stats(
        scenario, goal, tree, p, config.runs, seed, config.max_ticks, options, check=config.check_replans
    )


def summarise(
    rows: Sequence[RobustnessRow],
    scenarios: Sequence[str],
    p_values: Sequence[float],
    trees: Sequence[str] = TREES,
) -> dict[str, Any]:
    """Per scenario (and ``all``), per p and tree: means over tasks; and full-vs-path task counts."""
    table: dict[str, Any] = {}
    for name in [*scenarios, "all"]:
        mine = [r for r in rows if name == "all" or r.scenario == name]
        table[name] = {
            "tasks": len({(r.scenario, r.task) for r in mine}),
            "planned_with": _planned_with(mine),
            "unsolved": len({(r.scenario, r.task) for r in mine if not r.solved}),
            "p": {str(p): _at_p([r for r in mine if r.p == p], trees) for p in p_values},
        }
    return {"benchmark": "robustness", "scenarios": table}


def _at_p(rows: Sequence[RobustnessRow], trees: Sequence[str]) -> dict[str, Any]:
    """The rows of one p: the figures of each tree kind, and the tasks where the full tree did better
    than the path tree, worse, or the same."""
    entry: dict[str, Any] = {kind: _tree_figures([r for r in rows if r.tree == kind], kind) for kind in trees}
    pairs = _pairs(rows)
    entry["full_better"] = sum(f > q for f, q in pairs)
    entry["path_better"] = sum(f < q for f, q in pairs)
    entry["equal"] = sum(f == q for f, q in pairs)
    return entry


def _tree_figures(rows: Sequence[RobustnessRow], kind: str) -> dict[str, Any]:
    """Means over the tasks of one tree kind at one p (each over the rows that have the figure)."""
    return {
        "tasks": len(rows),
        "success_rate": mean(r.success_rate for r in rows),
        "runs_succeeded": sum(r.successes for r in rows),
        "tasks_all_runs_succeeded": sum(r.successes == r.runs for r in rows),
        "mean_extra_ticks": mean(r.mean_extra_ticks for r in rows),
        "mean_extra_cost": mean(r.mean_extra_cost for r in rows),
        "mean_events": mean(r.mean_events for r in rows),
        "mean_nodes": mean(r.nodes for r in rows),
        "mean_base_ticks": mean(r.base_ticks for r in rows),
        "mean_condition_checks": mean(r.condition_checks for r in rows),
        **(_replanning(rows) if kind in REPLANNED else {}),
    }


def _replanning(rows: Sequence[RobustnessRow]) -> dict[str, Any]:
    """The re-planning figures of a tree kind's rows: runs whose goal stayed reachable and how many
    of them succeeded, re-plans per run, and the median of the rows' median re-planning times."""
    replanned = [r for r in rows if r.unsolvable_runs is not None]
    runs = sum(r.runs for r in replanned)
    unsolvable = sum(r.unsolvable_runs or 0 for r in replanned)
    return {
        "reachable_runs": runs - unsolvable,
        "reachable_runs_succeeded": sum(r.successes for r in replanned),
        "unsolvable_runs": unsolvable,
        "budget_runs": sum(r.budget_runs or 0 for r in rows),
        "replans": sum(r.replans or 0 for r in rows),
        "pruned_replans": sum(r.pruned_replans or 0 for r in rows),
        "optimal_replans": _total(r.optimal_replans for r in rows),
        "replan_extra_cost": _total(r.replan_extra_cost for r in rows),
        "median_plan_ms": median(1000 * r.plan_time_s for r in rows if r.plan_time_s is not None),
        # The same tasks' planning from s0, of those that re-planned (what a re-plan is held against).
        "median_plan_ms_replanned": median(
            1000 * r.plan_time_s for r in rows if r.plan_time_s is not None and r.median_replan_ms is not None
        ),
        "mean_replans": mean(r.mean_replans for r in rows),
        "median_replan_ms": median(r.median_replan_ms for r in rows),
        "recalled_replans": _total(r.recalled_replans for r in rows),
        "median_searched_replan_ms": median(r.median_searched_replan_ms for r in rows),
        "max_replan_ms": max((r.max_replan_ms for r in rows if r.max_replan_ms is not None), default=None),
    }


def _total(values: Iterable[int | None]) -> int | None:
    """The sum of the values given (``None`` when none is)."""
    known = [value for value in values if value is not None]
    return sum(known) if known else None


def _pairs(rows: Sequence[RobustnessRow]) -> list[tuple[float, float]]:
    full = {(r.scenario, r.task): r.success_rate for r in rows if r.tree == "full"}
    path = {(r.scenario, r.task): r.success_rate for r in rows if r.tree == "path"}
    return [(full[key], path[key]) for key in full if key in path]


def _planned_with(rows: Sequence[RobustnessRow]) -> dict[str, int]:
    """How many tasks each configuration planned (as a task's last row says), by name."""
    seen = {(r.scenario, r.task): r.planned_with for r in rows}
    return dict(sorted(Counter(seen.values()).items()))


__all__ = [
    "SCENARIOS",
    "RobustnessConfig",
    "RobustnessRow",
    "dataset_of",
    "plan_record",
    "run_robustness",
    "summarise",
    "task_seed",
]
