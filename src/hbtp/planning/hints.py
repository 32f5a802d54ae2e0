"""Hints from an LLM (or an oracle) and the action-space pruning of the paper's §III-C.

Hints are a plain typed value: the heuristic path p̂ (a multiset of grounded actions, in order),
the relevant action predicates Q̂ and the relevant objects Ô. The planner never trusts them for
correctness: they only order the search and choose the action space.
"""

from __future__ import annotations

import functools
import hashlib
import logging
import random
from collections import Counter, defaultdict
from collections.abc import Collection, Iterable, Sequence
from dataclasses import dataclass
from typing import TypeVar

from hbtp.errors import InputError
from hbtp.logic.atoms import parse_atom
from hbtp.logic.names import ActionNames
from hbtp.logic.task import GroundTask

log = logging.getLogger(__name__)

_T = TypeVar("_T")


@dataclass(frozen=True)
class Hints:
    """p̂, Q̂ and Ô as names (``Walk(apple)`` / ``Walk_apple``, ``Walk``, ``apple``)."""

    path: tuple[str, ...] = ()
    predicates: tuple[str, ...] = ()
    objects: tuple[str, ...] = ()

    @property
    def empty(self) -> bool:
        return not (self.path or self.predicates or self.objects)

    def grown_by(self, newer: Hints, names: ActionNames) -> Hints:
        """``newer``'s p̂ with the action predicates and objects of both and of the actions of p̂
        (Q⁻ = Q̂ ∪ Q(p̂), O⁻ = Ô ∪ O(p̂), the feedback rounds': the space only grows); names that
        ``names`` does not know are left out."""
        path = [atom for atom in (parse_atom(a) for a in newer.path) if atom in names.signatures]
        known = set(names.action_predicates)
        predicates = dict.fromkeys(self.predicates)
        predicates.update(dict.fromkeys(p for p in newer.predicates if p in known))
        predicates.update(dict.fromkeys(a.predicate for a in path))
        objects = dict.fromkeys(self.objects)
        objects.update(dict.fromkeys(o for o in newer.objects if o in names.symbols))
        objects.update(dict.fromkeys(o for a in path for o in a.args))
        return Hints(tuple(str(a) for a in path), tuple(predicates), tuple(objects))

    @classmethod
    def from_plan(cls, task: GroundTask, actions: Iterable[int]) -> Hints:
        """p̂ = the plan's actions (``Walk(apple)``), Q̂ and Ô = their predicates and objects, in order of first use."""
        plan = [task.actions[i] for i in actions]
        predicates = tuple(dict.fromkeys(a.predicate for a in plan))
        objects = tuple(dict.fromkeys(o for a in plan for o in a.objects))
        return cls(tuple(a.name for a in plan), predicates, objects)


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

    def space(self, task: GroundTask) -> ResolvedHints:
        """The same p̂ with Q⁻ = Q̂ ∪ Q(p̂) and O⁻ = Ô ∪ O(p̂): the names the pruned space keeps."""
        path_actions = [task.actions[i] for i in self.path]
        return ResolvedHints(
            self.path,
            self.predicates | {a.predicate for a in path_actions},
            self.objects | {o for a in path_actions for o in a.objects},
            self.unknown,
        )


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


class PrunedSpace:
    """The pruned action space of some hints, A⁻ = (Q⁻ × O⁻) ∩ A with Q⁻ = Q̂ ∪ Q(p̂) and
    O⁻ = Ô ∪ O(p̂) (every argument must be in O⁻), and that space widened for a re-plan from another
    state (:meth:`around`), found without a pass over every action."""

    def __init__(self, task: GroundTask, hints: ResolvedHints) -> None:
        space = hints.space(task)
        self.task = task
        self.predicates, self.objects = space.predicates, space.objects
        predicates, objects = space.predicates, space.objects
        self._undo_names: dict[tuple[int, bool], frozenset[str]] = {}
        #: A⁻ itself, in task order.
        self.base = tuple(
            a.index for a in task.actions if a.predicate in predicates and all(o in objects for o in a.objects)
        )

    @functools.cached_property
    def outside(self) -> dict[str, list[tuple[int, frozenset[str]]]]:
        """The actions of Q⁻ with arguments outside O⁻, each under the least of those arguments
        (built at the first widening)."""
        table: dict[str, list[tuple[int, frozenset[str]]]] = defaultdict(list)
        for action in self.task.actions:
            if action.predicate in self.predicates:
                extra = frozenset(action.objects) - self.objects
                if extra:
                    table[min(extra)].append((action.index, extra))
        return table

    @functools.cached_property
    def other(self) -> dict[str, list[tuple[int, frozenset[str]]]]:
        """The actions of the predicates outside Q⁻, under their predicate, with their arguments
        outside O⁻ (built at the first widening by predicates)."""
        table: dict[str, list[tuple[int, frozenset[str]]]] = defaultdict(list)
        for action in self.task.actions:
            if action.predicate not in self.predicates:
                table[action.predicate].append((action.index, frozenset(action.objects) - self.objects))
        return table

    @functools.cached_property
    def deleters(self) -> dict[int, list[int]]:
        """For each atom, the actions that delete it (built at the first use)."""
        table: dict[int, list[int]] = defaultdict(list)
        for action in self.task.actions:
            for atom in action.delete:
                table[atom].append(action.index)
        return table

    def prepare(self) -> None:
        """Build now the indexes :meth:`around` uses (else at its first call)."""
        built = (self.outside, self.other, self.deleters)
        log.debug("pruned space indexed: %d objects outside, %d other predicates", len(built[0]), len(built[1]))

    def actions(self, objects: Iterable[str] = (), predicates: Iterable[str] = ()) -> tuple[int, ...]:
        """The indices of A⁻ with O⁻ widened by ``objects`` and Q⁻ by ``predicates``, in task order."""
        added = set(objects) - self.objects
        found = [index for obj in added for index, extra in self.outside.get(obj, ()) if extra <= added]
        for name in sorted(set(predicates) - self.predicates):
            found += [index for index, extra in self.other.get(name, ()) if extra <= added]
        return tuple(sorted([*self.base, *found])) if found else self.base

    def undoing(self, state: frozenset[int], space: Collection[int] = ()) -> set[int]:
        """The actions that undo a change of ``state`` from the task's start state: delete an atom it
        gained (unless an action of ``space`` deletes it already: a walk in the space takes the robot
        away from where it was moved to), or add one it lost."""
        start = self.task.initial_state
        undo = {index for atom in start - state for index in self._undoers(atom, gained=False)}
        for atom in state - start:
            found = self._undoers(atom, gained=True)
            if not any(index in space for index in found):
                undo.update(found)
        return undo

    def _undoers(self, atom: int, *, gained: bool) -> Sequence[int]:
        """The actions that undo a change of ``atom``: delete it (``gained``) or add it (lost)."""
        return self.deleters.get(atom, ()) if gained else self.task.achievers[atom]

    def _undo_predicates(self, atom: int, gained: bool) -> frozenset[str]:
        """The predicates of :meth:`_undoers` (kept per atom)."""
        key = (atom, gained)
        known = self._undo_names.get(key)
        if known is None:
            actions = self.task.actions
            known = self._undo_names[key] = frozenset(actions[i].predicate for i in self._undoers(atom, gained=gained))
        return known

    def around(self, state: Iterable[int]) -> tuple[int, ...]:
        """A⁻ for a re-plan from ``state``: widened by the objects of every atom the state changed
        from the task's start state, by the predicates of the actions that undo a change
        (:meth:`undoing`: put down what a disturbance put in a hand), and by the actions that apply
        in ``state`` and give back an atom of the start state it took away (empty the hand where the
        robot is, on what the hints never name). The hints did not foresee the disturbance."""
        task, now = self.task, frozenset(state)
        changed = now ^ task.initial_state
        undo = set[str]().union(*(self._undo_predicates(atom, atom in now) for atom in changed))
        widened = self.actions({obj for atom in changed for obj in task.atoms[atom].args}, undo)
        actions, achievers = task.actions, task.achievers
        restoring = {i for atom in task.initial_state - now for i in achievers[atom] if actions[i].pre <= now}
        return widened if restoring <= set(widened) else tuple(sorted(restoring.union(widened)))

    def beyond(self, state: Iterable[int]) -> tuple[int, ...]:
        """:meth:`around` with the actions that undo a change (:meth:`undoing`: not those of an atom
        gained that the space deletes already) and apply in ``state`` or after one action that applies
        there, and those actions: put the thing in the hand down on any surface (the hints name none
        to put it on), after walking there; not a walk to everywhere because the robot was moved. A
        pass over every action."""
        task, now = self.task, frozenset(state)
        around = self.around(now)
        applicable = [action for action in task.actions if action.pre <= now]
        near = now.union(*(action.add for action in applicable))
        undoing = self.undoing(now, frozenset(around))
        undo = [task.actions[index] for index in sorted(undoing) if task.actions[index].pre <= near]
        needed = frozenset().union(*(a.pre for a in undo)) - now
        enabling = [action.index for action in applicable if action.add & needed]
        return tuple(sorted({*around, *(a.index for a in undo), *enabling}))


def pruned_action_space(task: GroundTask, hints: ResolvedHints) -> tuple[int, ...]:
    """A⁻ = (Q⁻ × O⁻) ∩ A (:class:`PrunedSpace`)."""
    return PrunedSpace(task, hints).actions()


def hints_from_names(path: Iterable[str] = (), predicates: Iterable[str] = (), objects: Iterable[str] = ()) -> Hints:
    """Build hints from name lists, normalising action names to the ``Walk(apple)`` form."""
    normalised: list[str] = []
    for name in path:
        try:
            normalised.append(str(parse_atom(name)))
        except InputError:
            normalised.append(name.strip())
    return Hints(tuple(normalised), tuple(p.strip() for p in predicates), tuple(o.strip() for o in objects))


@dataclass(frozen=True)
class PathNoise:
    """Errors in a heuristic path (the paper's error-tolerance study, Fig. 4): each action of the
    right path is kept with probability ``correct``, and ``round(error * len(path))`` wrong ones are
    inserted at random places.

    The one noise model of hbtp: Figure 4 applies it to the records' plans, the ``noisy-oracle``
    backend to the optimal plans. Seeded by :func:`seeded_random`, so reruns give the same paths.
    """

    correct: float = 1.0
    error: float = 0.0

    def scaled(self, factor: float) -> PathNoise:
        """``factor`` times the noise: that fraction of the drops and of the insertions."""
        return PathNoise(1.0 - (1.0 - self.correct) * factor, self.error * factor)

    def apply(self, path: Sequence[_T], wrong: Sequence[_T], rng: random.Random) -> list[_T]:
        """``path`` with the noise; the inserted actions are drawn from ``wrong`` (none when it is empty)."""
        noisy = [item for item in path if rng.random() < self.correct]
        for _ in range(round(self.error * len(path)) if wrong else 0):
            noisy.insert(rng.randrange(len(noisy) + 1), rng.choice(wrong))
        return noisy


def seeded_random(*parts: object) -> random.Random:
    """A random generator seeded by ``parts`` (their text joined by ``|``), the same in every process."""
    digest = hashlib.sha256("|".join(map(str, parts)).encode()).digest()
    return random.Random(int.from_bytes(digest[:8], "big"))
