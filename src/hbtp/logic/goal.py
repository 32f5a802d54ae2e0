"""A goal resolved against a task: its disjuncts as atom-id sets (see :mod:`hbtp.logic.resolve`)."""

from __future__ import annotations

import weakref
from collections.abc import Iterable
from dataclasses import dataclass, field
from typing import Any

from hbtp.logic.atoms import Atom
from hbtp.logic.suggest import listing


@dataclass(frozen=True)
class Goal:
    """A goal in disjunctive normal form, resolved against a task.

    ``terms`` are the goal's conjunctions as written (names in their declared spelling, literals
    possibly negated); ``disjuncts`` the atom-id sets of the terms that can be satisfied, without
    the ones another disjunct makes redundant (a superset of another). A goal holds in a state when
    one of its disjuncts does. ``unreachable`` lists well-formed literals that no action makes true
    and s0 does not hold; ``reachable`` are the disjuncts without one (the search's roots), and
    ``contradictory`` the terms left out because they ask for a literal and its negation. When no
    disjunct is reachable, the goal is unsolvable for those reasons.
    """

    terms: tuple[tuple[Atom, ...], ...]
    disjuncts: tuple[frozenset[int], ...]
    unreachable: tuple[Atom, ...] = ()
    contradictory: tuple[tuple[Atom, ...], ...] = ()
    reachable: tuple[frozenset[int], ...] = ()
    #: The task the goal was resolved against, held weakly (``None``: not known, e.g. unpickled), so
    #: that resolving it there again is free (:meth:`resolved_in`).
    origin: weakref.ref[Any] | None = field(default=None, compare=False, repr=False)

    def resolved_in(self, task: object) -> bool:
        """Whether this goal's atom ids are ``task``'s (it was resolved against that very task)."""
        return self.origin is not None and self.origin() is task

    def __getstate__(self) -> dict[str, Any]:
        state = dict(self.__dict__)
        state["origin"] = None  # a weak reference is not pickled (nor is the task)
        return state

    def __str__(self) -> str:
        return " | ".join(" & ".join(a.underscored for a in term) for term in self.terms)

    @property
    def atoms(self) -> tuple[Atom, ...]:
        """Every literal of the goal, in the order written."""
        return tuple(dict.fromkeys(atom for term in self.terms for atom in term))

    @property
    def conjunctive(self) -> bool:
        """Whether the goal is one conjunction (the paper's goals)."""
        return len(self.terms) == 1

    @property
    def ids(self) -> frozenset[int]:
        """The atom ids of a conjunctive goal (raises ``ValueError`` for a disjunction)."""
        if len(self.disjuncts) == 1:
            return self.disjuncts[0]
        if not self.disjuncts:
            return frozenset()
        raise ValueError(f"the goal {self} is a disjunction: use Goal.disjuncts or Goal.holds")

    @property
    def literal_ids(self) -> frozenset[int]:
        """The atom ids of every disjunct together (what a heuristic must reach)."""
        return frozenset().union(*self.disjuncts)

    def holds(self, state: Iterable[int]) -> bool:
        """Whether one of the disjuncts holds in ``state``."""
        present = state if isinstance(state, frozenset | set) else frozenset(state)
        return any(d <= present for d in self.disjuncts)

    @property
    def unsolvable(self) -> str | None:
        """Why no state can satisfy the goal (no disjunct is left), or ``None``."""
        if self.reachable:
            return None
        reasons: list[str] = []
        if self.unreachable:
            reasons.append(f"no action makes {listing(str(a) for a in self.unreachable)} true and s0 does not hold it")
        for term in self.contradictory[:3]:
            reasons.append(f"{' & '.join(a.underscored for a in term)} asks for a literal and its negation")
        return "; ".join(reasons) or "the goal has no alternative"


#: What a goal can be given as where only its meaning matters: a :class:`Goal`, or the atom ids of
#: a conjunction.
GoalIds = Goal | Iterable[int]


def disjuncts_of(goal: GoalIds) -> tuple[frozenset[int], ...]:
    """The disjuncts of ``goal`` (one for a conjunction given by its atom ids)."""
    return goal.disjuncts if isinstance(goal, Goal) else (frozenset(goal),)


__all__ = ["Goal", "GoalIds", "disjuncts_of"]
