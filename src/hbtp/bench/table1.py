"""Table I of the paper: the four planners on the Table I tasks, pruned or full action space."""

from __future__ import annotations

import logging
from collections.abc import Sequence
from dataclasses import dataclass
from pathlib import Path
from typing import Any, Literal

from hbtp.bench.paper import paper_scenario
from hbtp.bench.plots import plot_table1
from hbtp.bench.report import table1_section, write_report
from hbtp.bench.results import ResultsFile, mean, median, write_json
from hbtp.bench.runner import DEFAULT_EXECUTION, Execution, RunFailure, Work, hard_limit, run_work
from hbtp.datasets import load_dataset
from hbtp.datasets.records import Record
from hbtp.llm.parse import hints_from_record
from hbtp.planning import Limits, plan
from hbtp.planning.heuristics import HeuristicName
from hbtp.planning.planners import Space
from hbtp.planning.result import Status

log = logging.getLogger(__name__)

DATASET = "table1_robothow_100"
SCENARIO = "robothow"
KEY = ("task", "planner", "space", "hints", "heuristic")

#: The paper's Table I and the reference implementation's figures (reference_results.md).
PAPER = {
    "pruned": {
        "bte": {"explored": 41.0, "cost": 59.86},
        "obtea": {"explored": 34.5, "cost": 58.64},
        "hbtp-o": {"explored": 25.43, "cost": 58.64},
        "hbtp-s": {"explored": 18.17, "cost": 58.83},
    },
    "full": {
        "bte": {"explored": 117.8, "timeout_rate": 0.79},
        "obtea": {"explored": 405.3, "timeout_rate": 0.82},
        "hbtp-o": {"explored": 27.71, "timeout_rate": 0.09},
        "hbtp-s": {"explored": 23.87, "timeout_rate": 0.04},
    },
}
REFERENCE = {
    "pruned": {
        "bte": {"explored": "40.7-45.6", "cost": 59.86, "mean_time_s": 0.129, "median_time_s": 0.020},
        "obtea": {"explored": 34.50, "cost": 58.64, "mean_time_s": 0.036, "median_time_s": 0.012},
        "hbtp-o": {"explored": 25.43, "cost": 58.64, "mean_time_s": 0.027, "median_time_s": 0.013},
        "hbtp-s": {"explored": 18.17, "cost": 58.94, "mean_time_s": 0.017, "median_time_s": 0.012},
    },
    "full": {
        "bte": {"timeout_rate": 0.83},
        "obtea": {"timeout_rate": 0.83},
        "hbtp-o": {"timeout_rate": 0.44},
        "hbtp-s": {"timeout_rate": 0.31},
    },
}


@dataclass(frozen=True)
class Table1Config:
    space: Space = Space.PRUNED
    planners: tuple[str, ...] = ("bte", "obtea", "hbtp-o", "hbtp-s")
    hints: Literal["oracle", "none"] = "oracle"
    heuristic: HeuristicName = "none"
    time_limit: float = 5.0
    limit: int | None = None  # only the first N tasks


@dataclass(frozen=True)
class Table1Run:
    """One planner on one task (the spec a worker runs)."""

    record: Record
    planner: str
    space: Space
    hints: Literal["oracle", "none"]
    heuristic: HeuristicName
    time_limit: float


def run_table1(config: Table1Config, out: Path, execution: Execution = DEFAULT_EXECUTION) -> dict[str, Any]:
    """Run (or resume) Table I into ``out``; returns the summary (also written to summary.json)."""
    records = load_dataset(DATASET)[: config.limit]
    results = ResultsFile(out / "results.jsonl", KEY)
    work = [
        Work(
            (record.id, planner, config.space, config.hints, config.heuristic),
            Table1Run(record, planner, config.space, config.hints, config.heuristic, config.time_limit),
            {
                "task": record.id,
                "planner": planner,
                "space": config.space,
                "hints": config.hints,
                "heuristic": config.heuristic,
                "p_star": len(record.optimal_actions),
                "explored": None,
                "cost": None,
            },
            stage=f"{setting_name(config)} {planner}",
        )
        for planner in config.planners
        for record in records
    ]
    run_work(run_one, work, results, execution, kill_after=hard_limit(config.time_limit), description="table1")
    summary = summarise(list(results.ordered(w.key for w in work)), config)
    write_json(out / "summary.json", summary)
    write_table1_report(out, {setting_label(config): summary})
    return summary


def setting_label(config: Table1Config) -> str:
    """``pruned space, oracle hints`` or ``full space, no hints, heuristic lm``."""
    label = f"{config.space} space, {'oracle hints' if config.hints == 'oracle' else 'no hints'}"
    return label + (f", heuristic {config.heuristic}" if config.heuristic != "none" else "")


def setting_name(config: Table1Config) -> str:
    """The setting in a few words for progress bars: ``pruned``, ``full``, ``full no-hints lm``."""
    words: list[str] = [config.space]
    if config.hints == "none":
        words.append("no-hints")
    if config.heuristic != "none":
        words.append(config.heuristic)
    return " ".join(words)


def write_table1_report(out: Path, summaries: dict[str, dict[str, Any]]) -> None:
    """``report.md`` and ``table1.png`` for one or more Table I settings."""
    write_report(out / "report.md", "Table I", [table1_section(summaries)])
    plot_table1(summaries, out / "table1.png")


def run_one(run: Table1Run) -> dict[str, Any]:
    """Plan one Table I task (in a worker; the scenario is loaded once per process)."""
    scenario = paper_scenario(SCENARIO)
    record = run.record
    hints = hints_from_record(record) if run.hints == "oracle" else None
    space = run.space if hints is not None else Space.FULL
    result = plan(
        scenario.task,
        record.goal,
        run.planner,
        hints=hints,
        space=space,
        mutexes=scenario.mutexes,
        heuristic=run.heuristic,
        limits=Limits(time_s=run.time_limit),
    )
    return {
        "task": record.id,
        "goal": record.goal.strip(),
        "planner": run.planner,
        "space": run.space,
        "hints": run.hints,
        "heuristic": run.heuristic,
        "status": result.status.value,
        "solved": result.solved,
        "cost": result.cost,
        "explored": result.stats.explored,
        "generated": result.stats.generated,
        "time_s": round(result.stats.time_s, 6),
        "action_space": result.stats.action_space,
        "p_star": len(record.optimal_actions),
    }


def summarise(rows: Sequence[dict[str, Any]], config: Table1Config) -> dict[str, Any]:
    planners: dict[str, Any] = {}
    for planner in config.planners:
        mine = [r for r in rows if r["planner"] == planner]
        solved = [r for r in mine if r["solved"]]
        planners[planner] = {
            "tasks": len(mine),
            "solved": len(solved),
            "timeouts": sum(r["status"] in (Status.TIMEOUT.value, RunFailure.KILLED.value) for r in mine),
            "killed": sum(r["status"] == RunFailure.KILLED.value for r in mine),
            "mean_explored": mean([r["explored"] for r in solved]),
            "mean_cost": mean([r["cost"] for r in solved]),
            "mean_time_s": mean([r["time_s"] for r in mine]),
            "median_time_s": median([r["time_s"] for r in mine]),
            "max_time_s": max((r["time_s"] for r in mine), default=None),
            "mean_explored_per_path": mean([r["explored"] / (r["p_star"] + 1) for r in solved]),
        }
    return {
        "dataset": DATASET,
        "scenario": SCENARIO,
        "config": {
            "space": config.space,
            "hints": config.hints,
            "heuristic": config.heuristic,
            "time_limit": config.time_limit,
            "tasks": config.limit,
        },
        "planners": planners,
        "paper": PAPER.get(config.space, {}),
        "reference": REFERENCE.get(config.space, {}),
    }
