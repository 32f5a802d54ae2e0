"""Auto mode: plan LLM-free first, and ask the LLM only when that takes longer than a model call.

Measured (``hbtp bench payoff``, docs/llm.md "When does the LLM pay?"): the LLM-free search with the
landmark heuristic solves most tasks in milliseconds, while one call of the local model takes
seconds (and loading it 1.5 s); only long-horizon tasks, whose LLM-free search takes seconds, can
gain from hints. So :func:`plan_auto` first runs that search (the configured planner, the fallback's
heuristic, the full action space, no hints) for ``probe_seconds``, about one model call. A verdict
(solved, or proved unsolvable) is returned at once: the backend is never built, so a local model is
never loaded. Otherwise the HBTP loop (:func:`~hbtp.pipeline.loop.run_hbtp`: LLM rounds, feedback,
fallback) runs in the time that is left before ``deadline``, which bounds the whole call.
"""

from __future__ import annotations

import math
import time
from collections.abc import Callable, Sequence
from dataclasses import dataclass
from typing import Any

from hbtp.datasets.records import Record
from hbtp.deadline import Deadline, expired, within
from hbtp.domains.scenarios import Scenario
from hbtp.llm.backend import Backend
from hbtp.logic.task import Goal
from hbtp.pipeline.loop import LoopOptions, run_hbtp
from hbtp.pipeline.results import LoopResult
from hbtp.planning.limits import Limits
from hbtp.planning.planners import Space, plan
from hbtp.planning.result import PlanResult, Status

__all__ = ["DEFAULT_PROBE_SECONDS", "AutoResult", "BackendFactory", "plan_auto"]

#: About one call of the local model (0.97-18.2 s per task measured, 2.1 s median on Table I tasks).
DEFAULT_PROBE_SECONDS = 2.0

#: Builds the backend; called only when the LLM-free probe gave no verdict.
BackendFactory = Callable[[], Backend]

#: Statuses of the probe that end auto mode: a tree, or a proof that there is none.
_VERDICTS = frozenset({Status.SOLVED, Status.UNSOLVABLE})


@dataclass(frozen=True)
class AutoResult:
    """The LLM-free probe, and the HBTP loop when the probe gave no verdict (``loop`` ``None``: the
    LLM was never asked, its backend never built)."""

    probe: PlanResult
    probe_budget_s: float
    probe_s: float
    loop: LoopResult | None

    @property
    def result(self) -> PlanResult:
        """The final result: the loop's when it ran, else the probe's."""
        return self.loop.result if self.loop is not None else self.probe

    @property
    def asked_llm(self) -> bool:
        return self.loop is not None

    @property
    def solved(self) -> bool:
        return self.result.solved

    def to_dict(self) -> dict[str, Any]:
        return {
            "probe_s": round(self.probe_s, 6),
            "probe_budget_s": self.probe_budget_s,
            "probe_status": self.probe.status.value,
            "asked_llm": self.asked_llm,
        }


def plan_auto(
    scenario: Scenario,
    goal: Goal | str,
    backend_factory: BackendFactory,
    pool: Sequence[Record] | Callable[[], Sequence[Record]] = (),
    options: LoopOptions | None = None,
    probe_seconds: float = DEFAULT_PROBE_SECONDS,
    deadline: Deadline | None = None,
) -> AutoResult:
    """Plan ``goal`` LLM-free for ``probe_seconds``; without a verdict, run the HBTP loop with the
    backend ``backend_factory()`` (closed afterwards) and ``pool`` (or ``pool()``, built only then)."""
    if not (probe_seconds > 0 and not math.isnan(probe_seconds)):
        raise ValueError(f"the probe needs a positive number of seconds, not {probe_seconds}")
    options = options or LoopOptions()
    started = time.perf_counter()
    scenario, resolved = scenario.resolve_goal(goal)
    probe = plan(
        scenario.task,
        resolved,
        options.planner,
        space=Space.FULL,
        mutexes=scenario.mutexes,  # plan() re-checks a failure without declared mutexes: a verdict is a proof
        heuristic=options.fallback_heuristic,
        limits=Limits(deadline=within(deadline, probe_seconds)),
    )
    probe_s = time.perf_counter() - started
    if probe.status in _VERDICTS:
        return AutoResult(probe, probe_seconds, probe_s, None)
    if expired(deadline):  # no time to ask: do not build (or load) the backend
        return AutoResult(probe, probe_seconds, probe_s, None)
    if options.progress is not None:
        options.progress(f"no verdict LLM-free in {probe_s:.2f} s ({probe.status.value}): asking the LLM")
    backend = backend_factory()
    try:
        examples = pool() if callable(pool) else pool
        loop = run_hbtp(scenario, resolved, backend, examples, options, deadline)
    finally:
        backend.close()
    return AutoResult(probe, probe_seconds, probe_s, loop)
