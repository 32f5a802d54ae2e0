"""Figure 3 of the paper: planning time against the size of the action space, and against |p*|.

(a) RobotHow with its objects cloned ``factor`` times (:mod:`hbtp.domains.scale`; 7329 actions at 1x,
about 62,600 at 3x); each planner plans the first Table I tasks in the full action space: BT
Expansion and OBTEA without hints, HBTP-O and HBTP-S with the records' plans as p̂ (oracle); with
``--space pruned`` all four plan in the records' pruned spaces instead. A run that hits the time
limit counts with the limit as its time (so means are lower bounds). (b) The same runs at 1x,
grouped by the length of the optimal path |p*|.
"""

from __future__ import annotations

import functools
from collections.abc import Sequence
from dataclasses import dataclass
from pathlib import Path
from typing import Any

from hbtp.bench.paper import paper_scaled, paper_scenario
from hbtp.bench.plots import plot_fig3
from hbtp.bench.report import fig3_section, write_report
from hbtp.bench.results import ResultsFile, Row, mean, median, optional, write_json
from hbtp.bench.runner import DEFAULT_EXECUTION, Execution, Work, hard_limit, run_work
from hbtp.datasets import load_dataset, validate_records
from hbtp.datasets.records import Record
from hbtp.llm.parse import hints_from_record
from hbtp.planning import Limits, plan
from hbtp.planning.heuristic_names import HeuristicName
from hbtp.planning.planners import Space

DATASET = "table1_robothow_100"
HINTED = ("hbtp-o", "hbtp-s")


@dataclass(frozen=True)
class Fig3Config:
    scales: tuple[float, ...] = (1.0, 1.5, 2.0, 2.5, 3.0)
    planners: tuple[str, ...] = ("bte", "obtea", "hbtp-o", "hbtp-s")
    space: Space = Space.FULL
    heuristic: HeuristicName = HeuristicName.NONE
    time_limit: float = 5.0
    limit: int | None = 20


@dataclass(frozen=True, kw_only=True)
class Fig3Row(Row):
    """One planner on one task at one scale. A killed run's row has no ``actions`` or
    ``action_space``, and ``None`` for ``explored``."""

    KEY = ("scale", "task", "planner", "space", "heuristic")

    scale: float
    task: str
    p_star: int
    planner: str
    space: str
    heuristic: str
    status: str
    solved: bool
    time_s: float
    explored: int | None
    actions: int | None = optional()
    action_space: int | None = optional()


@dataclass(frozen=True)
class Fig3Run:
    """One planner on one task at one scale (the spec a worker runs)."""

    scale: float
    record: Record
    planner: str
    space: Space
    heuristic: HeuristicName
    time_limit: float


def run_fig3(config: Fig3Config, out: Path, execution: Execution = DEFAULT_EXECUTION) -> dict[str, Any]:
    """Run (or resume) Figure 3 into ``out``; returns the summary (also summary.json, fig3.png)."""
    base = paper_scenario("robothow")
    records = load_dataset(DATASET)
    invalid = set(validate_records(records, base.task).invalid_ids)
    records = [r for r in records if r.id not in invalid][: config.limit]
    results = ResultsFile(out / "results.jsonl", Fig3Row)
    work = [
        Work(
            (scale, record.id, planner, config.space, config.heuristic),
            Fig3Run(scale, record, planner, config.space, config.heuristic, config.time_limit),
            {
                "scale": scale,
                "task": record.id,
                "p_star": len(record.optimal_actions),
                "planner": planner,
                "space": config.space,
                "heuristic": config.heuristic,
                "explored": None,
            },
            stage=" ".join([config.space, *([config.heuristic] if config.heuristic != "none" else []), f"x{scale:g}"]),
        )
        for scale in config.scales
        for record in records
        for planner in config.planners
    ]
    # Generating a scaled scenario takes seconds: allow for it in the hard limit.
    run_work(
        run_one, work, results, execution, kill_after=hard_limit(config.time_limit, slack=300.0), description="fig3"
    )
    summary = summarise(list(results.ordered(w.key for w in work)), config)
    write_json(out / "summary.json", summary)
    plot_fig3(summary, out / "fig3.png")
    write_report(out / "report.md", "Figure 3", [fig3_section(summary)])
    return summary


#: The scaled scenarios a worker process has built. A per-process cache, not a per-task table (it
#: makes the task): building one takes seconds, and runs come ordered by scale, so two (the scale
#: being run and the one before) bound the memory of a worker while sparing every rebuild.
_scaled = functools.lru_cache(maxsize=2)(paper_scaled)


def run_one(run: Fig3Run) -> Fig3Row:
    """Plan one task in RobotHow grown ``run.scale`` times."""
    scenario = _scaled("robothow", run.scale)
    record = run.record
    hinted = run.space == "pruned" or run.planner in HINTED
    result = plan(
        scenario.task,
        record.goal,
        run.planner,
        hints=hints_from_record(record) if hinted else None,
        space=run.space,
        mutexes=scenario.mutexes,
        heuristic=run.heuristic,
        limits=Limits(time_s=run.time_limit),
    )
    return Fig3Row(
        scale=run.scale,
        actions=len(scenario.task.actions),
        task=record.id,
        p_star=len(record.optimal_actions),
        planner=run.planner,
        space=run.space,
        heuristic=run.heuristic,
        action_space=result.stats.action_space,
        status=result.status.value,
        solved=result.solved,
        explored=result.stats.explored,
        time_s=round(result.stats.time_s, 6),
    )


def _by_size(rows: Sequence[Fig3Row], scale: float, planner: str) -> dict[str, Any]:
    """(a): one planner at one scale (``rows`` its rows)."""
    times = [r.time_s for r in rows]
    return {
        "scale": scale,
        "actions": next((r.actions for r in rows if r.actions is not None), None),
        "planner": planner,
        "tasks": len(rows),
        "solved": sum(r.solved for r in rows),
        "mean_time_s": mean(times),
        "median_time_s": median(times),
    }


def _by_length(rows: Sequence[Fig3Row], planner: str, length: int) -> dict[str, Any]:
    """(b): one planner on the tasks of one |p*| at the first scale (``rows`` its rows)."""
    return {
        "planner": planner,
        "p_star": length,
        "tasks": len(rows),
        "solved": sum(r.solved for r in rows),
        "mean_time_s": mean(r.time_s for r in rows),
    }


def summarise(rows: Sequence[Fig3Row], config: Fig3Config) -> dict[str, Any]:
    by_size = []
    for scale in config.scales:
        for planner in config.planners:
            mine = [r for r in rows if r.scale == scale and r.planner == planner]
            if mine:
                by_size.append(_by_size(mine, scale, planner))
    base = [r for r in rows if r.scale == config.scales[0]]
    by_length = [
        _by_length([r for r in base if r.planner == planner and r.p_star == length], planner, length)
        for planner in config.planners
        for length in sorted({r.p_star for r in base})
    ]
    return {
        "dataset": DATASET,
        "config": {
            "scales": list(config.scales),
            "planners": list(config.planners),
            "space": config.space,
            "heuristic": config.heuristic,
            "time_limit": config.time_limit,
            "tasks": config.limit,
        },
        "by_action_space": by_size,
        "by_path_length": by_length,
    }
