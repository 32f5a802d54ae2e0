"""Goals resolved against a task: names checked (with did-you-mean messages), spelled as declared,
and turned into atom-id disjuncts (:class:`~hbtp.logic.goal.Goal`).

A goal comes as text (infix or PDDL, :mod:`hbtp.logic.goals`), as a :class:`~hbtp.logic.goals.GoalFormula`
read once, as a goal resolved against another task, or as one conjunction of literals.
"""

from __future__ import annotations

import weakref
from collections.abc import Iterable
from typing import TYPE_CHECKING

from hbtp.errors import InputError, UnknownSymbolError
from hbtp.logic.atoms import Atom, parse_atom
from hbtp.logic.goal import Goal
from hbtp.logic.goals import GoalFormula, parse_goal
from hbtp.logic.suggest import did_you_mean, listing

if TYPE_CHECKING:
    from hbtp.logic.task import GroundTask

#: What a goal can be given as (see the module docstring).
GoalSource = str | Goal | GoalFormula | Iterable[Atom | str]


def check_literal(task: GroundTask, atom: Atom) -> None:
    """Raise :class:`UnknownSymbolError` unless ``atom`` is well formed for this domain (names are
    case-insensitive; see :meth:`~hbtp.logic.task.GroundTask.spelled`)."""
    atom = task.spelled(atom).positive
    arity = task.predicates.get(atom.predicate)
    if arity is None:
        static_arity = task.static_arities.get(atom.predicate)
        if static_arity is None:
            hint = did_you_mean(atom.predicate, [*task.predicates, *task.static_arities])
            raise UnknownSymbolError(
                f"unknown predicate {atom.predicate!r} in {atom}{hint} (task {task.name!r} has: "
                f"{', '.join(sorted(task.predicates))})"
            )
        arity = static_arity
    if len(atom.args) != arity:
        raise UnknownSymbolError(f"{atom}: predicate {atom.predicate!r} takes {arity} argument(s)")
    unknown = [arg for arg in atom.args if arg not in task.symbols]
    if unknown:
        hint = did_you_mean(unknown[0], task.symbols) or _valid_objects(task, atom, atom.args.index(unknown[0]))
        raise UnknownSymbolError(f"unknown object {unknown[0]!r} in {atom}{hint}")


def goal_terms(task: GroundTask, goal: GoalSource) -> tuple[tuple[Atom, ...], ...]:
    """The terms of a goal text (infix or PDDL, see :mod:`hbtp.logic.goals`), of a goal resolved
    against another task, or of one conjunction of literals; names in their declared spelling."""
    if isinstance(goal, Goal | GoalFormula):
        raw = goal.terms
    elif isinstance(goal, str):
        raw = parse_goal(goal)
    else:
        raw = (tuple(parse_atom(a) if isinstance(a, str) else a for a in goal),)
    terms = tuple(tuple(dict.fromkeys(task.spelled(a) for a in term)) for term in raw)
    if not terms or not any(terms):
        raise InputError("empty goal")
    return terms


def negations_needed(task: GroundTask, goal: GoalSource) -> frozenset[int]:
    """The atoms whose negated twin a goal needs and this task lacks (see :meth:`resolve_goal`)."""
    needed: set[int] = set()
    for term in goal_terms(task, goal):
        for atom in term:
            atom_id = task.atom_ids.get(atom.positive)
            if (
                atom.negated
                and atom_id is not None
                and atom_id not in task.negation_ids
                and _negation_matters(task, atom_id)
            ):
                needed.add(atom_id)
    return frozenset(needed)


def _negation_matters(task: GroundTask, atom_id: int) -> bool:
    """Whether ``~atom`` can be false in some reachable state (s0 holds the atom, or an action adds it)."""
    return atom_id in task.initial_state or bool(task.achievers[atom_id])


def _valid_objects(task: GroundTask, atom: Atom, position: int) -> str:
    """`` (IsIn takes at argument 2: a, b, c)``: the objects the task's literals of ``atom``'s
    predicate have at ``position`` (its category, in effect), or ''."""
    values = sorted({a.args[position] for a in task.atoms if a.predicate == atom.predicate and len(a.args) > position})
    if not values:
        return ""
    where = f" at argument {position + 1}" if len(atom.args) > 1 else ""
    return f" ({atom.predicate} takes{where}: {listing(values)})"


def resolve_goal(task: GroundTask, goal: GoalSource) -> Goal:
    """Resolve a goal (``IsIn_milk_fridge & ~IsOpen(fridge) | IsOn_milk_table``, a PDDL goal, a
    goal of another task or a conjunction of literals) against this task.

    A negative literal ``~p`` needs ``p``'s negated twin in the task unless it always holds (no
    action adds ``p`` and s0 lacks it: it is dropped); :func:`negations_needed` says which are
    missing, and :func:`hbtp.logic.negation.with_negations` adds them.
    """
    if isinstance(goal, Goal) and goal.resolved_in(task):
        return goal  # resolved against this very task: nothing to do
    disjuncts: list[frozenset[int]] = []
    unreachable: list[Atom] = []
    contradictory: list[tuple[Atom, ...]] = []
    live: list[frozenset[int]] = []
    # A goal resolved against the same atoms (the task from another s0, when re-planning) has its
    # literals checked and spelled already; only what depends on s0 is worked out again.
    if isinstance(goal, Goal) and _same_atoms(goal, task):
        checked, terms = True, goal.terms
    else:
        checked, terms = False, goal_terms(task, goal)
    for term in terms:
        ids, missing = _term_ids(task, term, checked)
        if ids is None:
            contradictory.append(term)
            continue
        unreachable.extend(a for a in missing if a not in unreachable)
        if any(a.positive not in task.atom_ids for a in missing):
            continue  # a literal that is no atom of the task: the term can hold in no state
        disjuncts.append(ids)
        if not missing:
            live.append(ids)
    kept = tuple(
        d for i, d in enumerate(disjuncts) if not any(o < d or (o == d and j < i) for j, o in enumerate(disjuncts))
    )
    roots = tuple(d for d in kept if d in live)
    return Goal(terms, kept, tuple(unreachable), tuple(contradictory), roots, weakref.ref(task))


def _same_atoms(goal: Goal, task: GroundTask) -> bool:
    """Whether ``goal`` was resolved against a task with ``task``'s very atoms (and so symbols)."""
    origin = goal.origin() if goal.origin is not None else None
    return origin is not None and getattr(origin, "atoms", None) is task.atoms and origin.symbols is task.symbols


def _term_ids(
    task: GroundTask, term: tuple[Atom, ...], checked: bool = False
) -> tuple[frozenset[int] | None, list[Atom]]:
    """The atom ids of one conjunction, and its literals that can never hold (``None`` ids when
    it asks for a literal and its negation)."""
    ids: set[int] = set()
    missing: list[Atom] = []
    for atom in term:
        if not checked:
            check_literal(task, atom)
        if atom.predicate not in task.predicates:  # static: true or false in every state
            if (atom.positive in task.static_facts) == atom.negated:
                missing.append(atom)
            continue
        atom_id = task.atom_ids.get(atom.positive)
        if not atom.negated:
            if atom_id is None or (atom_id not in task.initial_state and not task.achievers[atom_id]):
                missing.append(atom)
            if atom_id is not None:
                ids.add(atom_id)
        elif atom_id is not None and _negation_matters(task, atom_id):
            twin = task.negation_ids.get(atom_id)
            if twin is None:
                raise InputError(
                    f"the goal literal {atom} needs the task with negated literals "
                    "(resolve the goal through its scenario, or hbtp.logic.negation.with_negations)"
                )
            if twin not in task.initial_state and not task.achievers[twin]:
                missing.append(atom)
            ids.add(twin)
    if any(task.negation_ids.get(i) in ids for i in ids):
        return None, missing
    return frozenset(ids), missing


__all__ = ["GoalSource", "check_literal", "goal_terms", "negations_needed", "resolve_goal"]
