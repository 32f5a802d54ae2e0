"""Backward relevance: the actions that can take part in reaching some atoms (the operators Fast
Downward's translator keeps as "necessary")."""

from __future__ import annotations

from collections.abc import Iterable

from hbtp.logic.goal import Goal
from hbtp.logic.task import GroundTask


def relevant_actions(task: GroundTask, goal: Goal) -> frozenset[int]:
    """The indices of the actions that can take part in reaching ``goal``: the achievers of its
    literals, then of their preconditions' literals, and so on (backward relevance, the
    operators Fast Downward's translator keeps as "necessary")."""
    return relevant_to(task, (atom for disjunct in goal.disjuncts for atom in disjunct))


def relevant_to(task: GroundTask, atoms: Iterable[int]) -> frozenset[int]:
    """The indices of the actions relevant to reaching ``atoms`` (see :func:`relevant_actions`)."""
    seen: set[int] = set()
    found: set[int] = set()
    pending = list(atoms)
    achievers, actions = task.achievers, task.actions
    while pending:
        atom = pending.pop()
        if atom in seen:
            continue
        seen.add(atom)
        for index in achievers[atom]:
            if index not in found:
                found.add(index)
                pending.extend(actions[index].pre)
    return frozenset(found)


__all__ = ["relevant_actions", "relevant_to"]
