"""The names of an action space: what the LLM side reads and checks, without conditions or effects.

A prompt's vocabulary, the reply's grammar and the check of a reply need the ground actions' names
(``Walk(apple)``), their costs, the values each condition predicate's arguments take and the object
categories, but none of the actions' preconditions and effects. :func:`names_of` reads them off a
grounded task; :mod:`hbtp.domains.pruned` builds them from the lifted model without grounding it,
so that LLM guidance can prune a large world before it is grounded.
"""

from __future__ import annotations

from collections.abc import Mapping
from dataclasses import dataclass, field
from functools import cached_property
from typing import TypeVar

from hbtp.logic.atoms import Atom
from hbtp.logic.tables import Tables, TaskTable
from hbtp.logic.task import GroundTask

_T = TypeVar("_T")


@dataclass(frozen=True, eq=False)
class ActionNames:
    """The ground actions' names (in task order) and costs, and the vocabulary of their conditions.

    ``condition_slots`` gives, for each fluent predicate (sorted), the values each of its argument
    positions takes; ``categories`` are the unary static predicates with their sorted members.
    """

    actions: tuple[Atom, ...]
    costs: tuple[int, ...]
    objects: tuple[str, ...]
    constants: tuple[str, ...]
    condition_slots: Mapping[str, tuple[frozenset[str], ...]]
    categories: Mapping[str, tuple[str, ...]] = field(default_factory=dict)

    @cached_property
    def action_predicates(self) -> tuple[str, ...]:
        """Action predicate names (the paper's Q), in first-named order."""
        return tuple(dict.fromkeys(a.predicate for a in self.actions))

    @cached_property
    def symbols(self) -> frozenset[str]:
        return frozenset(self.objects) | frozenset(self.constants)

    @cached_property
    def signatures(self) -> frozenset[Atom]:
        return frozenset(self.actions)

    @cached_property
    def _tables(self) -> Tables:
        return Tables()

    def tables(self, state_free: bool = False) -> Tables:
        """The tables kept with these names (:class:`~hbtp.logic.tables.TaskTable`)."""
        return self._tables


#: A grounded task's action names (what the LLM side reads of it).
NAMES: TaskTable[ActionNames] = TaskTable("the action and condition names")


def names_of(task: GroundTask) -> ActionNames:
    """The names of ``task``'s actions and conditions (built once, kept with the task)."""
    return NAMES.of(task, lambda: _names(task))


def _names(task: GroundTask) -> ActionNames:
    positions: dict[str, list[set[str]]] = {}
    for atom in task.atoms:
        slots = positions.setdefault(atom.predicate, [set() for _ in atom.args])
        for slot, value in zip(slots, atom.args, strict=True):
            slot.add(value)
    return ActionNames(
        actions=tuple(a.signature for a in task.actions),
        costs=tuple(a.cost for a in task.actions),
        objects=task.objects,
        constants=task.constants,
        condition_slots={p: tuple(frozenset(s) for s in positions.get(p, ())) for p in sorted(task.predicates)},
        categories=task.categories,
    )


__all__ = ["ActionNames", "names_of"]
