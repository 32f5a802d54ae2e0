"""Hints from an LLM (or an oracle) and the action-space pruning of the paper's §III-C.

Hints are a plain typed value: the heuristic path p̂ (a multiset of grounded actions, in order),
the relevant action predicates Q̂ and the relevant objects Ô. The planner never trusts them for
correctness: they only order the search and choose the action space.
"""

from __future__ import annotations

import logging
from collections import Counter
from collections.abc import Iterable
from dataclasses import dataclass

from hbtp.datasets.records import Record
from hbtp.errors import InputError
from hbtp.logic.atoms import parse_atom
from hbtp.logic.task import GroundTask

log = logging.getLogger(__name__)


@dataclass(frozen=True)
class Hints:
    """p̂, Q̂ and Ô as names (``Walk(apple)`` / ``Walk_apple``, ``Walk``, ``apple``)."""

    path: tuple[str, ...] = ()
    predicates: tuple[str, ...] = ()
    objects: tuple[str, ...] = ()

    @property
    def empty(self) -> bool:
        return not (self.path or self.predicates or self.objects)


@dataclass(frozen=True)
class ResolvedHints:
    """Hints checked against a task: unknown names are reported and left out, never fatal."""

    path: tuple[int, ...]
    predicates: frozenset[str]
    objects: frozenset[str]
    unknown: tuple[str, ...] = ()

    @property
    def owed(self) -> dict[int, int]:
        """How many times each action of p̂ may be discounted along one search path: I(p̂, a)."""
        return dict(Counter(self.path))


def resolve_hints(task: GroundTask, hints: Hints) -> ResolvedHints:
    """Map hint names to the task's actions, predicates and objects; collect the unknown ones."""
    unknown: list[str] = []
    path: list[int] = []
    for name in hints.path:
        try:
            path.append(task.action(parse_atom(name)).index)
        except InputError:
            unknown.append(f"action {name}")
    known_predicates = set(task.action_predicates)
    predicates = set()
    for predicate in hints.predicates:
        if predicate in known_predicates:
            predicates.add(predicate)
        else:
            unknown.append(f"action predicate {predicate}")
    objects = set()
    for obj in hints.objects:
        if obj in task.symbols:
            objects.add(obj)
        else:
            unknown.append(f"object {obj}")
    if unknown:
        log.info("hints name %d unknown item(s), ignored: %s", len(unknown), ", ".join(unknown))
    return ResolvedHints(
        path=tuple(path),
        predicates=frozenset(predicates),
        objects=frozenset(objects),
        unknown=tuple(unknown),
    )


def pruned_action_space(task: GroundTask, hints: ResolvedHints) -> tuple[int, ...]:
    """A⁻ = (Q⁻ × O⁻) ∩ A with Q⁻ = Q̂ ∪ Q(p̂) and O⁻ = Ô ∪ O(p̂): every argument must be in O⁻."""
    path_actions = [task.actions[i] for i in hints.path]
    predicates = hints.predicates | {a.predicate for a in path_actions}
    objects = hints.objects | {o for a in path_actions for o in a.objects}
    return tuple(a.index for a in task.actions if a.predicate in predicates and all(o in objects for o in a.objects))


def hints_from_names(path: Iterable[str] = (), predicates: Iterable[str] = (), objects: Iterable[str] = ()) -> Hints:
    """Build hints from name lists, normalising action names to the ``Walk(apple)`` form."""
    normalised: list[str] = []
    for name in path:
        try:
            normalised.append(str(parse_atom(name)))
        except InputError:
            normalised.append(name.strip())
    return Hints(tuple(normalised), tuple(p.strip() for p in predicates), tuple(o.strip() for o in objects))


def hints_from_record(record: Record) -> Hints:
    """A dataset record's plan, vital predicates and objects as hints (the oracle of the benchmarks)."""
    return hints_from_names(record.optimal_actions, record.vital_predicates, record.vital_objects)
