"""The one executor: tick a policy, apply the running action, repeat.

A *policy* maps a state to the status of a tick: SUCCESS, FAILURE, or RUNNING with the action to
apply. A behavior tree is one (:func:`hbtp.bt.simulate.compile_tree`), the expansion record of a
search another (:func:`hbtp.planning.execution.execute_expansions`), and a first-match list of
``(condition, action)`` pairs the common fast form of both (:func:`first_match`).

:func:`execute` runs a policy from a state (s0 by default). Before each tick a *disturbance* may
change the state: an external event (another agent, a slip) that the policy must cope with
(:class:`Disturbance`; :mod:`hbtp.bt.disturb` provides seeded random ones). When the tick is
RUNNING, the action's effects are applied by progression ``(s - del) | add`` and the next tick
follows. The run ends when a tick returns SUCCESS or FAILURE, or after ``max_ticks`` ticks (status
RUNNING). *Observers* see every tick (:class:`Tick`): :class:`Trace` records them; a runtime that
ticks from observed states uses the same hooks.

An action may take several ticks (``ActionLifecycle(action_ticks=n)``, see
:mod:`hbtp.logic.lifecycle`): it is RUNNING for ``n`` ticks in a row and its effects are applied
after the last; an action the tree stops ticking before then is halted and has no effect, and
:attr:`Run.halts` counts the halts. With one tick per action (the default) every action finishes in
the tick that runs it, and no action is ever halted.

Counting: ``ticks`` counts every tick, the last one included, so an undisturbed run that executes
``n`` actions and then succeeds takes ``n + 1`` ticks. ``cost`` is the sum of the executed actions'
costs (the paper's D(T) for a run from s0).

This module sits in :mod:`hbtp.logic` because both the planners (the search checks the tree it
built by running it) and :mod:`hbtp.bt` (the simulator, the benchmarks) run policies, and the
planning layer may not import :mod:`hbtp.bt`.
"""

from __future__ import annotations

import enum
import logging
from collections.abc import Callable, Iterable, Sequence
from dataclasses import dataclass
from typing import Any, Protocol

from hbtp.errors import InputError
from hbtp.logic.lifecycle import ActionLifecycle
from hbtp.logic.task import GoalIds, GroundAction, GroundTask, State, disjuncts_of

log = logging.getLogger(__name__)


class NodeStatus(enum.Enum):
    """The status of a tick (of a behavior-tree node, or of a whole policy)."""

    SUCCESS = "success"
    FAILURE = "failure"
    RUNNING = "running"


#: A policy: ``state -> (status, running action)``; the action is given exactly when RUNNING.
Policy = Callable[[State], tuple[NodeStatus, int | None]]

_SUCCESS = (NodeStatus.SUCCESS, None)
_FAILURE = (NodeStatus.FAILURE, None)


def first_match(table: Sequence[tuple[frozenset[int], int | None]]) -> Policy:
    """The policy of a first-match list: RUNNING with the action of the first ``(condition,
    action)`` pair whose condition holds, SUCCESS when that pair has no action, FAILURE when no
    condition holds. The conditions must include the actions' preconditions."""
    pairs = tuple(table)

    def policy(state: State) -> tuple[NodeStatus, int | None]:
        for condition, action in pairs:
            if condition <= state:
                return _SUCCESS if action is None else (NodeStatus.RUNNING, action)
        return _FAILURE

    return policy


@dataclass(frozen=True, slots=True)
class Event:
    """An external change of the state: ``(state - removed) | added``."""

    kind: str
    added: frozenset[int]
    removed: frozenset[int]

    def apply(self, state: State) -> State:
        return (state - self.removed) | self.added

    def describe(self, task: GroundTask) -> str:
        """``make-true: +P(a) -Q(a)``: the kind, then the literals added and removed."""
        changes = [f"+{name}" for name in task.names(self.added)] + [f"-{name}" for name in task.names(self.removed)]
        return f"{self.kind}: {' '.join(changes)}"


class Disturbance(Protocol):
    """Called before each tick; returns the event to apply, or ``None`` for no change.

    ``tick`` is the number of the tick about to happen (from 1), ``state`` the current state,
    ``last_action`` the action applied after the previous tick (``None`` at the start) and
    ``before_last`` the state in which it was applied.
    """

    def __call__(self, tick: int, state: State, last_action: int | None, before_last: State | None) -> Event | None: ...


@dataclass(frozen=True, slots=True)
class Tick:
    """What an observer sees of one tick: its number (from 1), the state the policy was ticked in
    (after any disturbance), the status, the running action and the event applied just before."""

    number: int
    state: State
    status: NodeStatus
    action: int | None
    event: Event | None


#: Called after every tick, before the running action is applied.
Observer = Callable[[Tick], None]


@dataclass(frozen=True, slots=True)
class TraceStep:
    """One tick, readable: the state as sorted literal names, the root's status, the running
    action's name, the disturbance applied just before the tick."""

    tick: int
    state: tuple[str, ...]
    status: NodeStatus
    action: str | None
    disturbance: str | None

    @classmethod
    def of(cls, tick: Tick, task: GroundTask) -> TraceStep:
        return cls(
            tick.number,
            tuple(task.names(tick.state)),
            tick.status,
            task.actions[tick.action].name if tick.action is not None else None,
            tick.event.describe(task) if tick.event is not None else None,
        )

    def to_dict(self) -> dict[str, Any]:
        return {
            "tick": self.tick,
            "state": list(self.state),
            "status": self.status.value,
            "action": self.action,
            "disturbance": self.disturbance,
        }


class Trace:
    """An observer that records every tick as a :class:`TraceStep`."""

    def __init__(self, task: GroundTask) -> None:
        self.task = task
        self.steps: list[TraceStep] = []

    def __call__(self, tick: Tick) -> None:
        self.steps.append(TraceStep.of(tick, self.task))


@dataclass(frozen=True)
class Run:
    """The outcome of :func:`execute`.

    ``status`` is the last tick's status: SUCCESS or FAILURE when the run ended by itself, RUNNING
    when it hit the tick limit. ``events`` counts the disturbances applied, ``halts`` the actions
    halted while RUNNING (only actions that take several ticks can be); ``trace`` is filled only
    when asked for (:class:`Trace`).
    """

    status: NodeStatus
    executed: tuple[int, ...]
    cost: int
    ticks: int
    final_state: State
    events: int = 0
    trace: tuple[TraceStep, ...] = ()
    halts: int = 0

    @property
    def succeeded(self) -> bool:
        """The last tick returned SUCCESS."""
        return self.status is NodeStatus.SUCCESS

    @property
    def hit_limit(self) -> bool:
        return self.status is NodeStatus.RUNNING

    def reached(self, goal: GoalIds) -> bool:
        """The last tick returned SUCCESS and the goal (one of its disjuncts) holds in the final state."""
        return self.succeeded and any(d <= self.final_state for d in disjuncts_of(goal))

    def to_dict(self, task: GroundTask) -> dict[str, Any]:
        return {
            "status": self.status.value,
            "ticks": self.ticks,
            "cost": self.cost,
            "events": self.events,
            "halts": self.halts,
            "executed": [task.actions[i].name for i in self.executed],
            "final_state": task.names(self.final_state),
        }


def apply_actions(task: GroundTask, actions: Sequence[GroundAction], state: State | None = None) -> tuple[State, int]:
    """Apply ``actions`` in order from ``state`` (default: s0).

    Returns the final state and the number of actions applied before the first that is not
    applicable (``len(actions)`` when all are).
    """
    current = task.initial_state if state is None else state
    for done, action in enumerate(actions):
        if not action.applicable(current):
            return current, done
        current = action.progress(current)
    return current, len(actions)


def execute(
    policy: Policy,
    task: GroundTask,
    state: State | None = None,
    *,
    max_ticks: int,
    disturbance: Disturbance | None = None,
    observers: Iterable[Observer] = (),
    lifecycle: ActionLifecycle | None = None,
) -> Run:
    """Run ``policy`` from ``state`` (default s0) until SUCCESS, FAILURE or ``max_ticks`` ticks;
    ``lifecycle`` says how many ticks an action takes (one by default) and counts the halts."""
    if max_ticks < 1:
        raise InputError(f"max_ticks must be at least 1, not {max_ticks}")
    watchers = tuple(observers)
    actions = task.actions
    life = lifecycle if lifecycle is not None else ActionLifecycle()
    current = task.initial_state if state is None else frozenset(state)
    executed: list[int] = []
    cost = events = ticks = 0
    last_action: int | None = None
    before_last: State | None = None
    status = NodeStatus.RUNNING
    for ticks in range(1, max_ticks + 1):
        event: Event | None = None
        if disturbance is not None:
            event = disturbance(ticks, current, last_action, before_last)
            if event is not None:
                current = event.apply(current)
                events += 1
        status, running = policy(current)
        if watchers:
            seen = Tick(ticks, current, status, running, event)
            for observer in watchers:
                observer(seen)
        life.step(running if status is NodeStatus.RUNNING else None)
        if status is not NodeStatus.RUNNING:
            break
        assert running is not None, "a RUNNING tick names its action"
        if not life.done:
            continue
        life.finish()
        action = actions[running]
        before_last = current
        current = action.progress(current)
        last_action = running
        executed.append(running)
        cost += action.cost
    else:
        life.halt()  # the tick limit: an action still running is halted
        log.debug("execute: tick limit %d reached", max_ticks)
    return Run(status, tuple(executed), cost, ticks, current, events, halts=life.halts)


__all__ = [
    "Disturbance",
    "Event",
    "NodeStatus",
    "Observer",
    "Policy",
    "Run",
    "Tick",
    "Trace",
    "TraceStep",
    "apply_actions",
    "execute",
    "first_match",
]
