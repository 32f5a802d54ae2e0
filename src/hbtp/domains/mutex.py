"""Invariants and mutexes, derived from the action models and the initial state of any task.

An *invariant* here is a group of atoms of which at most one holds in every reachable state, such as
``{IsNear(self,x) : x}`` or ``{IsOpen(x), IsClose(x)}``. Candidates are lifted *patterns* (one part
per predicate; each part maps its arguments to the pattern's parameters, except at most one counted
argument); every candidate is checked on the grounded task:

* the initial state holds at most one atom of each group, and
* every action that adds an atom ``g`` of a group either needs ``g`` already, or deletes a group atom
  that its precondition requires, or deletes every other atom of the group.

That induction proves the group. A candidate that fails on an action is refined with the atoms the
action deletes from its precondition (Fast Downward's invariant synthesis does the same, lifted).

Domains may *declare* further groups and forbidden combinations (nogoods) that cannot be proved,
for example when a quirk of the action models makes them false in odd corners of the state space.
Declared mutexes only prune the search; they never make a tree wrong, as every tree is verified, and
they never make a goal "unsolvable": :func:`hbtp.planning.plan` confirms a failed search that they
pruned with the proved mutexes alone (:meth:`Mutexes.proved_only`).
"""

from __future__ import annotations

import logging
from collections import deque
from collections.abc import Iterable, Sequence
from dataclasses import dataclass
from functools import cached_property

from hbtp.deadline import Deadline
from hbtp.errors import InputError
from hbtp.logic.atoms import Atom
from hbtp.logic.task import GroundTask

log = logging.getLogger(__name__)

# A part maps each argument position to a parameter index (int), a constant (str) or None (counted).
Slot = int | str | None
Part = tuple[str, tuple[Slot, ...]]
Pattern = tuple[Part, ...]

MAX_CANDIDATES = 2000


@dataclass(frozen=True)
class MutexGroup:
    """At most one of ``atoms`` holds in any reachable state (``proved``) or by declaration."""

    atoms: frozenset[int]
    pattern: str
    proved: bool


@dataclass(frozen=True)
class Mutexes:
    """Literals that cannot hold together: pairwise groups and larger declared nogoods."""

    groups: tuple[MutexGroup, ...]
    nogoods: tuple[frozenset[int], ...]
    atom_count: int

    @cached_property
    def partners(self) -> tuple[frozenset[int], ...]:
        """For each atom id, the atoms that can never hold together with it."""
        table: list[set[int]] = [set() for _ in range(self.atom_count)]
        for group in self.groups:
            for atom in group.atoms:
                table[atom] |= group.atoms
        for atom, partners in enumerate(table):
            partners.discard(atom)
        return tuple(frozenset(p) for p in table)

    @cached_property
    def nogoods_by_atom(self) -> tuple[tuple[frozenset[int], ...], ...]:
        table: list[list[frozenset[int]]] = [[] for _ in range(self.atom_count)]
        for nogood in self.nogoods:
            table[min(nogood)].append(nogood)
        return tuple(tuple(n) for n in table)

    def conflict(self, condition: Iterable[int]) -> frozenset[int] | None:
        """A set of literals of ``condition`` that cannot hold together, or ``None``."""
        atoms = frozenset(condition)
        partners = self.partners
        by_atom = self.nogoods_by_atom
        for atom in atoms:
            clash = partners[atom] & atoms
            if clash:
                return frozenset((atom, min(clash)))
            for nogood in by_atom[atom]:
                if nogood <= atoms:
                    return nogood
        return None

    @property
    def declared(self) -> bool:
        """Whether some groups or nogoods are declared rather than proved (they may be false)."""
        return bool(self.nogoods) or any(not group.proved for group in self.groups)

    def pairs(self) -> int:
        """How many pairs of literals are mutually exclusive."""
        return sum(len(p) for p in self.partners) // 2

    def proved_only(self) -> Mutexes:
        """The proved groups alone: pruning with them never cuts off a reachable condition."""
        return self._proved

    @cached_property
    def _proved(self) -> Mutexes:
        if not self.declared:
            return self
        return Mutexes(tuple(g for g in self.groups if g.proved), (), self.atom_count)


# ====================================================================== infer
def infer_mutexes(
    task: GroundTask,
    declared_groups: Sequence[Sequence[str]] = (),
    declared_nogoods: Sequence[Sequence[str]] = (),
    deadline: Deadline | None = None,
) -> Mutexes:
    """Prove invariant groups of ``task`` and add the declared ones (past ``deadline``,
    :class:`~hbtp.deadline.TimeLimitReached`).

    ``declared_groups`` are lifted patterns such as ``["IsLeftHandEmpty(self)", "IsLeftHolding(self,*)"]``
    (``?x`` a group parameter, ``*`` the counted argument); ``declared_nogoods`` are lifted atom sets
    such as ``["IsHoldingKnife(self)", "IsLeftHandEmpty(self)", "IsRightHandEmpty(self)"]``.
    """
    synth = _Synthesis(task)
    groups: dict[frozenset[int], MutexGroup] = {}
    for pattern in synth.proved_patterns(deadline):
        for atoms in synth.groups(pattern).values():
            if len(atoms) > 1 and frozenset(atoms) not in groups:
                groups[frozenset(atoms)] = MutexGroup(frozenset(atoms), _describe(pattern), True)
    for spec in declared_groups:
        pattern = _parse_pattern(spec, task)
        for atoms in synth.groups(pattern).values():
            if len(atoms) > 1 and frozenset(atoms) not in groups:
                groups[frozenset(atoms)] = MutexGroup(frozenset(atoms), _describe(pattern), False)
    nogoods = tuple(dict.fromkeys(n for spec in declared_nogoods for n in _ground_nogood(spec, task)))
    ordered = tuple(sorted(groups.values(), key=lambda g: (not g.proved, g.pattern, sorted(g.atoms))))
    log.debug("%s: %d mutex groups, %d declared nogoods", task.name, len(ordered), len(nogoods))
    return with_negation_groups(Mutexes(ordered, nogoods, len(task.atoms)), task)


def with_negation_groups(mutexes: Mutexes, task: GroundTask) -> Mutexes:
    """``mutexes`` for ``task``, which may have more atoms (negated twins appended by
    :func:`hbtp.logic.negation.with_negations`), with the group ``{p, ~p}`` of every twin.

    The group is proved by the usual induction: s0 holds exactly one of the two, and every action
    that adds one deletes the other (the compilation makes it so).
    """
    known = {group.atoms for group in mutexes.groups}
    added = tuple(
        MutexGroup(frozenset((atom, twin)), "negation", True)
        for atom, twin in sorted(task.negation_ids.items())
        if frozenset((atom, twin)) not in known
    )
    if not added and mutexes.atom_count == len(task.atoms):
        return mutexes
    return Mutexes((*mutexes.groups, *added), mutexes.nogoods, len(task.atoms))


class _Synthesis:
    def __init__(self, task: GroundTask) -> None:
        self.task = task
        self.atoms_by_predicate: dict[str, list[int]] = {}
        for atom_id, atom in enumerate(task.atoms):
            if not atom.negated:  # negated twins get their groups from with_negation_groups
                self.atoms_by_predicate.setdefault(atom.predicate, []).append(atom_id)
        self.adders_by_predicate: dict[str, list[int]] = {}
        for action in task.actions:
            for predicate in {task.atoms[a].predicate for a in action.add if not task.atoms[a].negated}:
                self.adders_by_predicate.setdefault(predicate, []).append(action.index)

    # ------------------------------------------------------------ candidates
    def initial_candidates(self) -> list[Pattern]:
        patterns: list[Pattern] = []
        for predicate, arity in sorted(self.task.predicates.items()):
            if predicate not in self.adders_by_predicate:
                continue
            patterns.append(((predicate, tuple(range(arity))),))
            for counted in range(arity):
                slots: list[Slot] = []
                next_param = 0
                for position in range(arity):
                    if position == counted:
                        slots.append(None)
                    else:
                        slots.append(next_param)
                        next_param += 1
                patterns.append(((predicate, tuple(slots)),))
        return patterns

    def proved_patterns(self, deadline: Deadline | None = None) -> list[Pattern]:
        queue = deque(_canonical(p) for p in self.initial_candidates())
        seen = set(queue)
        proved: list[Pattern] = []
        while queue and len(seen) < MAX_CANDIDATES:
            if deadline is not None:
                deadline.check("inferring mutexes")
            pattern = queue.popleft()
            holds, extension_points = self.check(pattern)
            if holds:
                proved.append(pattern)
            for action_index, key in extension_points:
                for refined in self.refinements(pattern, action_index, key):
                    canonical = _canonical(refined)
                    if canonical not in seen:
                        seen.add(canonical)
                        queue.append(canonical)
        return _maximal(proved)

    def refinements(self, pattern: Pattern, action_index: int, key: tuple[str, ...]) -> list[Pattern]:
        """New patterns adding one atom that the action deletes from its precondition."""
        action = self.task.actions[action_index]
        present = {part[0] for part in pattern}
        result: list[Pattern] = []
        for atom_id in sorted(action.pre & action.delete):
            atom = self.task.atoms[atom_id]
            if atom.predicate in present or atom.negated:
                continue
            for slots in _slot_choices(atom.args, key):
                result.append((*pattern, (atom.predicate, slots)))
        return result

    # ----------------------------------------------------------------- check
    def groups(self, pattern: Pattern) -> dict[tuple[str, ...], list[int]]:
        params = _param_count(pattern)
        table: dict[tuple[str, ...], list[int]] = {}
        for predicate, slots in pattern:
            for atom_id in self.atoms_by_predicate.get(predicate, ()):
                key = _key(self.task.atoms[atom_id].args, slots, params)
                if key is not None:
                    table.setdefault(key, []).append(atom_id)
        return table

    def check(self, pattern: Pattern) -> tuple[bool, list[tuple[int, tuple[str, ...]]]]:
        """Whether ``pattern`` is an invariant, and where it could be extended.

        The extension points are (action, group key) pairs where an action adds a group atom that its
        precondition does not require, one per action predicate; the first is the failure, if any.
        """
        groups = self.groups(pattern)
        key_of: dict[int, tuple[str, ...]] = {a: k for k, atoms in groups.items() for a in atoms}
        counts: dict[tuple[str, ...], int] = {}
        for atom_id in self.task.initial_state:
            key = key_of.get(atom_id)
            if key is not None:
                counts[key] = counts.get(key, 0) + 1
                if counts[key] > 1:
                    return False, []  # no refinement can repair the initial state
        points: dict[str, tuple[int, tuple[str, ...]]] = {}
        adders = sorted({i for predicate, _ in pattern for i in self.adders_by_predicate.get(predicate, ())})
        for index in adders:
            action = self.task.actions[index]
            added: dict[tuple[str, ...], list[int]] = {}
            for atom_id in action.add:
                key = key_of.get(atom_id)
                if key is not None:
                    added.setdefault(key, []).append(atom_id)
            for key, atoms in added.items():
                if len(atoms) > 1:
                    return False, [(index, key)]
                atom_id = atoms[0]
                if atom_id in action.pre:
                    continue
                points.setdefault(action.predicate, (index, key))
                group = groups[key]
                if any(h in action.delete and h in action.pre for h in group if h != atom_id):
                    continue
                if all(h in action.delete for h in group if h != atom_id):
                    continue
                return False, [(index, key), *(p for p in points.values() if p != (index, key))]
        return True, list(points.values())


def _slot_choices(args: tuple[str, ...], key: tuple[str, ...]) -> list[tuple[Slot, ...]]:
    """Ways to map ``args`` onto the parameters whose values are ``key`` (at most one counted arg)."""
    choices: list[tuple[Slot, ...]] = []

    def extend(position: int, slots: list[Slot], used: set[int], counted: bool) -> None:
        if position == len(args):
            if len(used) == len(key):
                choices.append(tuple(slots))
            return
        for param, value in enumerate(key):
            if value == args[position] and param not in used:
                extend(position + 1, [*slots, param], used | {param}, counted)
        if not counted:
            extend(position + 1, [*slots, None], used, True)

    extend(0, [], set(), False)
    return choices


def _param_count(pattern: Pattern) -> int:
    params = [s for _, slots in pattern for s in slots if isinstance(s, int)]
    return max(params) + 1 if params else 0


def _key(args: tuple[str, ...], slots: tuple[Slot, ...], params: int) -> tuple[str, ...] | None:
    values: list[str | None] = [None] * params
    for value, slot in zip(args, slots, strict=True):
        if slot is None:
            continue
        if isinstance(slot, str):
            if slot != value:
                return None
            continue
        if values[slot] is not None and values[slot] != value:
            return None
        values[slot] = value
    if any(v is None for v in values):
        return None
    return tuple(v for v in values if v is not None)


def _canonical(pattern: Pattern) -> Pattern:
    """Parts sorted by predicate, parameters renumbered by first appearance."""
    renumber: dict[int, int] = {}
    parts: list[Part] = []
    for predicate, slots in sorted(pattern, key=lambda p: p[0]):
        new_slots: list[Slot] = []
        for slot in slots:
            if isinstance(slot, int):
                renumber.setdefault(slot, len(renumber))
                new_slots.append(renumber[slot])
            else:
                new_slots.append(slot)
        parts.append((predicate, tuple(new_slots)))
    return tuple(parts)


def _maximal(patterns: list[Pattern]) -> list[Pattern]:
    """Drop patterns whose parts are a subset of another proved pattern's parts."""
    sets = [frozenset(p) for p in patterns]
    return [p for p, s in zip(patterns, sets, strict=True) if not any(s < other for other in sets)]


def _describe(pattern: Pattern) -> str:
    names = "xyzuvw"

    def slot_text(slot: Slot) -> str:
        if slot is None:
            return "*"
        if isinstance(slot, str):
            return slot
        return f"?{names[slot] if slot < len(names) else slot}"

    return " | ".join(f"{p}({','.join(slot_text(s) for s in slots)})" for p, slots in pattern)


# ----------------------------------------------------------------- declared
def _lifted(text: str, task: GroundTask) -> tuple[str, tuple[str, ...]]:
    text = text.strip()
    if not text.endswith(")") or "(" not in text:
        raise InputError(f"declared mutex {text!r}: expected Pred(arg,...)")
    predicate, inner = text[:-1].split("(", 1)
    args = tuple(a.strip() for a in inner.split(",")) if inner.strip() else ()
    if predicate not in task.predicates:
        raise InputError(f"declared mutex {text!r}: unknown predicate {predicate!r}")
    if len(args) != task.predicates[predicate]:
        raise InputError(f"declared mutex {text!r}: {predicate} takes {task.predicates[predicate]} argument(s)")
    for arg in args:
        if arg != "*" and not arg.startswith("?") and arg not in task.symbols:
            raise InputError(f"declared mutex {text!r}: unknown object {arg!r}")
    return predicate, args


def _parse_pattern(spec: Sequence[str], task: GroundTask) -> Pattern:
    parts = [_lifted(text, task) for text in spec]
    variables: dict[str, int] = {}
    for _, args in parts:
        for arg in args:
            if arg.startswith("?"):
                variables.setdefault(arg, len(variables))
    pattern: list[Part] = []
    for predicate, args in parts:
        if args.count("*") > 1:
            raise InputError(f"declared mutex group {list(spec)}: at most one '*' per atom")
        missing = set(variables) - set(args)
        if missing:
            raise InputError(f"declared mutex group {list(spec)}: every atom must use {', '.join(sorted(missing))}")
        pattern.append((predicate, tuple(None if a == "*" else variables[a] if a.startswith("?") else a for a in args)))
    return tuple(pattern)


def _ground_nogood(spec: Sequence[str], task: GroundTask) -> list[frozenset[int]]:
    parts = [_lifted(text, task) for text in spec]
    if len(parts) < 2:
        raise InputError(f"declared nogood {list(spec)}: needs at least two atoms")
    by_predicate: dict[str, list[Atom]] = {}
    for atom in task.atoms:
        by_predicate.setdefault(atom.predicate, []).append(atom)
    results: list[frozenset[int]] = []

    def join(index: int, binding: dict[str, str], chosen: list[int]) -> None:
        if index == len(parts):
            results.append(frozenset(chosen))
            return
        predicate, args = parts[index]
        for atom in by_predicate.get(predicate, ()):
            new = dict(binding)
            ok = True
            for pattern_arg, value in zip(args, atom.args, strict=True):
                if pattern_arg.startswith("?"):
                    if new.setdefault(pattern_arg, value) != value:
                        ok = False
                        break
                elif pattern_arg != "*" and pattern_arg != value:
                    ok = False
                    break
            if ok:
                join(index + 1, new, [*chosen, task.atom_ids[atom]])

    join(0, {}, [])
    return [r for r in results if len(r) == len(parts)]
