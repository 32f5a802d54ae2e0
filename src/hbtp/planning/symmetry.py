"""Interchangeable objects, and the symmetry pruning of the backward search they allow.

Two objects are *interchangeable* in a task when swapping them in every atom maps s0 onto s0, the
goal onto the goal (its disjuncts as a set), the static facts onto themselves, and every action onto an
action of the same cost whose precondition and effects are the swapped ones (gripper's balls, which
all start in one room and must all reach the other). Such swaps generate every permutation of a class
of mutually interchangeable objects, and a permutation σ maps each plan from s0 to a condition ``c``
onto a plan of the same cost from s0 to ``σ(c)``, and each way from ``c`` to the goal onto one from
``σ(c)``. So the backward search needs one condition of each such orbit: a condition whose
:meth:`Symmetry.canonical` image is already held by another at no higher g is pruned, like a
duplicate (Pochter, Zohar & Rosenschein, 2011, for forward search). The search stays optimal, and the
tree stays sound (it holds only conditions that were really regressed), but it is smaller: it no longer
holds the symmetric variants of its conditions, so it reacts to fewer disturbances. That is why the
pruning is a choice (``symmetry`` of :class:`~hbtp.planning.search.SearchConfig`).

The image is canonical up to ties: within each class, objects are ordered by the atoms of the
condition that mention them (other objects of a class written as the class), and the condition is
relabelled in that order. Two symmetric conditions may still get different images (then neither is
pruned); an image is always a true permutation of its condition, which is all that soundness needs.
"""

from __future__ import annotations

import logging
from collections import defaultdict
from collections.abc import Collection, Sequence

from hbtp.logic.atoms import Atom
from hbtp.logic.task import GroundAction, GroundTask

log = logging.getLogger(__name__)


class Symmetry:
    """The classes of interchangeable objects of a task, and the canonical image of a condition."""

    def __init__(self, task: GroundTask, classes: Sequence[Sequence[str]]) -> None:
        self.task = task
        self.classes = tuple(tuple(members) for members in classes)
        self.class_of = {o: k for k, members in enumerate(self.classes) for o in members}
        self.rank = {o: i for members in self.classes for i, o in enumerate(members)}
        # Per atom, its (object, shape) occurrences of class objects: the shape names the atom with that
        # object as a hole and the other class objects as their class, so equal shapes are the same role.
        shapes: dict[tuple[object, ...], int] = {}
        self.occurrences: list[tuple[tuple[str, int], ...]] = []
        for atom in task.atoms:
            found = []
            for position, name in enumerate(atom.args):
                if name in self.class_of:
                    key = (atom.predicate, atom.negated, position, *(self._role(other) for other in atom.args))
                    found.append((name, shapes.setdefault(key, len(shapes))))
            self.occurrences.append(tuple(found))

    def _role(self, name: str) -> object:
        k = self.class_of.get(name)
        return name if k is None else k

    def canonical(self, condition: frozenset[int]) -> frozenset[int]:
        """A condition symmetric to ``condition`` (itself when no class object appears in it), the
        same for symmetric conditions up to ties."""
        occurrences = self.occurrences
        touched = [atom for atom in condition if occurrences[atom]]
        if not touched:
            return condition
        profiles: dict[str, list[int]] = defaultdict(list)
        for atom in touched:
            for name, shape in occurrences[atom]:
                profiles[name].append(shape)
        mapping: dict[str, str] = {}
        rank = self.rank
        for members in self.classes:
            present = [o for o in members if o in profiles]
            if not present:
                continue
            ordered = sorted(present, key=lambda o: (sorted(profiles[o]), rank[o]))
            for target, source in zip(members, ordered, strict=False):
                if target != source:
                    mapping[source] = target
        if not mapping:
            return condition
        atoms, ids = self.task.atoms, self.task.atom_ids
        return (condition - frozenset(touched)) | frozenset(ids[_renamed(atoms[i], mapping)] for i in touched)


def find_symmetry(
    task: GroundTask, goal: Collection[frozenset[int]], actions: Sequence[GroundAction]
) -> Symmetry | None:
    """The interchangeable objects of ``task`` for ``goal`` (its disjuncts) with the action space
    ``actions`` (only the whole space is checked: a pruned space is not searched with symmetry),
    or ``None`` when there are none."""
    if len(actions) != len(task.actions):
        return None
    swaps = _Swaps(task, goal)
    classes: list[list[str]] = []
    for group in swaps.candidates():
        remaining = group
        while len(remaining) >= 2:
            first, members, rest = remaining[0], [remaining[0]], list[str]()
            for other in remaining[1:]:
                (members if swaps.is_symmetry(first, other) else rest).append(other)
            if len(members) >= 2:
                classes.append(members)
            remaining = rest
    if not classes:
        return None
    log.info("%s: interchangeable objects: %s", task.name, "; ".join(", ".join(c) for c in classes))
    return Symmetry(task, classes)


class _Swaps:
    """Whether swapping two objects is a symmetry of a task and goal (internal)."""

    def __init__(self, task: GroundTask, goal: Collection[frozenset[int]]) -> None:
        self.task = task
        self.goal = frozenset(goal)
        self.atoms_of: dict[str, list[int]] = defaultdict(list)
        for index, fact in enumerate(task.atoms):
            for name in set(fact.args):
                self.atoms_of[name].append(index)
        self.actions_of: dict[str, set[int]] = defaultdict(set)
        for action in task.actions:
            names = set(action.signature.args)
            for atom in (*action.pre, *action.add, *action.delete):
                names.update(task.atoms[atom].args)
            for name in names:
                self.actions_of[name].add(action.index)

    def candidates(self) -> list[list[str]]:
        """Groups of objects that may be interchangeable: same atoms of s0, goal and static facts
        by predicate and position, and as many actions (constants never are)."""
        task = self.task
        goal_atoms = frozenset().union(*self.goal) if self.goal else frozenset()
        marks: dict[str, list[tuple[object, ...]]] = defaultdict(list)
        listed = {
            "s0": [task.atoms[i] for i in task.initial_state],
            "goal": [task.atoms[i] for i in goal_atoms],
            "static": list(task.static_facts),
        }
        for where, atoms in listed.items():
            for atom in atoms:
                for position, name in enumerate(atom.args):
                    marks[name].append((where, atom.predicate, atom.negated, position))
        groups: dict[tuple[object, ...], list[str]] = defaultdict(list)
        constants = set(task.constants)
        for name in task.objects:
            if name not in constants:
                groups[(tuple(sorted(marks[name])), len(self.actions_of[name]))].append(name)
        return [members for members in groups.values() if len(members) >= 2]

    def is_symmetry(self, a: str, b: str) -> bool:
        """Whether swapping ``a`` and ``b`` maps s0, the goal, the static facts and the actions onto
        themselves."""
        task = self.task
        image = self._image(a, b)
        if image is None:
            return False
        s0 = task.initial_state
        if any((index in s0) != (moved in s0) for index, moved in image.items()):
            return False
        if frozenset(frozenset(image.get(i, i) for i in d) for d in self.goal) != self.goal:
            return False
        statics = [f for f in task.static_facts if a in f.args or b in f.args]
        if {_swapped(f, a, b) for f in statics} != set(statics):
            return False
        return all(self._maps_action(index, image, a, b) for index in sorted(self.actions_of[a] | self.actions_of[b]))

    def _image(self, a: str, b: str) -> dict[int, int] | None:
        """The swap of ``a`` and ``b`` on the atoms that hold either (``None``: an image is no atom)."""
        task = self.task
        image: dict[int, int] = {}
        for index in (*self.atoms_of[a], *self.atoms_of[b]):
            moved = task.atom_ids.get(_swapped(task.atoms[index], a, b))
            if moved is None:
                return None
            image[index] = moved
        return image

    def _maps_action(self, index: int, image: dict[int, int], a: str, b: str) -> bool:
        """Whether the swap of action ``index`` is an action of the same cost and swapped atoms."""
        task = self.task
        action = task.actions[index]
        twin_index = task.action_ids.get(_swapped(action.signature, a, b))
        if twin_index is None:
            return False
        twin = task.actions[twin_index]
        return (
            twin.cost == action.cost
            and twin.pre == frozenset(image.get(i, i) for i in action.pre)
            and twin.add == frozenset(image.get(i, i) for i in action.add)
            and twin.delete == frozenset(image.get(i, i) for i in action.delete)
        )


def _swapped(atom: Atom, a: str, b: str) -> Atom:
    return _renamed(atom, {a: b, b: a})


def _renamed(atom: Atom, mapping: dict[str, str]) -> Atom:
    """``atom`` with its objects renamed by ``mapping`` (the others kept)."""
    return Atom(atom.predicate, tuple(mapping.get(name, name) for name in atom.args), atom.negated)
