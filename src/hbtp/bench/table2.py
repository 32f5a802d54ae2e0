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
from collections.abc import Sequence
from dataclasses import dataclass, field, replace
from pathlib import Path
from typing import Any

from hbtp.bench.paper import paper_scenario
from hbtp.bench.plots import plot_table2
from hbtp.bench.report import table2_section, write_report
from hbtp.bench.results import ResultsFile, Row, mean, optional, write_json
from hbtp.bench.runner import DEFAULT_EXECUTION, Execution, RunFailure, Work, run_work
from hbtp.datasets import load_dataset
from hbtp.datasets.records import Record
from hbtp.domains.scenarios import Scenario
from hbtp.errors import InputError
from hbtp.llm.backend import Backend
from hbtp.llm.backends.first_reply import FirstReplyBackend
from hbtp.llm.backends.registry import BackendOptions, LlmSpec, make_backend
from hbtp.llm.parse import hints_from_record
from hbtp.llm.pool import example_pool
from hbtp.logic.tables import TaskTable
from hbtp.pipeline import LoopOptions, LoopResult, Outcome, run_hbtp
from hbtp.planning import Limits, plan, pruned_action_space, release_search_memory, resolve_hints
from hbtp.planning.heuristic_names import HeuristicName

log = logging.getLogger(__name__)

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
    #: Seconds for the paper's B-Time (OBTEA in the full space, no heuristic); 0 skips it.
    b_time_limit: float = 10.0


@dataclass(frozen=True, kw_only=True)
class Table2Row(Row):
    """The HBTP loop on one task with one backend in one run. The oracle columns (``A_star``,
    ``p_star``) are in every finished row, the B-Time ones (``b_*``) in run 0's when B-Time is run.
    A killed run's row has the fields known before it ran, with ``status`` and ``time_s``."""

    KEY = ("scenario", "task", "backend", "run")

    scenario: str
    task: str
    goal: str
    backend: str
    run: int
    outcome: str
    solved: bool
    rounds: int
    errors: tuple[str, ...]
    #: Of the successful round (``None`` without one).
    action_space: int | None = None
    p_hat: int | None = None
    cost: int | None = None
    explored: int | None = optional()
    planning_s: float | None = optional()
    llm_s: float | None = optional()
    repairs: int | None = optional()
    A_star: int | None = optional()
    p_star: int | None = optional()
    b_time_s: float | None = optional()
    b_solved: bool | None = optional()
    b_lm_time_s: float | None = optional()
    b_lm_solved: bool | None = optional()
    status: str | None = optional()
    time_s: float | None = optional()

    @property
    def loop_outcome(self) -> Outcome:
        """How the loop ended (``outcome`` read back)."""
        return Outcome.parse(self.outcome)


@dataclass(frozen=True)
class BTime:
    """B-Time of one task: OBTEA in the full action space without a heuristic (the paper's
    baseline), and with the landmark heuristic (``lm_``)."""

    time_s: float
    solved: bool
    lm_time_s: float
    lm_solved: bool


def _row(
    scenario: Scenario, record: Record, run: Table2Run, loop: LoopResult, a_star: int, b_time: BTime | None
) -> Table2Row:
    rounds = loop.rounds
    success = rounds[-1] if loop.outcome.feedback_rounds is not None else None
    return Table2Row(
        scenario=scenario.name,
        task=record.id,
        goal=record.goal.strip(),
        backend=run.backend,
        run=run.run,
        outcome=loop.outcome.label,
        solved=loop.solved,
        rounds=len(rounds),
        action_space=success.action_space if success else None,
        p_hat=len(success.hints.path) if success else None,
        explored=success.explored if success else loop.result.stats.explored,
        cost=loop.result.cost,
        planning_s=round(loop.planning_seconds, 6),
        llm_s=round(loop.llm_seconds, 6),
        repairs=sum(len(r.repairs) for r in rounds),
        errors=tuple(r.error for r in rounds if r.error),
        A_star=a_star,
        p_star=len(record.optimal_actions),
        b_time_s=b_time.time_s if b_time else None,
        b_solved=b_time.solved if b_time else None,
        b_lm_time_s=b_time.lm_time_s if b_time else None,
        b_lm_solved=b_time.lm_solved if b_time else None,
    )


@dataclass(frozen=True)
class BackendRecipe:
    """How a worker builds the LLM backend of a run: ``llm`` (a :data:`BACKENDS` name) with
    ``options`` (its seed is the run number), optionally behind recorded first-round replies."""

    llm: LlmSpec | None
    options: BackendOptions = field(default_factory=BackendOptions)
    first_replies: tuple[Record, ...] | None = None

    def __post_init__(self) -> None:
        if isinstance(self.llm, str):  # a name given as text by an untyped caller: read here
            object.__setattr__(self, "llm", LlmSpec.parse(self.llm))
        if self.llm is None and self.first_replies is None:
            raise InputError("give an LLM backend, recorded first replies, or both")

    @property
    def answers_by_planning(self) -> bool:
        """An oracle: its answers come from plans, so its time is not a model's."""
        return self.llm is not None and not self.llm.kind.is_model

    def make(self, scenario: Scenario, run: int) -> Backend:
        inner = make_backend(self.llm, scenario, replace(self.options, seed=run)) if self.llm else None
        if self.first_replies is not None:
            return FirstReplyBackend(list(self.first_replies), inner)
        assert inner is not None
        return inner


@dataclass(frozen=True)
class Table2Run:
    """One task of one scenario with one backend (the spec a worker runs)."""

    scenario: str
    record: Record
    backend: str
    recipe: BackendRecipe
    run: int
    loop: LoopOptions
    b_time_limit: float


#: Backends built by this (worker) process, per (recipe, scenario, run): a worker keeps its model
#: loaded across its tasks. At most :data:`BACKENDS_KEPT`, the oldest closed past it;
#: :func:`close_backends` empties it.
_BACKENDS: dict[tuple[BackendRecipe, str, int], Backend] = {}
BACKENDS_KEPT = 4


def _backend(recipe: BackendRecipe, scenario: Scenario, run: int) -> Backend:
    key = (recipe, scenario.name, run)
    if key not in _BACKENDS:
        while len(_BACKENDS) >= BACKENDS_KEPT:
            oldest = next(iter(_BACKENDS))
            _BACKENDS.pop(oldest).close()
        _BACKENDS[key] = recipe.make(scenario, run)
    return _BACKENDS[key]


def close_backends() -> None:
    """Close the backends this process built (workers' backends end with their process)."""
    while _BACKENDS:
        _, backend = _BACKENDS.popitem()
        backend.close()


_EXAMPLE_POOLS: TaskTable[list[Record]] = TaskTable("the scenario's example pool")


def _examples(scenario: Scenario) -> list[Record]:
    """The scenario's example pool, read once and kept with its task."""
    return _EXAMPLE_POOLS.of(scenario.task, lambda: example_pool(scenario), key=scenario.name)


def run_one(run: Table2Run) -> Table2Row:
    """The HBTP loop on one task, with the oracle columns and the B-Time baseline."""
    scenario = paper_scenario(run.scenario)
    record = run.record
    loop = run_hbtp(scenario, record.goal, _backend(run.recipe, scenario, run.run), _examples(scenario), run.loop)
    a_star = oracle_space(scenario, record)
    b_time = b_time_of(scenario, record, run.b_time_limit) if run.b_time_limit > 0 and run.run == 0 else None
    return _row(scenario, record, run, loop, a_star, b_time)


def oracle_space(scenario: Scenario, record: Record) -> int:
    """|A*|: the action space pruned by the record's own vital predicates and objects, plus its plan."""
    task = scenario.task
    return len(pruned_action_space(task, resolve_hints(task, hints_from_record(record))))


def b_time_of(scenario: Scenario, record: Record, time_limit: float) -> BTime:
    """B-Time: OBTEA in the full action space without a heuristic (the paper's baseline), and the
    same with the landmark heuristic (hbtp's default planner)."""
    runs: list[tuple[float, bool]] = []
    for heuristic in (HeuristicName.NONE, HeuristicName.LM):
        result = plan(
            scenario.task,
            record.goal,
            "obtea",
            mutexes=scenario.mutexes,
            heuristic=heuristic,
            limits=Limits(time_s=time_limit),
        )
        runs.append((round(result.stats.time_s, 6), result.solved))
        release_search_memory()
    (time_s, solved), (lm_time_s, lm_solved) = runs
    return BTime(time_s, solved, lm_time_s, lm_solved)


def kill_after(config: Table2Config, llm_timeout: float) -> float:
    """A generous hard limit for one task: every round's LLM requests and planning, the fallback
    and the B-Time runs, and a minute of slack."""
    loop = config.loop
    rounds = loop.feedback_rounds + 1
    llm = rounds * (loop.grammar_retries + 1) * llm_timeout
    return llm + rounds * loop.round_time_limit + loop.fallback_time_limit + 2 * config.b_time_limit + 60.0


def run_table2(
    config: Table2Config,
    recipe: BackendRecipe,
    out: Path,
    execution: Execution = DEFAULT_EXECUTION,
) -> dict[str, Any]:
    """Run (or resume) one scenario's Table II into ``out``."""
    scenario = paper_scenario(config.scenario)
    dataset = config.dataset or scenario.test_set
    if dataset is None:
        raise InputError(f"scenario {scenario.name} has no test set")
    records = load_dataset(dataset)[: config.limit]
    loop_options = replace(config.loop, prompt=replace(config.loop.prompt, exclude_same_goal=True))
    results = ResultsFile(out / "results.jsonl", Table2Row)
    work = [
        Work(
            (scenario.name, record.id, config.backend, run),
            Table2Run(scenario.name, record, config.backend, recipe, run, loop_options, config.b_time_limit),
            {
                "scenario": scenario.name,
                "task": record.id,
                "goal": record.goal.strip(),
                "backend": config.backend,
                "run": run,
                "outcome": Outcome.FAILED.label,
                "rounds": 0,
                "errors": [RunFailure.KILLED.value],
            },
            stage=f"run {run}" if config.runs > 1 else "",
        )
        for run in range(config.runs)
        for record in records
    ]
    try:
        run_work(
            run_one,
            work,
            results,
            execution,
            kill_after=kill_after(config, recipe.options.timeout),
            description=f"table2 {scenario.name}",
        )
    finally:
        close_backends()
    summary = summarise(list(results.ordered(w.key for w in work)), scenario, dataset, config)
    write_json(out / "summary.json", summary)
    return summary


def write_table2_report(out: Path, summaries: list[dict[str, Any]]) -> None:
    """``summary.json``, ``report.md`` and ``table2.png`` over the scenarios run into ``out``."""
    write_json(out / "summary.json", {"scenarios": summaries})
    write_report(out / "report.md", "Table II", [table2_section(summaries)])
    plot_table2(summaries, out / "table2.png")


def _rate(hits: int, rows: Sequence[Table2Row]) -> float | None:
    """``hits`` as a percentage of the rows, to 2 places (``None`` without rows)."""
    return round(100.0 * hits / len(rows), 2) if rows else None


def success_rates(rows: Sequence[Table2Row]) -> dict[str, float | None]:
    """``NF``, ``1F``, ``2F``, ``3F``: success with at most 0, 1, 2, 3 feedback rounds; ``final``:
    also with the full-space fallback."""
    needed = [row.loop_outcome.feedback_rounds for row in rows]
    rates = {
        label: _rate(sum(n is not None and n <= rounds for n in needed), rows)
        for label, rounds in (("NF", 0), ("1F", 1), ("2F", 2), ("3F", 3))
    }
    rates["final"] = _rate(sum(row.solved for row in rows), rows)
    return rates


def _b_time(rows: Sequence[Table2Row]) -> dict[str, Any]:
    """B-Time over the rows that ran it: solved tasks and mean seconds, without and with lm."""
    baseline = [r for r in rows if r.b_time_s is not None]
    return {
        "b_tasks": len(baseline),
        "b_solved": sum(bool(r.b_solved) for r in baseline),
        "b_mean_time_s": mean(r.b_time_s for r in baseline),
        "b_lm_solved": sum(bool(r.b_lm_solved) for r in baseline),
        "b_lm_mean_time_s": mean(r.b_lm_time_s for r in baseline),
    }


def summarise(rows: Sequence[Table2Row], scenario: Scenario, dataset: str, config: Table2Config) -> dict[str, Any]:
    successful = [r for r in rows if r.loop_outcome.feedback_rounds is not None]
    first = [r for r in rows if r.run == 0]
    runs = sorted({r.run for r in rows})
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
        **success_rates(rows),
        "fallback": _rate(sum(r.loop_outcome == Outcome.FALLBACK for r in rows), rows),
        "A_minus": mean(r.action_space for r in successful),
        "p_hat": mean(r.p_hat for r in successful),
        "explored": mean(r.explored for r in successful),
        "mean_planning_s": mean(r.planning_s for r in rows),
        "mean_llm_s": mean(r.llm_s for r in rows),
        "killed": sum(r.status == RunFailure.KILLED.value for r in rows),
        "NF_per_run": [success_rates([r for r in rows if r.run == run])["NF"] for run in runs]
        if len(runs) > 1
        else None,
        "A_star": mean(r.A_star for r in first),
        "p_star": mean(r.p_star for r in first),
        "b_time_limit": config.b_time_limit,
        **_b_time(first),
        "paper": PAPER.get(scenario.name, {}),
    }
