"""The grounded STRIPS task: interned atoms, grounded actions, the initial state.

Semantics (pyperplan's three lines): an action is applicable in ``s`` when ``pre <= s``;
progression is ``(s - delete) | add``; regression of a condition ``c`` through ``a`` is defined when
``c & delete`` is empty and gives ``pre | (c - add)`` (the backward search, :mod:`hbtp.planning.search`,
computes it inline, with its mutex check).

States and conditions are ``frozenset[int]`` of atom ids; :class:`Atom` names are kept at the edges.
"""

from __future__ import annotations

import dataclasses
import difflib
from collections.abc import Callable, Hashable, Iterable, Mapping, Sequence
from dataclasses import dataclass, field
from functools import cached_property
from typing import Any, TypeVar, cast

from hbtp.errors import InputError, UnknownSymbolError
from hbtp.logic.atoms import Atom, parse_atom, parse_conjunction

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


@dataclass(frozen=True)
class Goal:
    """A conjunctive goal, resolved against a task.

    ``atoms`` keeps the user's order. ``unreachable`` lists well-formed literals that no action adds
    and the initial state lacks: the goal is then unsolvable.
    """

    atoms: tuple[Atom, ...]
    ids: frozenset[int]
    unreachable: tuple[Atom, ...] = ()

    def __str__(self) -> str:
        return " & ".join(a.underscored for a in self.atoms)


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
    def symbols(self) -> frozenset[str]:
        return frozenset(self.objects) | frozenset(self.constants)

    @cached_property
    def static_arities(self) -> dict[str, int]:
        """The arity of each static (compiled-away) predicate."""
        return {fact.predicate: len(fact.args) for fact in self.static_facts}

    @cached_property
    def categories(self) -> dict[str, tuple[str, ...]]:
        """Unary static predicates read as object categories: name -> sorted members."""
        table: dict[str, list[str]] = {}
        for fact in self.static_facts:
            if len(fact.args) == 1:
                table.setdefault(fact.predicate, []).append(fact.args[0])
        return {name: tuple(sorted(members)) for name, members in sorted(table.items())}

    #: The lookups above that do not depend on s0 (kept by :meth:`from_state`).
    _STATE_FREE = (
        "atom_ids", "action_ids", "action_predicates", "achievers", "symbols", "static_arities", "categories"
    )  # fmt: skip

    def from_state(self, state: Iterable[int]) -> GroundTask:
        """The same task starting in ``state`` (re-planning from an observed state), sharing the
        lookups that do not depend on s0; the per-task index starts empty (its tables may)."""
        task = dataclasses.replace(self, initial_state=frozenset(state))
        for name in self._STATE_FREE:
            if name in self.__dict__:
                task.__dict__[name] = self.__dict__[name]
        return task

    # ------------------------------------------------------ the per-task index
    @cached_property
    def _derived(self) -> dict[Hashable, Any]:
        return {}

    def derived(self, key: Hashable, build: Callable[[], _T]) -> _T:
        """What ``build()`` computes from this task, computed once and kept with the task.

        The one home of every per-task table the layers above need (the prompt vocabulary, the
        heuristics' analyses, the disturbance model…): it lives exactly as long as the task, unlike a
        module-level cache. ``key`` names the table, usually the building function itself, or a
        tuple of it and its arguments. Not thread-safe against two first builds of one key (both
        compute the same value; one is kept).
        """
        memo = self._derived
        try:
            return cast(_T, memo[key])
        except KeyError:
            value = memo[key] = build()
            return value

    def forget_derived(self) -> None:
        """Drop every table :meth:`derived` keeps (they are rebuilt on demand)."""
        self._derived.clear()

    def __getstate__(self) -> dict[str, Any]:
        # Derived tables are rebuilt where the task is unpickled (a worker process), not shipped.
        state = dict(self.__dict__)
        state.pop("_derived", None)
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
        return Atom(predicate, args)

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
        """The grounded action named ``Walk(apple)`` or ``Walk_apple``."""
        signature = self.spelled(parse_atom(name) if isinstance(name, str) else name, action=True)
        try:
            return self.actions[self.action_ids[signature]]
        except KeyError:
            raise UnknownSymbolError(f"action {signature} is not a grounded action of {self.name!r}") from None

    def names(self, ids: Iterable[int]) -> list[str]:
        """Readable, sorted names of a set of atom ids."""
        return sorted(str(self.atoms[i]) for i in ids)

    # ------------------------------------------------------------- validation
    def check_literal(self, atom: Atom) -> None:
        """Raise :class:`UnknownSymbolError` unless ``atom`` is well formed for this domain (names are
        case-insensitive; see :meth:`spelled`)."""
        atom = self.spelled(atom)
        arity = self.predicates.get(atom.predicate)
        if arity is None:
            static_arity = self.static_arities.get(atom.predicate)
            if static_arity is None:
                hint = did_you_mean(atom.predicate, [*self.predicates, *self.static_arities])
                raise UnknownSymbolError(
                    f"unknown predicate {atom.predicate!r} in {atom}{hint} (task {self.name!r} has: "
                    f"{', '.join(sorted(self.predicates))})"
                )
            arity = static_arity
        if len(atom.args) != arity:
            raise UnknownSymbolError(f"{atom}: predicate {atom.predicate!r} takes {arity} argument(s)")
        unknown = [arg for arg in atom.args if arg not in self.symbols]
        if unknown:
            hint = did_you_mean(unknown[0], self.symbols)
            raise UnknownSymbolError(f"unknown object {unknown[0]!r} in {atom}{hint}")

    def resolve_goal(self, goal: str | Iterable[Atom | str]) -> Goal:
        """Resolve a goal text (``IsIn_milk_fridge & IsClose(fridge)``) or atoms against this task."""
        if isinstance(goal, str):
            atoms = tuple(self.spelled(a) for a in parse_conjunction(goal))
        else:
            atoms = tuple(self.spelled(parse_atom(a) if isinstance(a, str) else a) for a in goal)
            if not atoms:
                raise InputError("empty goal")
        ids: set[int] = set()
        unreachable: list[Atom] = []
        for atom in atoms:
            self.check_literal(atom)
            if atom.predicate not in self.predicates:
                raise InputError(f"{atom} is a static fact of the domain, not a goal literal")
            atom_id = self.atom_ids.get(atom)
            if atom_id is None:
                unreachable.append(atom)
            else:
                ids.add(atom_id)
        reachable_now = set(self.initial_state)
        for atom_id in ids:
            if atom_id not in reachable_now and not self.achievers[atom_id]:
                unreachable.append(self.atoms[atom_id])
        return Goal(atoms, frozenset(ids), tuple(unreachable))

    # ---------------------------------------------------------------- execute
    def execute(self, actions: Sequence[GroundAction], state: State | None = None) -> tuple[State, int]:
        """Apply ``actions`` in order from ``state`` (default: s0).

        Returns the final state and the number of actions applied before the first that is not
        applicable (``len(actions)`` when all are).
        """
        current = self.initial_state if state is None else state
        for done, action in enumerate(actions):
            if not action.applicable(current):
                return current, done
            current = action.progress(current)
        return current, len(actions)

    def restricted(self, action_ids: Iterable[int]) -> tuple[GroundAction, ...]:
        """The actions with the given indices, in task order (an action space for the planner)."""
        return tuple(self.actions[i] for i in sorted(set(action_ids)))


def did_you_mean(name: str, known: Iterable[str]) -> str:
    """`` (did you mean 'a' or 'b'?)`` with the closest of ``known`` names (case-insensitively), or ''."""
    spelling: dict[str, str] = {}
    for k in sorted(known):
        spelling.setdefault(k.lower(), k)
    close = difflib.get_close_matches(name.lower(), spelling, n=3)
    if not close:
        return ""
    return " (did you mean " + " or ".join(repr(spelling[c]) for c in close) + "?)"


def listing(names: Iterable[str], most: int = 10) -> str:
    """``a, b, c`` for a message: at most ``most`` names, then how many more there are."""
    shown = list(names)
    if len(shown) <= most:
        return ", ".join(shown)
    return ", ".join(shown[:most]) + f" and {len(shown) - most} more"
