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
from hbtp.bench.results import ResultsFile, Row, mean, median, optional, write_json
from hbtp.bench.runner import DEFAULT_EXECUTION, Execution, RunFailure, Work, hard_limit, run_work
from hbtp.datasets import load_dataset
from hbtp.datasets.records import Record
from hbtp.llm.parse import hints_from_record
from hbtp.planning import Limits, plan
from hbtp.planning.heuristic_names import HeuristicName
from hbtp.planning.planners import Space
from hbtp.planning.result import Status

log = logging.getLogger(__name__)

DATASET = "table1_robothow_100"
SCENARIO = "robothow"

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
    heuristic: HeuristicName = HeuristicName.NONE
    time_limit: float = 5.0
    limit: int | None = None  # only the first N tasks


@dataclass(frozen=True, kw_only=True)
class Table1Row(Row):
    """One planner on one task. A killed run's row has no ``goal``, ``generated`` or ``action_space``,
    and ``None`` for ``explored`` and ``cost``."""

    KEY = ("task", "planner", "space", "hints", "heuristic")

    task: str
    planner: str
    space: str
    hints: str
    heuristic: str
    p_star: int
    status: str
    solved: bool
    time_s: float
    explored: int | None
    cost: int | None
    goal: str | None = optional()
    generated: int | None = optional()
    action_space: int | None = optional()

    @property
    def timed_out(self) -> bool:
        """Stopped by its time limit, or killed past its hard limit."""
        return self.status in (Status.TIMEOUT.value, RunFailure.KILLED.value)


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
    results = ResultsFile(out / "results.jsonl", Table1Row)
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


def run_one(run: Table1Run) -> Table1Row:
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
    return Table1Row(
        task=record.id,
        goal=record.goal.strip(),
        planner=run.planner,
        space=run.space,
        hints=run.hints,
        heuristic=run.heuristic,
        status=result.status.value,
        solved=result.solved,
        cost=result.cost,
        explored=result.stats.explored,
        generated=result.stats.generated,
        time_s=round(result.stats.time_s, 6),
        action_space=result.stats.action_space,
        p_star=len(record.optimal_actions),
    )


def planner_figures(rows: Sequence[Table1Row]) -> dict[str, Any]:
    """One planner's Table I figures: counts over its rows, effort and cost over the solved ones."""
    solved = [r for r in rows if r.solved]
    times = [r.time_s for r in rows]
    return {
        "tasks": len(rows),
        "solved": len(solved),
        "timeouts": sum(r.timed_out for r in rows),
        "killed": sum(r.status == RunFailure.KILLED.value for r in rows),
        "mean_explored": mean(r.explored for r in solved),
        "mean_cost": mean(r.cost for r in solved),
        "mean_time_s": mean(times),
        "median_time_s": median(times),
        "max_time_s": max(times, default=None),
        "mean_explored_per_path": mean(r.explored / (r.p_star + 1) for r in solved if r.explored is not None),
    }


def summarise(rows: Sequence[Table1Row], config: Table1Config) -> dict[str, Any]:
    planners = {planner: planner_figures([r for r in rows if r.planner == planner]) for planner in config.planners}
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
