"""Figure 4 of the paper: error tolerance of HBTP-O and HBTP-S.

For each Table I task the heuristic path p̂ is the record's optimal plan with errors: each optimal
action is kept with probability ``correct`` (the correct rate) and ``round(error * |p*|)`` wrong
actions are inserted at random places (the error rate). Only the heuristic changes: the action space
is the record's own pruned space (its vital predicates and objects and its plan, §III-C), and the
wrong actions are drawn from that space (actions that look relevant but are not on the optimal
path), so the figure measures what an imperfect p̂ costs the search, as the paper's Figure 4 does.
Each planner reports |S⁻| and D(T). Seeded per (task, rates, seed): reruns give the same numbers.
"""

from __future__ import annotations

from collections.abc import Sequence
from dataclasses import dataclass
from pathlib import Path
from typing import Any

from hbtp.bench.paper import paper_scenario
from hbtp.bench.plots import plot_fig4
from hbtp.bench.report import fig4_section, write_report
from hbtp.bench.results import ResultsFile, Row, mean, optional, write_json
from hbtp.bench.runner import DEFAULT_EXECUTION, Execution, Work, hard_limit, run_work
from hbtp.datasets import load_dataset, validate_records
from hbtp.datasets.records import Record
from hbtp.llm.parse import hints_from_record
from hbtp.logic.tables import TaskTable
from hbtp.logic.task import GroundAction, GroundTask
from hbtp.planning import Hints, Limits, planner_config, pruned_action_space, resolve_hints, search
from hbtp.planning.heuristic_names import HeuristicName
from hbtp.planning.hints import PathNoise, seeded_random
from hbtp.planning.result import PlanResult

DATASET = "table1_robothow_100"
SCENARIO = "robothow"


@dataclass(frozen=True)
class Fig4Config:
    correct_rates: tuple[float, ...] = (0.0, 0.25, 0.5, 0.75, 1.0)
    error_rates: tuple[float, ...] = (0.0, 0.5, 1.0)
    seeds: int = 3
    planners: tuple[str, ...] = ("hbtp-o", "hbtp-s")
    time_limit: float = 5.0
    limit: int | None = None


def noisy_path(record: Record, candidates: Sequence[str], correct: float, error: float, seed: int) -> list[str]:
    """The record's optimal actions with :class:`PathNoise` ``(correct, error)``; the wrong actions
    come from ``candidates`` (action names) off the optimal path (any of them if none is off it)."""
    optimal = record.optimal_actions
    wrong = sorted(set(candidates) - set(optimal)) or sorted(candidates)
    return PathNoise(correct, error).apply(optimal, wrong, seeded_random("fig4", record.id, correct, error, seed))


@dataclass(frozen=True, kw_only=True)
class Fig4Row(Row):
    """One planner with one noisy p̂ on one task. A killed run's row has no ``p_star``, ``p_hat`` or
    ``action_space``, and ``None`` for ``explored`` and ``cost``."""

    KEY = ("task", "planner", "correct", "error", "seed")

    task: str
    planner: str
    correct: float
    error: float
    seed: int
    status: str
    solved: bool
    time_s: float
    explored: int | None
    cost: int | None
    p_star: int | None = optional()
    p_hat: int | None = optional()
    action_space: int | None = optional()


@dataclass(frozen=True)
class Fig4Run:
    """One planner with one noisy heuristic path on one task (the spec a worker runs)."""

    record: Record
    planner: str
    correct: float
    error: float
    seed: int
    time_limit: float


def run_fig4(config: Fig4Config, out: Path, execution: Execution = DEFAULT_EXECUTION) -> dict[str, Any]:
    """Run (or resume) Figure 4 into ``out``; returns the summary (also summary.json, and fig4.png
    when matplotlib is installed)."""
    scenario = paper_scenario(SCENARIO)
    records = load_dataset(DATASET)
    invalid = set(validate_records(records, scenario.task).invalid_ids)
    records = [r for r in records if r.id not in invalid][: config.limit]
    results = ResultsFile(out / "results.jsonl", Fig4Row)
    work = [
        Work(
            (record.id, planner, correct, error, seed),
            Fig4Run(record, planner, correct, error, seed, config.time_limit),
            {
                "task": record.id,
                "planner": planner,
                "correct": correct,
                "error": error,
                "seed": seed,
                "explored": None,
                "cost": None,
            },
        )
        for record in records
        for correct in config.correct_rates
        for error in config.error_rates
        for seed in range(config.seeds)
        for planner in config.planners
    ]
    run_work(run_one, work, results, execution, kill_after=hard_limit(config.time_limit), description="fig4")
    summary = summarise(list(results.ordered(w.key for w in work)), config)
    write_json(out / "summary.json", summary)
    plot_fig4(summary, out / "fig4.png")
    write_report(out / "report.md", "Figure 4", [fig4_section(summary)])
    return summary


_PRUNED_SPACES: TaskTable[tuple[GroundAction, ...]] = TaskTable("the pruned spaces of records' hints")


def _pruned_space(task: GroundTask, record: Record) -> tuple[GroundAction, ...]:
    """The record's own pruned action space (built once per task and record, kept with the task)."""

    def build() -> tuple[GroundAction, ...]:
        return task.restricted(pruned_action_space(task, resolve_hints(task, hints_from_record(record))))

    return _PRUNED_SPACES.of(task, build, key=record)


def run_one(run: Fig4Run) -> Fig4Row:
    """Plan one task with a noisy p̂ in the record's pruned space."""
    scenario = paper_scenario(SCENARIO)
    task = scenario.task
    record = run.record
    space = _pruned_space(task, record)
    path = noisy_path(record, [a.signature.underscored for a in space], run.correct, run.error, run.seed)
    result = search(
        task,
        task.resolve_goal(record.goal),
        space,
        planner_config(run.planner, heuristic=HeuristicName.NONE),
        mutexes=scenario.mutexes,
        hints=resolve_hints(task, Hints(tuple(path))),
        limits=Limits(time_s=run.time_limit),
    )
    return _row(record, run.planner, run.correct, run.error, run.seed, path, result)


def _row(
    record: Record, planner: str, correct: float, error: float, seed: int, path: Sequence[str], result: PlanResult
) -> Fig4Row:
    return Fig4Row(
        task=record.id,
        planner=planner,
        correct=correct,
        error=error,
        seed=seed,
        p_star=len(record.optimal_actions),
        p_hat=len(path),
        solved=result.solved,
        status=result.status.value,
        explored=result.stats.explored,
        cost=result.cost,
        time_s=round(result.stats.time_s, 6),
        action_space=result.stats.action_space,
    )


def _cell(rows: Sequence[Fig4Row], planner: str, error: float, correct: float) -> dict[str, Any]:
    """One planner at one (error rate, correct rate): ``rows`` are its runs."""
    solved = [r for r in rows if r.solved]
    return {
        "planner": planner,
        "error": error,
        "correct": correct,
        "runs": len(rows),
        "solved": len(solved),
        "mean_explored": mean(r.explored for r in solved),
        "mean_cost": mean(r.cost for r in solved),
        "mean_time_s": mean(r.time_s for r in rows),
    }


def summarise(rows: Sequence[Fig4Row], config: Fig4Config) -> dict[str, Any]:
    cells = [
        _cell(
            [r for r in rows if (r.planner, r.error, r.correct) == (planner, error, correct)], planner, error, correct
        )
        for planner in config.planners
        for error in config.error_rates
        for correct in config.correct_rates
    ]
    return {
        "dataset": DATASET,
        "config": {
            "correct_rates": list(config.correct_rates),
            "error_rates": list(config.error_rates),
            "seeds": config.seeds,
            "planners": list(config.planners),
            "time_limit": config.time_limit,
            "tasks": config.limit,
        },
        "cells": cells,
    }
