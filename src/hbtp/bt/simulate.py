"""A symbolic simulator: tick a tree, apply the running action, repeat.

A tree is a policy (:func:`compile_tree`: ticking is a pure function of the state,
:func:`hbtp.bt.nodes.tick`) run by the one executor, :func:`hbtp.logic.execution.execute`, which
documents the run: the optional disturbance before each tick, progression, the end on SUCCESS,
FAILURE or ``max_ticks`` ticks (status RUNNING), how ticks and cost are counted, and the observers.
:mod:`hbtp.bt.disturb` provides seeded random disturbances.
"""

from __future__ import annotations

import dataclasses
import json
from collections.abc import Iterable

from hbtp.bt.live import LiveOptions, paced
from hbtp.bt.nodes import Condition, Node, NodeStatus, tick
from hbtp.bt.verify import flatten
from hbtp.logic.execution import (
    Disturbance,
    Event,
    Observer,
    Policy,
    Run,
    Trace,
    TraceStep,
    execute,
    first_match,
)
from hbtp.logic.task import GroundTask, State

#: Ticks after which :func:`simulate` gives up (the run's status is then RUNNING).
DEFAULT_MAX_TICKS = 1000


def compile_tree(tree: Node, task: GroundTask) -> Policy:
    """A function ``state -> (status, running action)`` equal to ``tick(tree, state, task)``.

    Trees with a first-match form (:func:`hbtp.bt.verify.flatten`) are ticked as a flat list of
    (condition, action) pairs, which is faster than walking the nodes; others fall back to
    :func:`~hbtp.bt.nodes.tick`.
    """
    branches = flatten(tree)
    if branches is None:
        return lambda state: tick(tree, state, task)
    return first_match([(branch.condition(task), branch.action) for branch in branches])


def simulate(
    tree: Node,
    task: GroundTask,
    state: State | None = None,
    *,
    max_ticks: int = DEFAULT_MAX_TICKS,
    disturbance: Disturbance | None = None,
    trace: bool = False,
    policy: Policy | None = None,
    observers: Iterable[Observer] = (),
    live: LiveOptions | None = None,
) -> Run:
    """Run ``tree`` from ``state`` (default s0) until SUCCESS, FAILURE or ``max_ticks`` ticks.

    ``policy`` may pass a :func:`compile_tree` result to save compiling the tree on every run;
    ``trace`` records every tick in :attr:`Run.trace`; ``live`` gives the ticks each action takes
    and the tick rate (:class:`hbtp.bt.live.LiveOptions`; default: one tick, as fast as possible).
    """
    live = live or LiveOptions()
    tracer = Trace(task) if trace else None
    run = execute(
        paced(policy if policy is not None else compile_tree(tree, task), live.rate),
        task,
        state,
        max_ticks=max_ticks,
        disturbance=disturbance,
        observers=(*observers, *((tracer,) if tracer is not None else ())),
        lifecycle=live.lifecycle(),
    )
    return run if tracer is None else dataclasses.replace(run, trace=tuple(tracer.steps))


class ConditionChecks:
    """A tick visitor (:data:`hbtp.bt.nodes.Visitor`) that counts the Condition nodes ticked."""

    def __init__(self) -> None:
        self.count = 0

    def __call__(self, node: Node, status: NodeStatus) -> None:
        if isinstance(node, Condition):
            self.count += 1


def condition_checks(tree: Node, task: GroundTask, *, max_ticks: int = DEFAULT_MAX_TICKS) -> int:
    """Condition nodes ticked in the undisturbed run from s0 (BTPG's tick count)."""
    counter = ConditionChecks()
    simulate(tree, task, max_ticks=max_ticks, policy=lambda state: tick(tree, state, task, counter))
    return counter.count


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
    "ConditionChecks",
    "Disturbance",
    "Event",
    "Run",
    "TraceStep",
    "compile_tree",
    "condition_checks",
    "simulate",
    "trace_to_jsonl",
]
