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
from collections.abc import Sequence
from dataclasses import dataclass
from pathlib import Path
from typing import Any

from hbtp.bench.plots import plot_robustness
from hbtp.bench.report import robustness_section, write_report
from hbtp.bench.results import ResultsFile, mean, write_json
from hbtp.bench.runner import DEFAULT_EXECUTION, Execution, Work, hard_limit, run_work
from hbtp.bt import tree_of
from hbtp.bt.compact import measure
from hbtp.bt.disturb import perturbation_stats
from hbtp.bt.nodes import Node, tick
from hbtp.bt.simulate import simulate
from hbtp.datasets import load_dataset
from hbtp.datasets.records import Record
from hbtp.domains import Scenario, load_scenario
from hbtp.errors import InputError
from hbtp.logic.task import GroundTask
from hbtp.planning import PLANNERS, Limits, PlanResult, hints_from_record, plan
from hbtp.planning.heuristics import HEURISTICS, HeuristicName

log = logging.getLogger(__name__)

SCENARIOS = ("robowaiter", "virtualhome", "robothow-small", "robothow")
TREES = ("full", "path")
KEY = ("scenario", "task", "planner", "heuristic", "robust", "p", "tree", "runs", "seed", "max_ticks")
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
    heuristic: HeuristicName = "lm",
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
        space="pruned",
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
    result = plan(scenario.task, record.goal, "obtea", mutexes=scenario.mutexes, heuristic="lm", limits=limits)
    return result, "obtea/full"


def run_robustness(
    out_dir: Path | str,
    p_values: Sequence[float] = (0.1, 0.2),
    runs: int = 20,
    seed: int = 0,
    scenarios: Sequence[str] = SCENARIOS,
    limit: int | None = None,
    execution: Execution = DEFAULT_EXECUTION,
    max_ticks: int = MAX_TICKS,
    planner: str = "hbtp-s",
    heuristic: HeuristicName = "lm",
    robust: int = 0,
) -> dict[str, Any]:
    """Run (or resume) the benchmark into ``out_dir``; returns the summary (also ``summary.json``).

    ``robust`` explores that many more conditions after each solution (``hbtp plan --robust``).

    ``planner`` plans in the pruned space with ``heuristic`` (default HBTP-S with the landmark
    heuristic); ``limit``
    keeps the first tasks of each test set; ``max_ticks`` bounds every run.
    """
    out = Path(out_dir)
    unknown = [s for s in scenarios if s not in SCENARIOS]
    if unknown or not scenarios:
        raise InputError(f"unknown scenario(s) {', '.join(unknown) or '(none)'}; choose from {', '.join(SCENARIOS)}")
    if runs < 1:
        raise InputError(f"runs must be at least 1, not {runs}")
    if planner not in PLANNERS:
        raise InputError(f"unknown planner {planner!r}; choose one of: {', '.join(PLANNERS)}")
    if heuristic not in HEURISTICS:
        raise InputError(f"unknown heuristic {heuristic!r}; choose one of: {', '.join(HEURISTICS)}")
    p_values = tuple(float(p) for p in p_values)
    started = time.perf_counter()
    results = ResultsFile(out / "results.jsonl", KEY)
    work = [
        Work(
            (name, record.id),
            RobustnessRun(name, record, p_values, runs, seed, max_ticks, planner, heuristic, robust),
            tuple(
                {
                    "scenario": name,
                    "dataset": dataset_of(name),
                    "task": record.id,
                    "goal": record.goal.strip(),
                    "planner": planner,
                    "heuristic": heuristic,
                    "robust": robust,
                    "p": p,
                    "tree": kind,
                    "runs": runs,
                    "seed": seed,
                    "max_ticks": max_ticks,
                    "planned_with": "killed",
                    "explored": None,
                    "nodes": None,
                    "success_rate": 0.0,
                    "successes": 0,
                    "mean_extra_ticks": None,
                    "mean_extra_cost": None,
                }
                for p in p_values
                for kind in TREES
            ),
            stage=name,
        )
        for name in scenarios
        for record in load_dataset(dataset_of(name))[:limit]
    ]
    keys = [results.key(row) for item in work for row in item.rows]
    run_work(
        run_one, work, results, execution, kill_after=hard_limit(TIME_LIMIT, slack=120.0), description="robustness"
    )
    summary = summarise(list(results.ordered(keys)), scenarios, p_values)
    summary["config"] = {
        "p_values": list(p_values),
        "runs": runs,
        "seed": seed,
        "max_ticks": max_ticks,
        "tasks_per_scenario": limit,
        "scenarios": list(scenarios),
        "planner": planner,
        "heuristic": heuristic,
        "robust": robust,
    }
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
    p_values: tuple[float, ...]
    runs: int
    seed: int
    max_ticks: int
    planner: str
    heuristic: HeuristicName
    robust: int


def run_one(run: RobustnessRun) -> list[dict[str, Any]]:
    """The rows of one task: one per (p, tree)."""
    return _run_task(
        load_scenario(run.scenario), run.record, run.p_values, run.runs, run.seed, run.max_ticks, run.planner,
        run.heuristic, run.robust,
    )  # fmt: skip


def _run_task(
    scenario: Scenario,
    record: Record,
    p_values: Sequence[float],
    runs: int,
    seed: int,
    max_ticks: int,
    planner: str,
    heuristic: HeuristicName,
    robust: int = 0,
) -> list[dict[str, Any]]:
    task = scenario.task
    started = time.perf_counter()
    result, how = plan_record(scenario, record, planner=planner, heuristic=heuristic, robust=robust)
    plan_time = round(time.perf_counter() - started, 6)
    goal = task.resolve_goal(record.goal)
    base: dict[str, Any] = {
        "scenario": scenario.name,
        "dataset": dataset_of(scenario.name),
        "task": record.id,
        "goal": record.goal.strip(),
        "planner": planner,
        "heuristic": heuristic,
        "robust": robust,
        "planned_with": how,
        "solved": result.solved,
        "explored": result.stats.explored,
        "plan_cost": result.cost,
        "plan_time_s": plan_time,
        "runs": runs,
        "seed": seed,
        "max_ticks": max_ticks,
    }
    rows: list[dict[str, Any]] = []
    for kind in TREES:
        tree = tree_of(result, kind) if result.solved else None
        size = measure(tree) if tree is not None else None
        checks = condition_checks(tree, task, max_ticks) if tree is not None else None
        for p in p_values:
            row = {**base, "p": p, "tree": kind, "nodes": size.nodes if size else None, "condition_checks": checks}
            if tree is None:
                row.update({"success_rate": 0.0, "successes": 0, "mean_extra_ticks": None, "mean_extra_cost": None})
            else:
                stats = perturbation_stats(
                    tree,
                    task,
                    goal.ids,
                    scenario.mutexes,
                    p,
                    runs,
                    task_seed(seed, scenario.name, record.id),
                    max_ticks,
                )
                stats.pop("p")
                stats.pop("seed")
                row.update(stats)
            rows.append(row)
    return rows


def condition_checks(tree: Node, task: GroundTask, max_ticks: int) -> int:
    """Condition nodes ticked in the undisturbed run from s0 (BTPG's tick count)."""
    checks = [0]
    simulate(tree, task, max_ticks=max_ticks, ticker=lambda state: tick(tree, state, task, checks))
    return checks[0]


def summarise(rows: Sequence[dict[str, Any]], scenarios: Sequence[str], p_values: Sequence[float]) -> dict[str, Any]:
    """Per scenario (and ``all``), per p and tree: means over tasks; and full-vs-path task counts."""
    table: dict[str, Any] = {}
    for name in [*scenarios, "all"]:
        mine = [r for r in rows if name == "all" or r["scenario"] == name]
        per_p: dict[str, Any] = {}
        for p in p_values:
            at_p = [r for r in mine if r["p"] == p]
            entry: dict[str, Any] = {}
            for kind in TREES:
                chosen = [r for r in at_p if r["tree"] == kind]
                entry[kind] = {
                    "tasks": len(chosen),
                    "success_rate": mean([r["success_rate"] for r in chosen]),
                    "runs_succeeded": sum(r["successes"] for r in chosen),
                    "tasks_all_runs_succeeded": sum(r["successes"] == r["runs"] for r in chosen),
                    "mean_extra_ticks": mean(
                        [r["mean_extra_ticks"] for r in chosen if r["mean_extra_ticks"] is not None]
                    ),
                    "mean_extra_cost": mean([r["mean_extra_cost"] for r in chosen if r["mean_extra_cost"] is not None]),
                    "mean_events": mean([r["mean_events"] for r in chosen if r.get("mean_events") is not None]),
                    "mean_nodes": mean([r["nodes"] for r in chosen if r["nodes"] is not None]),
                    "mean_base_ticks": mean([r["base_ticks"] for r in chosen if r.get("base_ticks") is not None]),
                    "mean_condition_checks": mean(
                        [r["condition_checks"] for r in chosen if r.get("condition_checks") is not None]
                    ),
                }
            pairs = _pairs(at_p)
            entry["full_better"] = sum(f > q for f, q in pairs)
            entry["path_better"] = sum(f < q for f, q in pairs)
            entry["equal"] = sum(f == q for f, q in pairs)
            per_p[str(p)] = entry
        table[name] = {
            "tasks": len({(r["scenario"], r["task"]) for r in mine}),
            "planned_with": _counts(mine, "planned_with"),
            "unsolved": len({(r["scenario"], r["task"]) for r in mine if not r["solved"]}),
            "p": per_p,
        }
    return {"benchmark": "robustness", "scenarios": table}


def _pairs(rows: Sequence[dict[str, Any]]) -> list[tuple[float, float]]:
    full = {(r["scenario"], r["task"]): r["success_rate"] for r in rows if r["tree"] == "full"}
    path = {(r["scenario"], r["task"]): r["success_rate"] for r in rows if r["tree"] == "path"}
    return [(full[key], path[key]) for key in full if key in path]


def _counts(rows: Sequence[dict[str, Any]], field: str) -> dict[str, int]:
    seen: dict[tuple[str, str], str] = {(r["scenario"], r["task"]): r[field] for r in rows}
    counts: dict[str, int] = {}
    for value in seen.values():
        counts[value] = counts.get(value, 0) + 1
    return dict(sorted(counts.items()))


__all__ = ["SCENARIOS", "dataset_of", "plan_record", "run_robustness", "summarise", "task_seed"]
