"""Table II of the paper: LLM reasoning with HBTP on the four scenarios' test sets.

Per task: the HBTP loop (reason, check, prune, plan; reflective feedback; fallback) with any backend.
The summary reports success with no feedback (NF), up to one (1F), two (2F) and three (3F) rounds,
the final success including the full-space fallback, and the means of |A⁻| (the action space of the
successful round), |p̂|, |S⁻|, planning and LLM time, beside the paper's numbers. Demonstrations of
the very goal being asked are excluded by default (37 of the 50 RoboWaiter test goals are in its
example pool).
"""

from __future__ import annotations

import logging
from collections.abc import Callable, Sequence
from dataclasses import dataclass, field, replace
from pathlib import Path
from typing import Any

from tqdm import tqdm

from hbtp.bench.results import ResultsFile, mean, write_json
from hbtp.datasets import load_dataset
from hbtp.datasets.records import Record
from hbtp.domains import load_scenario
from hbtp.domains.scenarios import Scenario
from hbtp.llm.backend import Backend
from hbtp.llm.pool import example_pool
from hbtp.pipeline import LoopOptions, run_hbtp
from hbtp.pipeline.loop import feedback_rounds_of

log = logging.getLogger(__name__)

KEY = ("scenario", "task", "backend", "run")

#: Table II of the paper (gpt-4o-mini, 50 tasks per scenario, averaged over three runs).
_PAPER_COLUMNS = (
    "A",
    "Q",
    "O",
    "A_star",
    "p_star",
    "NF",
    "1F",
    "3F",
    "A_minus",
    "p_hat",
    "explored",
    "time_s",
    "b_time",
)
_PAPER_ROWS: dict[str, tuple[Any, ...]] = {
    "robowaiter": (174, 6, 31, 2.46, 2.46, 92.0, 98.67, 99.33, 2.54, 2.46, 3.99, 0.0004, "0.0008 s"),
    "virtualhome": (480, 11, 36, 8.02, 6.58, 90.67, 97.33, 98.0, 7.93, 6.66, 28.39, 0.0053, "> 1 min"),
    "robothow-small": (155, 16, 17, 5.52, 4.54, 74.0, 80.67, 84.67, 8.63, 4.55, 13.98, 0.0041, "0.5747 s"),
    "robothow": (7338, 16, 126, 12.3, 8.04, 52.67, 77.33, 83.33, 13.97, 8.19, 103.16, 0.0344, "> 1 h"),
}
PAPER = {name: dict(zip(_PAPER_COLUMNS, row, strict=True)) for name, row in _PAPER_ROWS.items()}


@dataclass(frozen=True)
class Table2Config:
    scenario: str
    backend: str
    dataset: str | None = None  # default: the scenario's Table II test set
    runs: int = 1
    limit: int | None = None
    loop: LoopOptions = field(default_factory=lambda: LoopOptions())


def _row(scenario: Scenario, record: Record, backend_name: str, run: int, loop: Any) -> dict[str, Any]:
    rounds = loop.rounds
    success = rounds[-1] if feedback_rounds_of(loop.outcome) is not None else None
    return {
        "scenario": scenario.name,
        "task": record.id,
        "goal": record.goal.strip(),
        "backend": backend_name,
        "run": run,
        "outcome": loop.outcome,
        "solved": loop.solved,
        "rounds": len(rounds),
        "action_space": success.action_space if success else None,
        "p_hat": len(success.hints.path) if success else None,
        "explored": success.explored if success else loop.result.stats.explored,
        "cost": loop.result.cost,
        "planning_s": round(loop.planning_seconds, 6),
        "llm_s": round(loop.llm_seconds, 6),
        "repairs": sum(len(r.repairs) for r in rounds),
        "errors": [r.error for r in rounds if r.error],
    }


def run_table2(
    config: Table2Config,
    make_backend: Callable[[Scenario, int], Backend],
    out: Path,
    *,
    progress: bool = True,
) -> dict[str, Any]:
    """Run (or resume) one scenario's Table II into ``out``; ``make_backend(scenario, run)``."""
    scenario = load_scenario(config.scenario)
    dataset = config.dataset or scenario.test_set
    if dataset is None:
        raise ValueError(f"scenario {scenario.name} has no test set")
    records = load_dataset(dataset)[: config.limit]
    pool = example_pool(scenario)
    loop_options = replace(config.loop, prompt=replace(config.loop.prompt, exclude_same_goal=True))
    results = ResultsFile(out / "results.jsonl", KEY)
    keys = [(scenario.name, r.id, config.backend, run) for run in range(config.runs) for r in records]
    pending = [k for k in keys if k not in results]
    by_id = {r.id: r for r in records}
    bar = tqdm(total=len(keys), initial=len(keys) - len(pending), desc=f"table2 {scenario.name}", disable=not progress)
    backends: dict[int, Backend] = {}
    try:
        for _, task_id, _, run in pending:
            backend = backends.get(run)
            if backend is None:
                backend = backends[run] = make_backend(scenario, run)
            loop = run_hbtp(scenario, by_id[task_id].goal, backend, pool, loop_options)
            results.append(_row(scenario, by_id[task_id], config.backend, run, loop))
            bar.update(1)
    finally:
        bar.close()
        for backend in backends.values():
            backend.close()
    summary = summarise(list(results.ordered(keys)), scenario, dataset, config)
    write_json(out / "summary.json", summary)
    return summary


def summarise(rows: Sequence[dict[str, Any]], scenario: Scenario, dataset: str, config: Table2Config) -> dict[str, Any]:
    def within(rounds: int | None) -> float | None:
        """Success rate with at most ``rounds`` feedback rounds (``None``: also the fallback)."""
        if not rows:
            return None
        hits = 0
        for row in rows:
            needed = feedback_rounds_of(row["outcome"])
            hits += (needed is not None and needed <= rounds) if rounds is not None else row["solved"]
        return round(100.0 * hits / len(rows), 2)

    successful = [r for r in rows if feedback_rounds_of(r["outcome"]) is not None]
    return {
        "scenario": scenario.name,
        "dataset": dataset,
        "backend": config.backend,
        "runs": config.runs,
        "tasks": len(rows),
        "problem": {
            "A": len(scenario.task.actions),
            "Q": len(scenario.task.action_predicates),
            "O": len(scenario.task.objects),
        },
        "NF": within(0),
        "1F": within(1),
        "2F": within(2),
        "3F": within(3),
        "final": within(None),
        "fallback": round(100.0 * sum(r["outcome"] == "fallback" for r in rows) / len(rows), 2) if rows else None,
        "A_minus": mean([r["action_space"] for r in successful]),
        "p_hat": mean([r["p_hat"] for r in successful]),
        "explored": mean([r["explored"] for r in successful]),
        "mean_planning_s": mean([r["planning_s"] for r in rows]),
        "mean_llm_s": mean([r["llm_s"] for r in rows]),
        "paper": PAPER.get(scenario.name, {}),
    }
