"""Run a planned tree on a robot: the user's actions and observer, re-planning when needed.

:class:`Runtime` ticks a tree (:class:`hbtp.replanning.Replanner`: re-planning when the tree has no
answer) against the user's code: an implementation per action (:mod:`hbtp.implementations`: a
:class:`StatefulAction` with start, running and halt callbacks, or a plain callable) and an observer
returning the literals that hold now. Each tick observes, ticks the tree, and calls the action it
runs: its start callback when it starts, its running callback while it goes on. An action that was
RUNNING and that the next tick does not run again is halted, once (its halt callback): a condition
higher in the tree holds, a disturbance changed the branch, a re-plan swapped the tree, or the run
ends (success, failure, ``max_ticks``, a :class:`RuntimeFailure`, Ctrl-C); the halt comes before
the next action starts (see :mod:`hbtp.logic.lifecycle`). An action that fails ``max_failures``
times in a row is left out of the next plan.

Every callback runs within ``tick_timeout_s`` (a positive, finite number). An action that raises or
answers garbage counts as a failure (logged); an observer that raises or answers literals that
cannot be read ends the run with :class:`RuntimeFailure`, as does an action or an observer that does
not return in time. A halt that raises or does not return in time is reported
(:attr:`RuntimeReport.halt_errors`, logged) and ends the run with the reason; Ctrl-C
(:class:`KeyboardInterrupt`) ends it too, with the running action halted, and :meth:`Runtime.run`
returns the report (``interrupted``). ``tick_hz`` ticks at most that many times a second
(:class:`hbtp.pacing.TickRate`); ``watch`` has Groot2 and BT.CPP's log follow every tree of a run
ticked by BehaviorTree.CPP.

This module re-exports the re-planning names its users need (:mod:`hbtp.replanning`).
"""

from __future__ import annotations

import contextlib
import logging
import math
import threading
from collections.abc import Callable, Iterable, Mapping
from dataclasses import dataclass, field
from typing import Any

from hbtp.bt.btcpp_engine import Watch, Watcher, btcpp_binding
from hbtp.bt.engines import Engine, TreePolicy
from hbtp.bt.nodes import Node
from hbtp.domains.scenarios import Scenario
from hbtp.errors import HbtpError, InputError
from hbtp.implementations import ActionCallback, StatefulAction, implementations, read_status, shown
from hbtp.logic.execution import NodeStatus, TraceStep
from hbtp.logic.lifecycle import ActionLifecycle, Phase
from hbtp.logic.task import Goal, State
from hbtp.pacing import TickRate
from hbtp.replanning import (
    UNSOLVABLE_FROM_STATE,
    Replan,
    Replanner,
    ReplanningRun,
    ReplanOptions,
    replanning_runs,
    replanning_stats,
    replanning_summary,
    replanning_trace_jsonl,
    run_replanning,
)

log = logging.getLogger(__name__)

__all__ = [
    "UNSOLVABLE_FROM_STATE",
    "ActionCallback",
    "Replan",
    "ReplanOptions",
    "Replanner",
    "ReplanningRun",
    "Runtime",
    "RuntimeFailure",
    "RuntimeReport",
    "StatefulAction",
    "replanning_runs",
    "replanning_stats",
    "replanning_summary",
    "replanning_trace_jsonl",
    "run_replanning",
]

#: Returns the literals that hold now (``IsIn(milk,fridge)`` or ``IsIn_milk_fridge``).
StateObserver = Callable[[], Iterable[str]]


class RuntimeFailure(HbtpError):
    """The runtime had to stop: a callback hung, or the observer named what the domain does not have."""


@dataclass
class RuntimeReport:
    """What a :class:`Runtime` run did: how it ended, its ticks, the actions called, the actions
    halted (and the halts that failed), the re-plans, the ticks traced."""

    status: NodeStatus
    reason: str
    ticks: int
    called: list[str] = field(default_factory=list)
    failures: int = 0
    replans: tuple[Replan, ...] = ()
    trace: list[TraceStep] = field(default_factory=list)
    #: The actions halted while RUNNING, in order (a halt whose callback failed included).
    halted: list[str] = field(default_factory=list)
    #: Why each halt that raised or did not return in time failed.
    halt_errors: list[str] = field(default_factory=list)
    #: The run was ended by Ctrl-C (:class:`KeyboardInterrupt`).
    interrupted: bool = False

    @property
    def succeeded(self) -> bool:
        return self.status is NodeStatus.SUCCESS

    @property
    def halts(self) -> int:
        return len(self.halted)

    def to_dict(self) -> dict[str, Any]:
        return {
            "status": self.status.value,
            "reason": self.reason,
            "ticks": self.ticks,
            "called": self.called,
            "failures": self.failures,
            "halts": self.halts,
            "halted": self.halted,
            "halt_errors": self.halt_errors,
            "interrupted": self.interrupted,
            "replans": [r.to_dict() for r in self.replans],
            "trace": [s.to_dict() for s in self.trace],
        }


class Runtime:
    """Ticks a planned tree against the user's actions and observer, re-planning when needed.

    ``actions`` maps an action name (``RightGrab(apple)``) or an action predicate (``RightGrab``,
    called with the objects as arguments) to its implementation (a :class:`StatefulAction` or a
    plain callable). ``tree`` defaults to a tree planned now from the observed state.
    """

    def __init__(
        self,
        scenario: Scenario,
        goal: Goal | str,
        actions: Mapping[str, StatefulAction | ActionCallback],
        observe: StateObserver,
        *,
        tree: Node | None = None,
        options: ReplanOptions | None = None,
        max_failures: int = 3,
        tick_timeout_s: float = 10.0,
        tick_hz: float | None = None,
        watch: Watch | None = None,
    ) -> None:
        if not isinstance(max_failures, int) or isinstance(max_failures, bool) or max_failures < 1:
            raise InputError(f"max_failures must be a whole number of at least 1, not {max_failures!r}")
        if not isinstance(tick_timeout_s, (int, float)) or not (0 < tick_timeout_s < math.inf):
            raise InputError(f"tick_timeout_s must be a positive, finite number of seconds, not {tick_timeout_s!r}")
        options = options or ReplanOptions()
        if watch is not None and options.engine is not Engine.BTCPP:
            raise InputError("Groot2 and BT.CPP's log watch BehaviorTree.CPP: give ReplanOptions(engine=Engine.BTCPP)")
        scenario, self.goal = scenario.resolve_goal(goal)
        self.task = scenario.task
        self.implementations = implementations(self.task, actions)
        self.observe = observe
        self.max_failures = max_failures
        self.tick_timeout_s = tick_timeout_s
        #: At most this many ticks a second (``None``: as fast as possible).
        self.rate = None if tick_hz is None else TickRate(tick_hz)
        self.watch = watch
        self.scenario = scenario
        self.options = options
        self.tree = tree

    def run(self, max_ticks: int = 1000) -> RuntimeReport:
        """Tick until the goal holds, the tree fails for good, ``max_ticks`` ticks, or Ctrl-C."""
        if not isinstance(max_ticks, int) or isinstance(max_ticks, bool) or max_ticks < 1:
            raise InputError(f"max_ticks must be a whole number of at least 1, not {max_ticks!r}")
        return _RuntimeRun(self).run(max_ticks)

    def _name(self, action: int | None) -> str | None:
        return None if action is None else self.task.actions[action].name

    def _observed(self) -> State:
        """The state the observer says holds now (:class:`RuntimeFailure` when it cannot be read)."""

        def observe() -> list[str]:  # in the worker: the literals as plain text
            return [_text(literal) for literal in self.observe()]

        answer = _bounded(observe, (), self.tick_timeout_s, "the state observer")
        if isinstance(answer, Exception):  # the user's code: any failure ends the run with its message
            raise RuntimeFailure(f"the state observer failed: {type(answer).__name__}: {shown(answer)}") from answer
        ids: set[int] = set()
        unknown: list[str] = []
        for literal in answer:
            try:
                ids.add(self.task.atom_id(literal))
            except InputError:
                unknown.append(literal)
        if unknown:
            raise RuntimeFailure(
                f"the state observer returned literal(s) the domain does not have: {', '.join(unknown[:5])}"
            )
        return self.task.complete(ids)

    def _call(self, action: int, phase: Phase) -> NodeStatus:
        """Call the action's start or running callback within ``tick_timeout_s``; anything but
        success or running counts as a failure."""
        ground = self.task.actions[action]
        bound = self.implementations[action]
        callback = bound.implementation.callback(phase)
        answer: NodeStatus | str | Exception = _bounded(
            lambda: read_status(callback(*bound.args)), (), self.tick_timeout_s, f"action {ground.name}"
        )
        if isinstance(answer, Exception):  # a failure of the action, logged
            log.warning("action %s raised %s: counted as a failure", ground.name, shown(answer))
            return NodeStatus.FAILURE
        if isinstance(answer, str):
            log.warning("action %s answered %s: counted as a failure", ground.name, answer)
            return NodeStatus.FAILURE
        return answer

    def _halt(self, action: int) -> str | None:
        """Call the action's halt callback within ``tick_timeout_s``: ``None``, or why it failed."""
        ground = self.task.actions[action]
        bound = self.implementations[action]
        on_halted = bound.implementation.on_halted
        if on_halted is None:
            return None
        try:
            answer = _bounded(on_halted, bound.args, self.tick_timeout_s, f"the halt of {ground.name}")
        except RuntimeFailure as error:
            message = str(error)
        else:
            if not isinstance(answer, Exception):
                return None
            message = f"the halt of {ground.name} raised {type(answer).__name__}: {shown(answer)}"
        log.warning("%s", message)
        return message


class _RuntimeRun:
    """One run of a :class:`Runtime`: its tree (through the re-planner), the action running, the
    failures in a row, the report."""

    def __init__(self, runtime: Runtime) -> None:
        self.runtime = runtime
        self.life = ActionLifecycle()
        self.report = RuntimeReport(NodeStatus.RUNNING, "", 0)
        self.failures: dict[int, int] = {}
        self.halt_error: str | None = None
        self.watcher: Watcher | None = None
        self.pacer = None if runtime.rate is None else runtime.rate.pacer()
        rt = runtime
        self.replanner = Replanner(rt.scenario, rt.goal, rt.tree, rt.options, on_swap=[self._swapped])

    def run(self, max_ticks: int) -> RuntimeReport:
        report = self.report
        with contextlib.ExitStack() as stack:
            if self.runtime.watch is not None:
                self.watcher = stack.enter_context(self.runtime.watch.watching(btcpp_binding()))
                if self.replanner.policy is not None:
                    self.watcher.attach(self.replanner.policy)  # type: ignore[arg-type]  # a BtcppPolicy
            try:
                self._ticks(max_ticks)
            except KeyboardInterrupt:
                report.status, report.interrupted = NodeStatus.RUNNING, True
                report.reason = f"interrupted (KeyboardInterrupt) at tick {report.ticks}"
                log.warning("%s", report.reason)
            finally:
                self._end()
        if self.halt_error is not None and self.halt_error not in report.reason:
            report.reason = f"{report.reason}; {self.halt_error}" if report.reason else self.halt_error
        report.replans = tuple(self.replanner.replans)
        return report

    def _ticks(self, max_ticks: int) -> None:
        report, replanner = self.report, self.replanner
        state = self.runtime._observed()
        if replanner.policy is None and not replanner.replan(state, "the first plan, from the observed state"):
            report.status, report.reason = NodeStatus.FAILURE, replanner.gave_up or ""
            return
        report.reason = f"{max_ticks} ticks without reaching the goal"
        for tick in range(1, max_ticks + 1):
            if self.pacer is not None:
                self.pacer.wait()
            if tick > 1:
                state = self.runtime._observed()
            if not self._tick(tick, state):
                return

    def _tick(self, tick: int, state: State) -> bool:
        """One tick; ``False`` when the run ends with it."""
        runtime, report = self.runtime, self.report
        status, action = self.replanner(state)
        report.ticks = tick
        report.trace.append(TraceStep(tick, tuple(runtime.task.names(state)), status, runtime._name(action), None))
        step = self.life.step(action if status is NodeStatus.RUNNING else None)
        if step.halted is not None:
            self._record_halt(step.halted)
        if status is not NodeStatus.RUNNING:
            report.status = status
            report.reason = "the goal holds" if status is NodeStatus.SUCCESS else (self.replanner.gave_up or "")
            return False
        if self.halt_error is not None:
            self.life.finish()  # the action this tick would run is never started: nothing to halt
            report.status, report.reason = NodeStatus.FAILURE, self.halt_error
            return False
        assert action is not None, "a RUNNING tick names its action"
        assert step.phase is not None
        report.called.append(runtime.task.actions[action].name)
        outcome = runtime._call(action, step.phase)
        if outcome is not NodeStatus.RUNNING:
            self.life.finish()
        if outcome is not NodeStatus.FAILURE:
            self.failures[action] = 0
            return True
        return self._failed(action, state)

    def _failed(self, action: int, state: State) -> bool:
        """Count a failure of ``action``; re-plan without it after ``max_failures`` in a row."""
        report, failures = self.report, self.failures
        report.failures += 1
        failures[action] = failures.get(action, 0) + 1
        if failures[action] < self.runtime.max_failures:
            return True
        reason = f"{self.runtime.task.actions[action].name} failed {failures[action]} times in a row"
        failures[action] = 0
        if self.replanner.replan(state, reason, without=(action,)):
            return True
        report.status, report.reason = NodeStatus.FAILURE, self.replanner.gave_up or reason
        return False

    def _swapped(self, policy: TreePolicy) -> None:
        """A re-plan swapped the tree: the action running is halted, the watchers follow."""
        halted = self.life.halt()
        if halted is not None:
            self._record_halt(halted)
        if self.watcher is not None:
            self.watcher.attach(policy)  # type: ignore[arg-type]  # a BtcppPolicy (checked in Runtime)

    def _record_halt(self, action: int) -> None:
        """``action`` was halted: its halt callback called, the halt (and its failure) reported."""
        self.report.halted.append(self.runtime.task.actions[action].name)
        error = self.runtime._halt(action)
        if error is not None:
            self.report.halt_errors.append(error)
            self.halt_error = self.halt_error or error

    def _end(self) -> None:
        """The run ends: the action running is halted, then the tree."""
        halted = self.life.halt()
        if halted is not None:
            self._record_halt(halted)
        self.replanner.halt()


def _bounded(function: Callable[..., Any], args: tuple[Any, ...], timeout: float, what: str) -> Any:
    """``function(*args)`` in a worker thread, waited for ``timeout`` seconds: its value, or the
    exception it raised; :class:`RuntimeFailure` when it has not returned by then (the thread is
    left to finish on its own: Python cannot stop it). A :class:`KeyboardInterrupt` (or another
    exception that is not an :class:`Exception`) raised by ``function`` is raised again here, in the
    thread that runs the run: the user's code asked to stop it, as Ctrl-C does."""
    box: list[Any] = []

    def target() -> None:
        try:
            box.append(function(*args))
        except BaseException as error:  # the user's code
            box.append(error)

    worker = threading.Thread(target=target, name=f"hbtp-{what}", daemon=True)
    worker.start()
    worker.join(timeout)
    if worker.is_alive() or not box:
        raise RuntimeFailure(f"{what} did not return within {timeout:g} s")
    value = box[0]
    if isinstance(value, BaseException) and not isinstance(value, Exception):
        raise value
    return value


def _text(literal: Any) -> str:
    """An observed literal as text (a ``str`` subclass read as the plain string it holds)."""
    return str.__str__(literal) if isinstance(literal, str) else str(literal)
