"""The grounded STRIPS task: interned atoms, grounded actions, the initial state.

Semantics (pyperplan's three lines): an action is applicable in ``s`` when ``pre <= s``;
progression is ``(s - delete) | add``; regression of a condition ``c`` through ``a`` is defined when
``c & delete`` is empty and gives ``pre | (c - add)`` (the backward search, :mod:`hbtp.planning.search`,
computes it inline, with its mutex check).

States and conditions are ``frozenset[int]`` of atom ids; :class:`Atom` names are kept at the edges.
"""

from __future__ import annotations

import dataclasses
from collections.abc import Iterable, Mapping
from dataclasses import dataclass, field
from functools import cached_property
from typing import Any, TypeVar

from hbtp.errors import UnknownSymbolError
from hbtp.logic.atoms import Atom, parse_atom
from hbtp.logic.goal import Goal, GoalIds, disjuncts_of
from hbtp.logic.goals import GoalFormula
from hbtp.logic.resolve import check_literal, resolve_goal
from hbtp.logic.suggest import did_you_mean, listing
from hbtp.logic.tables import Tables, TaskTable

State = frozenset[int]
_T = TypeVar("_T")
Condition = frozenset[int]


@dataclass(frozen=True, slots=True)
class GroundAction:
    """A grounded action: ``Walk(apple)`` with its precondition, add and delete effects and cost."""

    index: int
    signature: Atom
    pre: frozenset[int]
    add: frozenset[int]
    delete: frozenset[int]
    cost: int

    @property
    def name(self) -> str:
        return str(self.signature)

    @property
    def predicate(self) -> str:
        return self.signature.predicate

    @property
    def objects(self) -> tuple[str, ...]:
        return self.signature.args

    def applicable(self, state: State) -> bool:
        return self.pre <= state

    def progress(self, state: State) -> State:
        return (state - self.delete) | self.add


@dataclass(frozen=True, eq=False)
class GroundTask:
    """A grounded planning task over interned atoms.

    Tasks compare and hash by identity (they are large; caches key on the task object).

    ``objects`` are the problem's objects (the paper's O); ``constants`` are the domain's own symbols
    (``self``, ``Nothing``…). ``predicates`` maps each fluent predicate to its arity and
    ``static_facts`` holds the compiled-away facts (object categories and relations).
    """

    name: str
    atoms: tuple[Atom, ...]
    actions: tuple[GroundAction, ...]
    initial_state: State
    objects: tuple[str, ...]
    constants: tuple[str, ...] = ()
    predicates: Mapping[str, int] = field(default_factory=dict)
    static_facts: frozenset[Atom] = frozenset()
    #: The domain's predicates that no action changes, with their arities (facts of them or not).
    static_predicates: Mapping[str, int] = field(default_factory=dict)

    # ----------------------------------------------------------------- lookups
    @cached_property
    def atom_ids(self) -> dict[Atom, int]:
        return {atom: i for i, atom in enumerate(self.atoms)}

    @cached_property
    def action_ids(self) -> dict[Atom, int]:
        return {action.signature: action.index for action in self.actions}

    @cached_property
    def action_predicates(self) -> tuple[str, ...]:
        """Action predicate names (the paper's Q), in first-grounded order."""
        return tuple(dict.fromkeys(a.predicate for a in self.actions))

    @cached_property
    def achievers(self) -> tuple[tuple[int, ...], ...]:
        """For each atom id, the indices of the actions that add it."""
        table: list[list[int]] = [[] for _ in self.atoms]
        for action in self.actions:
            for atom in action.add:
                table[atom].append(action.index)
        return tuple(tuple(ids) for ids in table)

    @cached_property
    def consumers(self) -> tuple[tuple[int, ...], ...]:
        """For each atom id, the indices of the actions whose precondition holds it."""
        table: list[list[int]] = [[] for _ in self.atoms]
        for action in self.actions:
            for atom in action.pre:
                table[atom].append(action.index)
        return tuple(tuple(ids) for ids in table)

    @cached_property
    def symbols(self) -> frozenset[str]:
        return frozenset(self.objects) | frozenset(self.constants)

    @cached_property
    def static_arities(self) -> dict[str, int]:
        """The arity of each static (compiled-away) predicate."""
        return {**self.static_predicates, **{fact.predicate: len(fact.args) for fact in self.static_facts}}

    @cached_property
    def categories(self) -> dict[str, tuple[str, ...]]:
        """Unary static predicates read as object categories: name -> sorted members."""
        table: dict[str, list[str]] = {}
        for fact in self.static_facts:
            if len(fact.args) == 1:
                table.setdefault(fact.predicate, []).append(fact.args[0])
        return {name: tuple(sorted(members)) for name, members in sorted(table.items())}

    @cached_property
    def negation_ids(self) -> dict[int, int]:
        """For each atom that has a negated twin (``~p``, see :mod:`hbtp.logic.negation`), the twin's id."""
        ids = self.atom_ids
        return {ids[atom.positive]: i for i, atom in enumerate(self.atoms) if atom.negated and atom.positive in ids}

    def complete(self, positives: Iterable[int]) -> State:
        """The state in which exactly ``positives`` of the positive atoms hold: each negated twin is
        added where its atom is absent (an observed or edited state, given by what is true)."""
        state = {i for i in positives if not self.atoms[i].negated}
        state.update(neg for pos, neg in self.negation_ids.items() if pos not in state)
        return frozenset(state)

    #: The lookups above that do not depend on s0 (kept by :meth:`from_state`).
    _STATE_FREE = (
        "atom_ids", "action_ids", "action_predicates", "achievers", "consumers", "symbols", "static_arities",
        "categories", "negation_ids", "_state_free_tables", "_spellings",
    )  # fmt: skip

    def from_state(self, state: Iterable[int]) -> GroundTask:
        """The same task starting in ``state`` (re-planning from an observed state), sharing the
        lookups that do not depend on s0; the per-task index starts empty (its tables may)."""
        task = dataclasses.replace(self, initial_state=frozenset(state))
        _ = self._state_free_tables  # made now (empty) so that what is built in it later is shared
        for name in self._STATE_FREE:
            if name in self.__dict__:
                task.__dict__[name] = self.__dict__[name]
        return task

    #: The lookups above that depend on the atoms alone (kept by :meth:`keeping`).
    _ATOMS_ONLY = ("atom_ids", "symbols", "static_arities", "categories", "negation_ids")

    def keeping(self, action_ids: Iterable[int]) -> GroundTask:
        """The same task with only the actions ``action_ids``, renumbered in task order (their names,
        conditions, effects and costs unchanged), the same atoms and s0: this task itself when every
        action is kept. It shares the lookups that depend on the atoms alone."""
        kept = self.restricted(action_ids)
        if len(kept) == len(self.actions):
            return self
        actions = tuple(dataclasses.replace(action, index=i) for i, action in enumerate(kept))
        task = dataclasses.replace(self, actions=actions)
        for name in self._ATOMS_ONLY:
            if name in self.__dict__:
                task.__dict__[name] = self.__dict__[name]
        return task

    # ------------------------------------------------------ the per-task tables
    @cached_property
    def _tables(self) -> Tables:
        return Tables()

    @cached_property
    def _state_free_tables(self) -> Tables:
        return Tables()

    def tables(self, state_free: bool = False) -> Tables:
        """The per-task tables kept with this task (:class:`hbtp.logic.tables.TaskTable`); the
        ``state_free`` ones are shared with the tasks :meth:`from_state` makes."""
        return self._state_free_tables if state_free else self._tables

    def __getstate__(self) -> dict[str, Any]:
        # Per-task tables are rebuilt where the task is unpickled (a worker process), not shipped.
        state = dict(self.__dict__)
        state.pop("_tables", None)
        state.pop("_state_free_tables", None)
        return state

    def atom(self, atom_id: int) -> Atom:
        return self.atoms[atom_id]

    # ------------------------------------------------- case-insensitive names
    @cached_property
    def _spellings(self) -> tuple[dict[str, str], dict[str, str], dict[str, str]]:
        """Lower case -> declared spelling, for predicates, objects and action predicates."""
        predicates = {p.lower(): p for p in (*self.static_arities, *self.predicates)}
        objects = {o.lower(): o for o in sorted(self.symbols)}
        actions = {q.lower(): q for q in self.action_predicates}
        return predicates, objects, actions

    def spelled(self, atom: Atom, action: bool = False) -> Atom:
        """``atom`` with its names in their declared spelling: as in PDDL, names are case-insensitive
        (``on(a,b)`` is ``ON(A,B)`` in a domain that declares ``ON``); unknown names stay as written."""
        predicates, objects, actions = self._spellings
        table = actions if action else predicates
        predicate = table.get(atom.predicate.lower(), atom.predicate)
        args = tuple(objects.get(arg.lower(), arg) for arg in atom.args)
        if predicate == atom.predicate and args == atom.args:
            return atom
        return Atom(predicate, args, atom.negated)

    def atom_id(self, atom: Atom | str) -> int:
        """The id of a literal known to the task; raises :class:`UnknownSymbolError` otherwise."""
        if isinstance(atom, str):
            atom = parse_atom(atom)
        atom = self.spelled(atom)
        try:
            return self.atom_ids[atom]
        except KeyError:
            self.check_literal(atom)
            raise UnknownSymbolError(f"literal {atom} never occurs in task {self.name!r}") from None

    def action(self, name: Atom | str) -> GroundAction:
        """The grounded action named ``Walk(apple)`` or ``Walk_apple`` (also where a name has
        underscores of its own: ``make_sandwich_s1_b1`` of PDDL's ``make_sandwich``)."""
        signature = self.spelled(parse_atom(name) if isinstance(name, str) else name, action=True)
        try:
            return self.actions[self.action_ids[signature]]
        except KeyError:
            index = (
                _UNDERSCORED_ACTIONS.of(self, lambda: _underscored_actions(self)).get(name)
                if isinstance(name, str)
                else None
            )
            if index is None:
                raise UnknownSymbolError(f"action {signature} is not a grounded action of {self.name!r}") from None
            return self.actions[index]

    def names(self, ids: Iterable[int]) -> list[str]:
        """Readable, sorted names of a set of atom ids."""
        return sorted(str(self.atoms[i]) for i in ids)

    # ---------------------------------------------------------------- goals
    def check_literal(self, atom: Atom) -> None:
        """Raise :class:`UnknownSymbolError` unless ``atom`` is well formed for this domain (see
        :func:`hbtp.logic.resolve.check_literal`)."""
        check_literal(self, atom)

    def resolve_goal(self, goal: str | Goal | GoalFormula | Iterable[Atom | str]) -> Goal:
        """``goal`` resolved against this task (see :func:`hbtp.logic.resolve.resolve_goal`)."""
        return resolve_goal(self, goal)

    def restricted(self, action_ids: Iterable[int]) -> tuple[GroundAction, ...]:
        """The actions with the given indices, in task order (an action space for the planner)."""
        return tuple(self.actions[i] for i in sorted(set(action_ids)))


#: Each action's index by its name in the datasets' spelling, which cannot be split into the
#: predicate and objects when they hold underscores themselves (read only for such a name).
_UNDERSCORED_ACTIONS: TaskTable[dict[str, int]] = TaskTable("the actions by their underscored names", state_free=True)


def _underscored_actions(task: GroundTask) -> dict[str, int]:
    return {action.signature.underscored: action.index for action in task.actions}


__all__ = [
    "Condition",
    "Goal",
    "GoalIds",
    "GroundAction",
    "GroundTask",
    "State",
    "did_you_mean",
    "disjuncts_of",
    "listing",
]
