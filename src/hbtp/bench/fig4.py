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

import hashlib
import random
from collections.abc import Sequence
from dataclasses import dataclass
from pathlib import Path
from typing import Any

from tqdm import tqdm

from hbtp.bench.results import ResultsFile, mean, write_json
from hbtp.datasets import load_dataset, validate_records
from hbtp.datasets.records import Record
from hbtp.domains import load_scenario
from hbtp.planning import (
    Hints,
    Limits,
    hints_from_record,
    planner_config,
    pruned_action_space,
    resolve_hints,
    search,
)
from hbtp.planning.result import PlanResult

DATASET = "table1_robothow_100"
SCENARIO = "robothow"
KEY = ("task", "planner", "correct", "error", "seed")


@dataclass(frozen=True)
class Fig4Config:
    correct_rates: tuple[float, ...] = (0.0, 0.25, 0.5, 0.75, 1.0)
    error_rates: tuple[float, ...] = (0.0, 0.5, 1.0)
    seeds: int = 3
    planners: tuple[str, ...] = ("hbtp-o", "hbtp-s")
    time_limit: float = 5.0
    limit: int | None = None


def noisy_path(record: Record, candidates: Sequence[str], correct: float, error: float, seed: int) -> list[str]:
    """The record's optimal actions, each kept with probability ``correct``, with ``round(error *
    |p*|)`` wrong ones from ``candidates`` (action names) inserted."""
    digest = hashlib.sha256(f"fig4|{record.id}|{correct}|{error}|{seed}".encode()).digest()
    rng = random.Random(int.from_bytes(digest[:8], "big"))
    optimal = list(record.optimal_actions)
    path = [name for name in optimal if rng.random() < correct]
    wrong_pool = sorted(set(candidates) - set(optimal)) or sorted(candidates)
    for _ in range(round(error * len(optimal))):
        path.insert(rng.randrange(len(path) + 1), rng.choice(wrong_pool))
    return path


def run_fig4(config: Fig4Config, out: Path, *, progress: bool = True) -> dict[str, Any]:
    """Run (or resume) Figure 4 into ``out``; returns the summary (also summary.json, and fig4.png
    when matplotlib is installed)."""
    scenario = load_scenario(SCENARIO)
    records = load_dataset(DATASET)
    invalid = set(validate_records(records, scenario.task).invalid_ids)
    records = [r for r in records if r.id not in invalid][: config.limit]
    results = ResultsFile(out / "results.jsonl", KEY)
    work = [
        (record, planner, correct, error, seed)
        for record in records
        for correct in config.correct_rates
        for error in config.error_rates
        for seed in range(config.seeds)
        for planner in config.planners
    ]
    keys = [(r.id, p, c, e, s) for r, p, c, e, s in work]
    task = scenario.task
    spaces: dict[str, tuple[Any, ...]] = {}
    bar = tqdm(total=len(work), desc="fig4", disable=not progress, unit="run")
    for (record, planner, correct, error, seed), key in zip(work, keys, strict=True):
        if key not in results:
            if record.id not in spaces:
                truth = hints_from_record(record)
                spaces[record.id] = task.restricted(pruned_action_space(task, resolve_hints(task, truth)))
            space = spaces[record.id]
            path = noisy_path(record, [a.signature.underscored for a in space], correct, error, seed)
            result = search(
                task,
                task.resolve_goal(record.goal),
                space,
                planner_config(planner),
                mutexes=scenario.mutexes,
                hints=resolve_hints(task, Hints(tuple(path))),
                limits=Limits(time_s=config.time_limit),
            )
            results.append(_row(record, planner, correct, error, seed, path, result))
        bar.update(1)
    bar.close()
    summary = summarise(list(results.ordered(keys)), config)
    write_json(out / "summary.json", summary)
    plot_fig4(summary, out / "fig4.png")
    return summary


def _row(
    record: Record, planner: str, correct: float, error: float, seed: int, path: Sequence[str], result: PlanResult
) -> dict[str, Any]:
    return {
        "task": record.id,
        "planner": planner,
        "correct": correct,
        "error": error,
        "seed": seed,
        "p_star": len(record.optimal_actions),
        "p_hat": len(path),
        "solved": result.solved,
        "status": result.status.value,
        "explored": result.stats.explored,
        "cost": result.cost,
        "time_s": round(result.stats.time_s, 6),
        "action_space": result.stats.action_space,
    }


def summarise(rows: Sequence[dict[str, Any]], config: Fig4Config) -> dict[str, Any]:
    cells = []
    for planner in config.planners:
        for error in config.error_rates:
            for correct in config.correct_rates:
                mine = [r for r in rows if (r["planner"], r["error"], r["correct"]) == (planner, error, correct)]
                solved = [r for r in mine if r["solved"]]
                cells.append(
                    {
                        "planner": planner,
                        "error": error,
                        "correct": correct,
                        "runs": len(mine),
                        "solved": len(solved),
                        "mean_explored": mean([r["explored"] for r in solved]),
                        "mean_cost": mean([r["cost"] for r in solved]),
                        "mean_time_s": mean([r["time_s"] for r in mine]),
                    }
                )
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


def plot_fig4(summary: dict[str, Any], path: Path) -> bool:
    """The three panels of the paper's Figure 4, if matplotlib (the plot extra) is installed."""
    try:
        import matplotlib

        matplotlib.use("Agg")
        import matplotlib.pyplot as plt
    except ImportError:
        return False
    cells = summary["cells"]
    figure, axes = plt.subplots(1, 3, figsize=(13, 3.6))
    panels = [("hbtp-o", "mean_explored", "HBTP-O |S⁻|"), ("hbtp-s", "mean_explored", "HBTP-S |S⁻|")]
    for axis, (planner, field, title) in zip(axes[:2], panels, strict=True):
        for error in summary["config"]["error_rates"]:
            points = [(c["correct"], c[field]) for c in cells if c["planner"] == planner and c["error"] == error]
            axis.plot([x for x, _ in points], [y for _, y in points], marker="o", label=f"ER={error}")
        axis.set(title=title, xlabel="correct rate of p̂", ylabel="explored conditions")
        axis.legend()
    for planner in summary["config"]["planners"]:
        for error in summary["config"]["error_rates"]:
            points = [(c["correct"], c["mean_cost"]) for c in cells if c["planner"] == planner and c["error"] == error]
            axes[2].plot([x for x, _ in points], [y for _, y in points], marker=".", label=f"{planner} ER={error}")
    axes[2].set(title="D(T)", xlabel="correct rate of p̂", ylabel="cost of the executed actions")
    axes[2].legend(fontsize=7)
    figure.tight_layout()
    path.parent.mkdir(parents=True, exist_ok=True)
    figure.savefig(path, dpi=110)
    plt.close(figure)
    return True
