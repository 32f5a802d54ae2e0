"""Regression of a condition through the actions, and the conditions no plan reaches for want of a
last action.

A condition ``c`` regresses through an action ``a`` that adds one of its literals and deletes none,
to ``pre(a) | (c - add(a))`` (the step of the backward search, :mod:`hbtp.planning.search`);
a regression whose literals cannot hold together (the proved mutexes) leads nowhere. A condition
that does not hold at the start and has no regression is *stuck*: no plan reaches it, whatever its
literals can do one by one. A café world's ``Holding_Cup & On_Cup_Table2`` is one: putting the cup
down ends the holding, picking it up takes it off every place. Deciding this costs one look at the
achievers of the condition's literals, far less than a search.
"""

from __future__ import annotations

from collections.abc import Iterator

from hbtp.domains.mutex import Mutexes
from hbtp.logic.task import Condition, GroundAction, GroundTask


def regressions(task: GroundTask, condition: Condition, mutexes: Mutexes) -> Iterator[tuple[GroundAction, Condition]]:
    """Each action that regresses ``condition``, with the condition it regresses to, those whose
    literals ``mutexes`` rule out together left out (in the order of the task's achievers)."""
    seen: set[int] = set()
    for atom in sorted(condition):
        for index in task.achievers[atom]:
            if index in seen:
                continue
            seen.add(index)
            action = task.actions[index]
            if not condition.isdisjoint(action.delete):
                continue
            regressed = action.pre | (condition - action.add)
            if mutexes.conflict(regressed) is None:
                yield action, regressed


def stuck(task: GroundTask, condition: Condition, mutexes: Mutexes) -> bool:
    """Whether no plan reaches ``condition``: it does not hold at the start and nothing regresses it
    (see the module docstring). Sound with proved mutexes only (:meth:`Mutexes.proved_only`)."""
    return not condition <= task.initial_state and next(regressions(task, condition, mutexes), None) is None


__all__ = ["regressions", "stuck"]
