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
from hbtp.logic.atoms import Atom, parse_atom
from hbtp.logic.goals import parse_goal

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

    def relevant_actions(self, goal: Goal) -> frozenset[int]:
        """The indices of the actions that can take part in reaching ``goal``: the achievers of its
        literals, then of their preconditions' literals, and so on (backward relevance, the
        operators Fast Downward's translator keeps as "necessary")."""
        return self.relevant_to(atom for disjunct in goal.disjuncts for atom in disjunct)

    def relevant_to(self, atoms: Iterable[int]) -> frozenset[int]:
        """The indices of the actions relevant to reaching ``atoms`` (see :meth:`relevant_actions`)."""
        seen: set[int] = set()
        found: set[int] = set()
        pending = list(atoms)
        achievers, actions = self.achievers, self.actions
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
        "categories", "negation_ids", "_state_free_derived",
    )  # fmt: skip

    def from_state(self, state: Iterable[int]) -> GroundTask:
        """The same task starting in ``state`` (re-planning from an observed state), sharing the
        lookups that do not depend on s0; the per-task index starts empty (its tables may)."""
        task = dataclasses.replace(self, initial_state=frozenset(state))
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

    # ------------------------------------------------------ the per-task index
    @cached_property
    def _derived(self) -> dict[Hashable, Any]:
        return {}

    @cached_property
    def _state_free_derived(self) -> dict[Hashable, Any]:
        return {}

    def derived(self, key: Hashable, build: Callable[[], _T], *, state_free: bool = False) -> _T:
        """What ``build()`` computes from this task, computed once and kept with the task.

        The one home of every per-task table the layers above need (the prompt vocabulary, the
        heuristics' analyses, the disturbance model…): it lives exactly as long as the task, unlike a
        module-level cache. ``key`` names the table, usually the building function itself, or a
        tuple of it and its arguments. A ``state_free`` table (one that does not depend on s0) is
        shared with the tasks :meth:`from_state` makes. Not thread-safe against two first builds of
        one key (both compute the same value; one is kept).
        """
        memo = self._state_free_derived if state_free else self._derived
        try:
            return cast(_T, memo[key])
        except KeyError:
            value = memo[key] = build()
            return value

    def forget_derived(self) -> None:
        """Drop every table :meth:`derived` keeps (they are rebuilt on demand)."""
        self._derived.clear()
        self._state_free_derived.clear()

    def __getstate__(self) -> dict[str, Any]:
        # Derived tables are rebuilt where the task is unpickled (a worker process), not shipped.
        state = dict(self.__dict__)
        state.pop("_derived", None)
        state.pop("_state_free_derived", None)
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
        atom = self.spelled(atom).positive
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
            hint = did_you_mean(unknown[0], self.symbols) or self._valid_objects(atom, atom.args.index(unknown[0]))
            raise UnknownSymbolError(f"unknown object {unknown[0]!r} in {atom}{hint}")

    def goal_terms(self, goal: str | Goal | Iterable[Atom | str]) -> tuple[tuple[Atom, ...], ...]:
        """The terms of a goal text (infix or PDDL, see :mod:`hbtp.logic.goals`), of a goal resolved
        against another task, or of one conjunction of literals; names in their declared spelling."""
        if isinstance(goal, Goal):
            raw = goal.terms
        elif isinstance(goal, str):
            raw = parse_goal(goal)
        else:
            raw = (tuple(parse_atom(a) if isinstance(a, str) else a for a in goal),)
        terms = tuple(tuple(dict.fromkeys(self.spelled(a) for a in term)) for term in raw)
        if not terms or not any(terms):
            raise InputError("empty goal")
        return terms

    def negations_needed(self, goal: str | Goal | Iterable[Atom | str]) -> frozenset[int]:
        """The atoms whose negated twin a goal needs and this task lacks (see :meth:`resolve_goal`)."""
        needed: set[int] = set()
        for term in self.goal_terms(goal):
            for atom in term:
                atom_id = self.atom_ids.get(atom.positive)
                if (
                    atom.negated
                    and atom_id is not None
                    and atom_id not in self.negation_ids
                    and self._negation_matters(atom_id)
                ):
                    needed.add(atom_id)
        return frozenset(needed)

    def _negation_matters(self, atom_id: int) -> bool:
        """Whether ``~atom`` can be false in some reachable state (s0 holds the atom, or an action adds it)."""
        return atom_id in self.initial_state or bool(self.achievers[atom_id])

    def _valid_objects(self, atom: Atom, position: int) -> str:
        """`` (IsIn takes at argument 2: a, b, c)``: the objects the task's literals of ``atom``'s
        predicate have at ``position`` (its category, in effect), or ''."""
        values = sorted(
            {a.args[position] for a in self.atoms if a.predicate == atom.predicate and len(a.args) > position}
        )
        if not values:
            return ""
        where = f" at argument {position + 1}" if len(atom.args) > 1 else ""
        return f" ({atom.predicate} takes{where}: {listing(values)})"

    def resolve_goal(self, goal: str | Goal | Iterable[Atom | str]) -> Goal:
        """Resolve a goal (``IsIn_milk_fridge & ~IsOpen(fridge) | IsOn_milk_table``, a PDDL goal, a
        goal of another task or a conjunction of literals) against this task.

        A negative literal ``~p`` needs ``p``'s negated twin in the task unless it always holds (no
        action adds ``p`` and s0 lacks it: it is dropped); :meth:`negations_needed` says which are
        missing, and :func:`hbtp.logic.negation.with_negations` adds them.
        """
        disjuncts: list[frozenset[int]] = []
        unreachable: list[Atom] = []
        contradictory: list[tuple[Atom, ...]] = []
        live: list[frozenset[int]] = []
        terms = self.goal_terms(goal)
        for term in terms:
            ids, missing = self._term_ids(term)
            if ids is None:
                contradictory.append(term)
                continue
            unreachable.extend(a for a in missing if a not in unreachable)
            if any(a.positive not in self.atom_ids for a in missing):
                continue  # a literal that is no atom of the task: the term can hold in no state
            disjuncts.append(ids)
            if not missing:
                live.append(ids)
        kept = tuple(
            d for i, d in enumerate(disjuncts) if not any(o < d or (o == d and j < i) for j, o in enumerate(disjuncts))
        )
        roots = tuple(d for d in kept if d in live)
        return Goal(terms, kept, tuple(unreachable), tuple(contradictory), roots)

    def _term_ids(self, term: tuple[Atom, ...]) -> tuple[frozenset[int] | None, list[Atom]]:
        """The atom ids of one conjunction, and its literals that can never hold (``None`` ids when
        it asks for a literal and its negation)."""
        ids: set[int] = set()
        missing: list[Atom] = []
        for atom in term:
            self.check_literal(atom)
            if atom.predicate not in self.predicates:  # static: true or false in every state
                if (atom.positive in self.static_facts) == atom.negated:
                    missing.append(atom)
                continue
            atom_id = self.atom_ids.get(atom.positive)
            if not atom.negated:
                if atom_id is None or (atom_id not in self.initial_state and not self.achievers[atom_id]):
                    missing.append(atom)
                if atom_id is not None:
                    ids.add(atom_id)
            elif atom_id is not None and self._negation_matters(atom_id):
                twin = self.negation_ids.get(atom_id)
                if twin is None:
                    raise InputError(
                        f"the goal literal {atom} needs the task with negated literals "
                        "(resolve the goal through its scenario, or hbtp.logic.negation.with_negations)"
                    )
                if twin not in self.initial_state and not self.achievers[twin]:
                    missing.append(atom)
                ids.add(twin)
        if any(self.negation_ids.get(i) in ids for i in ids):
            return None, missing
        return frozenset(ids), missing

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
