"""A symbolic simulator: tick a tree, apply the running action, repeat.

A run starts in a state (s0 by default). At every tick the tree is ticked in the current state
(ticking is a pure function of the state, :func:`hbtp.bt.nodes.tick`); when the root is RUNNING, the
running action's effects are applied by progression ``(s - del) | add`` and the next tick follows.
The run ends when the root returns SUCCESS or FAILURE, or after ``max_ticks`` ticks (status RUNNING).

A *disturbance* may change the state before each tick: an external event (another agent, a slip)
that the tree must cope with. It is any callable following :class:`Disturbance`;
:mod:`hbtp.bt.disturb` provides seeded random ones.

Counting: ``ticks`` counts every tick, the last one included, so an undisturbed run that executes
``n`` actions and then finds the goal takes ``n + 1`` ticks. ``cost`` is the sum of the executed
actions' costs (the paper's D(T) for a run from s0).
"""

from __future__ import annotations

import json
import logging
from collections.abc import Callable
from dataclasses import dataclass
from typing import Any, Protocol

from hbtp.bt.nodes import Node, NodeStatus, tick
from hbtp.bt.verify import flatten
from hbtp.errors import InputError
from hbtp.logic.task import GroundTask, State

log = logging.getLogger(__name__)

#: Ticks after which :func:`simulate` gives up (the run's status is then RUNNING).
DEFAULT_MAX_TICKS = 1000

Ticker = Callable[[State], tuple[NodeStatus, int | None]]


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
class TraceStep:
    """One tick: the state the tree was ticked in (after any disturbance), as sorted literal names;
    the root's status; the running action's name; the disturbance applied just before the tick."""

    tick: int
    state: tuple[str, ...]
    status: NodeStatus
    action: str | None
    disturbance: str | None

    def to_dict(self) -> dict[str, Any]:
        return {
            "tick": self.tick,
            "state": list(self.state),
            "status": self.status.value,
            "action": self.action,
            "disturbance": self.disturbance,
        }


@dataclass(frozen=True)
class Run:
    """The outcome of :func:`simulate`.

    ``status`` is the root's last status: SUCCESS or FAILURE when the run ended by itself, RUNNING
    when it hit the tick limit. ``events`` counts the disturbances applied; ``trace`` is filled
    only when asked for.
    """

    status: NodeStatus
    executed: tuple[int, ...]
    cost: int
    ticks: int
    final_state: State
    events: int = 0
    trace: tuple[TraceStep, ...] = ()

    @property
    def succeeded(self) -> bool:
        """The root returned SUCCESS."""
        return self.status is NodeStatus.SUCCESS

    @property
    def hit_limit(self) -> bool:
        return self.status is NodeStatus.RUNNING

    def reached(self, goal_ids: frozenset[int]) -> bool:
        """The root returned SUCCESS and the goal holds in the final state."""
        return self.succeeded and goal_ids <= self.final_state

    def to_dict(self, task: GroundTask) -> dict[str, Any]:
        return {
            "status": self.status.value,
            "ticks": self.ticks,
            "cost": self.cost,
            "events": self.events,
            "executed": [task.actions[i].name for i in self.executed],
            "final_state": task.names(self.final_state),
        }


def compile_tree(tree: Node, task: GroundTask) -> Ticker:
    """A function ``state -> (status, running action)`` equal to ``tick(tree, state, task)``.

    Trees with a first-match form (:func:`hbtp.bt.verify.flatten`) are ticked as a flat list of
    (condition, action) pairs, which is faster than walking the nodes; others fall back to
    :func:`~hbtp.bt.nodes.tick`.
    """
    branches = flatten(tree)
    if branches is None:
        return lambda state: tick(tree, state, task)
    table = tuple((branch.condition(task), branch.action) for branch in branches)

    def ticker(state: State) -> tuple[NodeStatus, int | None]:
        for condition, action in table:
            if condition <= state:
                return (NodeStatus.SUCCESS, None) if action is None else (NodeStatus.RUNNING, action)
        return NodeStatus.FAILURE, None

    return ticker


def simulate(
    tree: Node,
    task: GroundTask,
    state: State | None = None,
    *,
    max_ticks: int = DEFAULT_MAX_TICKS,
    disturbance: Disturbance | None = None,
    trace: bool = False,
    ticker: Ticker | None = None,
) -> Run:
    """Run ``tree`` from ``state`` (default s0) until SUCCESS, FAILURE or ``max_ticks`` ticks.

    ``ticker`` may pass a :func:`compile_tree` result to save compiling the tree on every run.
    """
    if max_ticks < 1:
        raise InputError(f"max_ticks must be at least 1, not {max_ticks}")
    run_tick = ticker if ticker is not None else compile_tree(tree, task)
    current = task.initial_state if state is None else frozenset(state)
    executed: list[int] = []
    steps: list[TraceStep] = []
    cost = 0
    events = 0
    last_action: int | None = None
    before_last: State | None = None
    status = NodeStatus.RUNNING
    ticks = 0
    for ticks in range(1, max_ticks + 1):
        applied: Event | None = None
        if disturbance is not None:
            applied = disturbance(ticks, current, last_action, before_last)
            if applied is not None:
                current = applied.apply(current)
                events += 1
        status, running = run_tick(current)
        if trace:
            steps.append(
                TraceStep(
                    ticks,
                    tuple(task.names(current)),
                    status,
                    task.actions[running].name if running is not None else None,
                    applied.describe(task) if applied is not None else None,
                )
            )
        if status is not NodeStatus.RUNNING:
            break
        assert running is not None, "a RUNNING tick names its action"
        action = task.actions[running]
        before_last = current
        current = action.progress(current)
        last_action = running
        executed.append(running)
        cost += action.cost
    else:
        log.debug("simulate: tick limit %d reached", max_ticks)
    return Run(status, tuple(executed), cost, ticks, current, events, tuple(steps))


def trace_to_jsonl(run: Run, task: GroundTask, *, run_index: int | None = None) -> str:
    """The run's trace as JSON lines: one object per tick (see :class:`TraceStep`), then one
    ``{"end": status, ...}`` object with the totals. ``run_index`` adds a ``"run"`` field to every
    line (to tell several runs apart in one file)."""
    lines: list[str] = []
    extra = {} if run_index is None else {"run": run_index}
    for step in run.trace:
        lines.append(json.dumps({**extra, **step.to_dict()}, ensure_ascii=False))
    end = {**extra, "end": run.status.value, **{k: v for k, v in run.to_dict(task).items() if k != "status"}}
    lines.append(json.dumps(end, ensure_ascii=False))
    return "\n".join(lines) + "\n"


__all__ = [
    "DEFAULT_MAX_TICKS",
    "Disturbance",
    "Event",
    "Run",
    "Ticker",
    "TraceStep",
    "compile_tree",
    "simulate",
    "trace_to_jsonl",
]
