"""``hbtp plan`` run: one session (the deadline, the world, the goal, the LLM backend, each made
once), one strategy per mode, one outcome for the report.

The modes (:class:`Mode`): plan once LLM-free (``--hints`` optional), the HBTP loop with an LLM,
``--llm auto:BACKEND`` (LLM-free first, the LLM only without a verdict), and the loop in a world
pruned before grounding. ``-t`` counts from the command's start and bounds all of it, every LLM
call included (:meth:`PlanSession.time_left`).

With ``--instruction``, the goal is asked of the ``--llm`` backend (``local`` by default); that
same backend (one loaded model) then serves the hints in auto mode, so the model is asked for
hints only when LLM-free planning finds no verdict in ``--auto-probe`` seconds.
"""

from __future__ import annotations

import enum
import logging
import sys
from collections.abc import Callable

import click

from hbtp.cli.goal_input import read_goal
from hbtp.cli.hints_file import load_hints
from hbtp.cli.instruction_input import DEFAULT_INSTRUCTION_BACKEND, choose_goal
from hbtp.cli.plan_command import Grounding, PlanRequest
from hbtp.cli.plan_report import PlanOutcome, PlanReport
from hbtp.deadline import Deadline
from hbtp.domains import Scenario
from hbtp.errors import InputError
from hbtp.llm.backend import Backend
from hbtp.llm.backends.local import LocalBackend
from hbtp.llm.backends.registry import BackendOptions, LlmSpec, make_backend, make_goal_backend
from hbtp.llm.pool import example_pool
from hbtp.logic.task import Goal
from hbtp.pipeline import LoopOptions, plan_auto, run_hbtp
from hbtp.pipeline.instruct import GoalChoice, InstructOptions
from hbtp.pipeline.loop import Progress
from hbtp.planning import plan
from hbtp.planning.planners import Space, check_alpha, planner_config

log = logging.getLogger(__name__)


class Mode(enum.Enum):
    """How ``hbtp plan`` plans (see the module docstring)."""

    PLAIN = "plain"
    LOOP = "loop"
    AUTO = "auto"
    PRUNED = "pruned"


def mode_of(request: PlanRequest) -> Mode:
    """The mode ``request`` asks for; with ``--instruction`` the hints come in auto mode."""
    spec = request.llm.llm
    if spec is None:
        return Mode.PLAIN
    if request.instruction is not None and request.llm.grounding is Grounding.PRUNED:
        raise InputError(
            "--instruction does not go with --grounding pruned (the instruction is read in the whole world)"
        )
    if spec.auto or request.instruction is not None:
        if request.llm.grounding is Grounding.PRUNED:
            raise InputError("--grounding pruned does not go with --llm auto (its probe plans in the whole world)")
        return Mode.AUTO
    return Mode.PRUNED if request.llm.pruned(request.source) else Mode.LOOP


class PlanSession:
    """One ``hbtp plan``: its request, the deadline of ``-t`` (started now), and the LLM backends,
    each built (and a local model loaded) once and closed by :meth:`close`."""

    def __init__(self, request: PlanRequest) -> None:
        self.request = request
        # One deadline for the whole command: loading, grounding, every LLM call and every search.
        self.limits = request.search.limits().starting_now()
        self.progress = _progress(request.outputs.as_json)
        self.chosen: GoalChoice | None = None
        self._backends: dict[str, Backend] = {}

    @property
    def deadline(self) -> Deadline | None:
        """The deadline of ``-t``, started with the command: every phase gets it."""
        return self.limits.deadline

    def load(self) -> Scenario:
        return self.request.source.load(deadline=self.deadline)

    def resolve(self, scenario: Scenario) -> tuple[Scenario, Goal]:
        """The goal (``-g``, the instruction's, or the problem's ``:goal``) resolved in ``scenario``."""
        request = self.request
        if request.instruction is not None:
            if request.goal is not None:
                raise InputError("give the goal (-g) or an instruction (--instruction), not both")
            spec = request.llm.llm or LlmSpec.parse(DEFAULT_INSTRUCTION_BACKEND)
            options = InstructOptions(rounds=request.llm.feedback_rounds, seed=request.llm.seed)
            backend = self.goal_backend(spec, scenario)
            self.chosen = choose_goal(
                scenario, request.instruction, backend, options, self.deadline, as_json=request.outputs.as_json
            )
            text = self.chosen.goal or ""
        else:
            text = read_goal(request.goal) if request.goal is not None else scenario.problem_goal()
        return scenario.resolve_goal(text)

    def backend(self, spec: LlmSpec, scenario: Scenario) -> Backend:
        """The backend that gives hints: a model backend is the one that read the instruction."""
        return self._shared(spec, "hints", lambda: make_backend(spec.backend, scenario, self._options()))

    def goal_backend(self, spec: LlmSpec, scenario: Scenario) -> Backend:
        """The backend that reads the instruction (the oracle's answers the instruction dataset)."""
        return self._shared(spec, "goals", lambda: make_goal_backend(spec.backend, scenario, self._options()))

    def _shared(self, spec: LlmSpec, role: str, make: Callable[[], Backend]) -> Backend:
        """One backend per model for both roles (one model loaded), one per role for the oracles."""
        key = str(spec.backend) if spec.kind.is_model else f"{role}:{spec.backend}"
        if key not in self._backends:
            self._backends[key] = self._started(make())
        return self._backends[key]

    def _options(self) -> BackendOptions:
        return self.request.llm.backend_options()

    def loop_options(self) -> LoopOptions:
        return self.request.llm.loop_options(self.request.search, self.progress)

    def _started(self, backend: Backend) -> Backend:
        """``backend``, a local model loaded now when progress is shown (then saying so)."""
        inner = getattr(backend, "inner", backend)  # --record wraps the backend
        if self.progress is not None and isinstance(inner, LocalBackend) and not inner.loaded:
            try:
                self.progress(f"loading the local model {inner.name} (assembled into the model cache on first use)")
                inner.load()
                self.progress(f"model loaded in {inner.load_seconds or 0:.1f} s")
            except BaseException:
                backend.close()
                raise
        return backend

    def close(self) -> None:
        for backend in self._backends.values():
            backend.close()
        self._backends.clear()


def run_plan(request: PlanRequest) -> int:
    """Plan as ``request`` says, report, and return the exit code."""
    check_request(request)
    strategy = STRATEGIES[mode_of(request)]
    session = PlanSession(request)
    try:
        outcome = strategy(session)
    finally:
        session.close()
    return PlanReport(request, outcome).finish()


def check_request(request: PlanRequest) -> None:
    """Options that do not go together, refused before any work."""
    search, llm = request.search, request.llm
    check_alpha(search.alpha)
    if llm.llm is not None:
        if search.hints.given:
            raise InputError("use either --llm or --hints, not both")
        if search.symmetry:
            raise InputError("--symmetry applies to planning without an LLM (drop --llm or --symmetry)")
        if not llm.round_time_limit > 0:
            raise InputError(f"--round-time-limit must be positive, not {llm.round_time_limit}")


def _plain(session: PlanSession) -> PlanOutcome:
    """Plan once, LLM-free, with ``--hints`` when given."""
    search = session.request.search
    scenario, goal = session.resolve(session.load())
    hints = load_hints(search.hints, scenario, goal, session.limits)
    if hints is None:  # hints name actions of the whole grounding; a search without them needs fewer
        scenario = scenario.for_goal(goal)
    config = planner_config(search.planner, heuristic=search.heuristic, alpha=search.alpha, symmetry=search.symmetry)
    space = search.space or (Space.PRUNED if hints is not None else Space.FULL)
    result = plan(
        scenario.task,
        goal,
        config,
        hints=hints,
        space=space,
        mutexes=scenario.mutexes,
        limits=session.limits,
        extra_expansions=search.extra_expansions,
    )
    pruned = hints if space is Space.PRUNED else None
    return PlanOutcome(scenario, goal, result, search.hints.label, chosen=session.chosen, plain_hints=pruned)


def _loop(session: PlanSession) -> PlanOutcome:
    """The HBTP loop: ask, plan in the pruned space, feed back, fall back."""
    spec, llm = session.request.llm.llm, session.request.llm
    assert spec is not None
    scenario, goal = session.resolve(session.load())
    backend = session.backend(spec, scenario)
    pool = example_pool(scenario, llm.examples_from)
    loop = run_hbtp(scenario, goal, backend, pool, session.loop_options(), session.deadline)
    return PlanOutcome(scenario, goal, loop.result, "llm", loop=loop, chosen=session.chosen)


def _auto(session: PlanSession) -> PlanOutcome:
    """LLM-free for ``--auto-probe`` seconds, then (only then) the HBTP loop, within what is left of ``-t``."""
    spec, llm = session.request.llm.llm, session.request.llm
    assert spec is not None
    scenario, goal = session.resolve(session.load())
    auto = plan_auto(
        scenario,
        goal,
        lambda: session.backend(spec, scenario),
        lambda: example_pool(scenario, llm.examples_from),
        session.loop_options(),
        llm.auto_probe,
        session.deadline,
    )
    hints = "llm" if auto.asked_llm else "none"
    return PlanOutcome(scenario, goal, auto.result, hints, loop=auto.loop, auto=auto, chosen=session.chosen)


def _pruned(session: PlanSession) -> PlanOutcome:
    """The HBTP loop in a world pruned before grounding: its action names listed, each round's space
    grounded alone, the whole world only for the fallback; the tree belongs to the part it came from."""
    request = session.request
    spec = request.llm.llm
    assert spec is not None
    world = request.source.load_pruned(deadline=session.deadline)
    empty = world.part(frozenset(), frozenset())
    goal_text = read_goal(request.goal) if request.goal is not None else empty.problem_goal()
    goal = empty.resolve_goal(goal_text)[1]
    # An oracle answers from an optimal plan of a whole world of its own (the loop's stays pruned);
    # a model needs no world at all.
    answering = empty if spec.kind.is_model else session.load()
    backend = session.backend(spec, answering)
    pool = example_pool(world, request.llm.examples_from)
    loop = run_hbtp(world, goal, backend, pool, session.loop_options(), session.deadline)
    grounding = {
        "kind": "pruned",
        "actions": len(world.names.actions),
        "listed_s": round(world.load_seconds, 6),
        "grounded_actions": len(loop.scenario.task.actions),
        "whole_grounded": world.grounded,
    }
    scenario = loop.scenario
    return PlanOutcome(scenario, scenario.resolve_goal(goal)[1], loop.result, "llm", loop=loop, grounding=grounding)


#: The strategy of each mode.
STRATEGIES: dict[Mode, Callable[[PlanSession], PlanOutcome]] = {
    Mode.PLAIN: _plain,
    Mode.LOOP: _loop,
    Mode.AUTO: _auto,
    Mode.PRUNED: _pruned,
}


def _progress(as_json: bool) -> Progress | None:
    """What the LLM loop is doing, on stderr, when stderr is a terminal and the output is not JSON."""
    if as_json or not sys.stderr.isatty():
        return None

    def show(message: str) -> None:
        click.echo(f"hbtp: {message}", err=True)

    return show


__all__ = ["STRATEGIES", "Mode", "PlanSession", "check_request", "mode_of", "run_plan"]
