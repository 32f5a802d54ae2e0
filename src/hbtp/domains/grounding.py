"""Compile a lifted PDDL domain and problem into a :class:`~hbtp.logic.GroundTask`.

Static predicates (no action changes them) are evaluated against the problem's initial facts and
disappear: guards such as ``(imply (hasplug ?y) (IsPlugged ?y))`` become plain STRIPS preconditions,
and ``(forall (?z) (when (not (= ?z ?x)) (not (IsNear self ?z))))`` becomes a list of delete effects.
A disjunction over fluents left in a precondition, or a ``when`` whose condition is over fluents,
gives a binding several ground actions (:mod:`hbtp.domains.alternatives`).

Bindings are enumerated by joining the static facts that an action's precondition requires (each
disjunct of its static part in turn), so an action over 126 objects never tries all pairs blindly.
Each join step looks its facts up in an index keyed by the arguments already bound; a ``forall``
effect's guard is joined once per distinct value of the outer variables it mentions.

With ``reachable_only``, only the actions reachable from s0 under the delete relaxation are kept
(:func:`~hbtp.domains.reachability.reachable_actions`), with the atoms s0 or they mention. With
``only``, only the ground actions it accepts are built (their effects computed), with the atoms s0
or they mention; :func:`action_bindings` lists the ground actions and their costs without effects.

Before enumerating, the number of ground actions of each schema is bounded from above (the join's
size: per static atom, at most its number of facts; per remaining parameter, the objects of its
type). When the bound exceeds ``max_ground_actions`` (by default ``$HBTP_MAX_GROUND_ACTIONS``, else
:data:`MAX_GROUND_ACTIONS`; a ground action takes about 1-2 KB of memory), only the actions reachable
from s0 are grounded (:meth:`_Grounder.reach`: the positive fluent atoms of each precondition are
joined with the fluent facts reached so far, round after round, as Fast Downward's translator
instantiates), and a task that still has more is refused with a one-line
:class:`~hbtp.errors.GroundingError` (with ``only``, the limit applies to the actions kept instead);
a ``deadline`` stops grounding with :class:`~hbtp.deadline.TimeLimitReached`.
"""

from __future__ import annotations

import dataclasses
import itertools
import logging
import math
import os
from collections.abc import Callable, Container, Iterable, Iterator, Mapping, Sequence
from dataclasses import dataclass

from hbtp.deadline import Deadline, TimeLimitReached
from hbtp.domains.alternatives import (
    Choice,
    Effects,
    TooManyAlternatives,
    Value,
    add_case,
    alternatives,
    conjoined,
    disjoined,
    variants,
)
from hbtp.domains.lifted import (
    MAX_ACTION_COST,
    OBJECT_TYPE,
    ActionSchema,
    AddEffect,
    And,
    AndEffect,
    AtomFormula,
    CostEffect,
    DeleteEffect,
    Domain,
    Effect,
    Equals,
    Exists,
    Forall,
    ForallEffect,
    Formula,
    Imply,
    Not,
    Or,
    Problem,
    TypedName,
    WhenEffect,
    changed_predicates,
    is_variable,
)
from hbtp.domains.quantifiers import expand_domain
from hbtp.domains.reachability import reachable_actions
from hbtp.errors import GroundingError, InputError
from hbtp.logic.atoms import NEGATION, Atom, alternative_name
from hbtp.logic.negation import with_twin_effects
from hbtp.logic.task import GroundAction, GroundTask, listing

log = logging.getLogger(__name__)

Binding = dict[str, str]
#: Which ground actions to build: called with the schema's name and the argument tuple.
ActionFilter = Callable[[str, tuple[str, ...]], bool]


@dataclass(frozen=True)
class Selection:
    """The ground actions of some schemas whose every argument is one of some objects: the pruned
    space (Q⁻ × O⁻) ∩ A as an :data:`ActionFilter` that the grounder also uses to skip the other
    schemas and to join only over the objects (so a small part of a large world grounds quickly)."""

    predicates: frozenset[str]
    objects: frozenset[str]

    def __call__(self, schema: str, args: tuple[str, ...]) -> bool:
        return schema in self.predicates and all(a in self.objects for a in args)


#: Per action schema, the argument tuples of its ground actions with their costs (see :func:`action_bindings`).
ActionBindings = dict[str, tuple[tuple[tuple[str, ...], int], ...]]

#: The default bound on the number of ground actions (see the module docstring).
MAX_GROUND_ACTIONS = 1_000_000
#: The most disjuncts a static precondition or ``when`` guard may have once put in disjunctive normal form.
MAX_DNF_TERMS = 10_000
#: With the fallback to relaxed reachability, the units of join work allowed per allowed action.
REACH_WORK = 100
#: ... counted for no fewer allowed actions than this.
REACH_FLOOR = 100_000
_PHASE = "grounding"
LIMIT_VARIABLE = "HBTP_MAX_GROUND_ACTIONS"
_TICKS = 4096  # units of work between two deadline checks

# Inside the grounder an atom is the plain tuple (predicate, arguments): it hashes and sorts as Atom
# does, much faster; Atoms are made once per distinct atom when the task is assembled.
_Key = tuple[str, tuple[str, ...]]
#: The mark of a negative fluent precondition's key: ``("~on", args)`` asks for ``(on ...)`` to be false.
NEGATED = NEGATION
_Template = tuple[tuple[bool, str], ...]  # (is a variable, name) per argument
_Check = Callable[[Binding], bool]
_Fluent = Callable[[Binding], Value]
_Op = Callable[[Binding, Effects], None]
#: A binding of an action as built: its arguments and its variants, each with its precondition's
#: alternatives (one unless the precondition has a disjunction over fluents), add, delete and cost.
_Built = tuple[tuple[str, ...], list[tuple[tuple[tuple[_Key, ...], ...], set[_Key], set[_Key], int]]]
_Grounded = tuple[Atom, frozenset[_Key], frozenset[_Key], frozenset[_Key], int]
_Segment = tuple[list[tuple[str, ...]], tuple[_Check, ...]]  # a forall's values, with their checks


def ground_actions_limit() -> int:
    """The default bound on ground actions: ``$HBTP_MAX_GROUND_ACTIONS`` when set, else :data:`MAX_GROUND_ACTIONS`."""
    text = os.environ.get(LIMIT_VARIABLE, "").strip()
    if not text:
        return MAX_GROUND_ACTIONS
    if not text.isascii() or not text.isdigit() or int(text) < 1:
        raise InputError(f"{LIMIT_VARIABLE} must be a whole number of at least 1, not {text!r}")
    return int(text)


@dataclass(frozen=True, slots=True)
class _Literal:
    """A static literal in a DNF term: an atom or an equality, possibly negated."""

    formula: AtomFormula | Equals
    positive: bool


def ground(
    domain: Domain,
    problem: Problem,
    *,
    keep_fluent: Iterable[str] = (),
    object_categories: Iterable[str] = (),
    name: str | None = None,
    max_ground_actions: int | None = None,
    deadline: Deadline | None = None,
    reachable_only: bool = False,
    only: ActionFilter | None = None,
) -> GroundTask:
    """Ground ``problem`` of ``domain``.

    ``keep_fluent`` names predicates that no action changes but that must stay part of the state
    (for example ``IsStanding``: a disturbance can make it false, so trees must test it).
    ``object_categories`` names the static categories whose members form the task's object set O
    (the objects an LLM reasons about); by default O is the problem's ``:objects``.
    A task whose estimated number of ground actions exceeds ``max_ground_actions`` (default:
    :func:`ground_actions_limit`) is refused (:class:`~hbtp.errors.GroundingError`); past ``deadline``,
    :class:`~hbtp.deadline.TimeLimitReached`. With ``reachable_only``, the actions that cannot be
    applied from s0 even when deletes are ignored are left out, with the atoms only they mention.
    With ``only``, only the ground actions whose schema name and arguments it accepts are built
    (exactly as in the full task, re-indexed), with the atoms s0 or they mention; the limit then
    applies to the number of actions kept, not to the estimate of all of them. A :class:`Selection`
    is also used to skip the schemas and objects it leaves out before joining.
    """
    if max_ground_actions is None:
        max_ground_actions = ground_actions_limit()
    if max_ground_actions < 1:
        raise InputError(f"max_ground_actions must be at least 1, not {max_ground_actions}")
    grounder = _Grounder(domain, problem, frozenset(keep_fluent), deadline, reachable_only)
    refusal = grounder.check_size(max_ground_actions) if only is None else None
    if only is not None:
        grounder.select(only, max_ground_actions)
    stopped = ""
    try:
        if refusal is not None:
            grounder.reach(max_ground_actions, refusal)
        task = grounder.run(name or problem.name)
    except TimeLimitReached as stop:
        stopped = str(stop)
    if stopped:
        # Raised afresh, outside the handler: the first exception's traceback would keep the partial
        # grounding (hundreds of thousands of objects) alive while the caller reports the timeout.
        raise TimeLimitReached(stopped)
    categories = tuple(object_categories)
    if not categories:
        return task
    objects, constants = objects_of_categories(task.objects, task.constants, task.categories, categories)
    return dataclasses.replace(task, objects=objects, constants=constants)


def objects_of_categories(
    objects: Sequence[str], constants: Sequence[str], members: Mapping[str, Sequence[str]], chosen: Sequence[str]
) -> tuple[tuple[str, ...], tuple[str, ...]]:
    """O = the members of the ``chosen`` static categories (``members``: category -> objects); every
    other object or constant becomes a constant. Both sorted."""
    unknown = [c for c in chosen if c not in members]
    if unknown:
        raise InputError(f"object category {unknown[0]!r} is not a unary static predicate with members")
    kept = tuple(sorted({o for c in chosen for o in members[c]}))
    everything = dict.fromkeys((*constants, *objects))
    return kept, tuple(sorted(s for s in everything if s not in set(kept)))


def fluent_predicates(domain: Domain, keep_fluent: frozenset[str]) -> set[str]:
    """The predicates some action changes, with ``keep_fluent`` (checked to be predicates of ``domain``)."""
    unknown = sorted(keep_fluent - set(domain.predicates))
    if unknown:
        raise InputError(f"keep_fluent names unknown predicate(s): {', '.join(unknown)}")
    return changed_predicates(domain.actions) | keep_fluent


def objects_by_type(domain: Domain, objects: Iterable[TypedName]) -> dict[str, tuple[str, ...]]:
    """The names of ``objects`` of each type, subtypes included (every object is an ``object``)."""
    parents = domain.types
    table: dict[str, list[str]] = {OBJECT_TYPE: []}
    for obj in objects:
        for declared in obj.types:
            current: str | None = declared
            seen: set[str] = set()
            while current is not None and current not in seen:
                seen.add(current)
                table.setdefault(current, []).append(obj.name)
                current = parents.get(current, OBJECT_TYPE if current != OBJECT_TYPE else None)
    return {t: tuple(dict.fromkeys(names)) for t, names in table.items()}


def typed_objects(by_type: Mapping[str, tuple[str, ...]], typed: TypedName) -> tuple[str, ...]:
    """The objects a parameter or variable of ``typed``'s type(s) ranges over (``by_type`` as
    :func:`objects_by_type` gives it)."""
    if len(typed.types) == 1:
        return by_type.get(typed.types[0], ())
    return tuple(dict.fromkeys(o for t in typed.types for o in by_type.get(t, ())))


def action_bindings(
    domain: Domain,
    problem: Problem,
    *,
    keep_fluent: Iterable[str] = (),
    deadline: Deadline | None = None,
) -> ActionBindings:
    """Per action schema (in the domain's order), the sorted ``(arguments, cost)`` of its ground actions.

    These are exactly the actions :func:`ground` (without ``reachable_only``) builds: the static
    precondition holds, the fluent one is not false once statics are evaluated, the cost is defined.
    Add and delete effects are not computed, so this is much cheaper than grounding; no size limit
    applies. Past ``deadline``, :class:`~hbtp.deadline.TimeLimitReached`.
    """
    grounder = _Grounder(domain, problem, frozenset(keep_fluent), deadline)
    found: ActionBindings = {}
    stopped = ""
    try:
        for schema in domain.actions:
            grounder.check_deadline()
            built = grounder.build(schema, costs_only=True)
            found[schema.name] = tuple(sorted((key, variants[0][3]) for key, variants in built if variants))
    except TimeLimitReached as stop:
        stopped = str(stop)
    if stopped:
        raise TimeLimitReached(stopped)
    return found


@dataclass(frozen=True, slots=True)
class _Step:
    """One positive static atom of a join: its facts looked up by the arguments already bound.

    ``positions`` (the index's key) are the bound arguments, ``lookup`` reads their values from a
    binding; ``new`` binds each unbound variable from its first position, ``same`` checks a variable's
    later positions; ``checks`` are the literals and types first decided once this step has bound.
    """

    predicate: str
    positions: tuple[int, ...]
    lookup: Callable[[Binding], tuple[str, ...]]
    new: tuple[tuple[str, int], ...]
    same: tuple[tuple[int, int], ...]
    checks: tuple[_Check, ...]


@dataclass(frozen=True, slots=True)
class _Plan:
    """How one DNF term is joined: equalities bind, ``checks`` filter, the steps extend, then the
    parameters still ``unbound`` range over their ``domains`` and ``last_checks`` filter."""

    equalities: tuple[Equals, ...]
    checks: tuple[_Check, ...]
    steps: tuple[_Step, ...]
    unbound: tuple[str, ...]
    domains: tuple[tuple[str, ...], ...]
    last_checks: tuple[_Check, ...]


@dataclass(frozen=True, slots=True)
class _Schema:
    """An action schema compiled for grounding: its static precondition in DNF, its fluent
    precondition parts, and its effects (all of them, or only what adds to the cost)."""

    names: tuple[str, ...]
    static: list[list[_Literal]]
    fluent: tuple[_Fluent, ...]
    ops: tuple[_Op, ...]
    cost_ops: tuple[_Op, ...]


class _Grounder:
    def __init__(
        self,
        domain: Domain,
        problem: Problem,
        keep_fluent: frozenset[str],
        deadline: Deadline | None = None,
        reachable_only: bool = False,
    ) -> None:
        self.reachable_only = reachable_only
        # With reach(): the fluent facts reached from s0 by predicate, joined like static facts.
        self.reached: dict[str, list[tuple[str, ...]]] | None = None
        self.work_left = 0
        self.estimate_text = ""
        self.problem = problem
        self.deadline = deadline
        self.ticks = 0
        self.only: ActionFilter | None = None
        self.kept = 0
        self.kept_limit = 0
        self.uses_costs = domain.uses_action_costs
        self.fluent = fluent_predicates(domain, keep_fluent)
        self.objects: tuple[TypedName, ...] = (*domain.constants, *problem.objects)
        self.by_type = objects_by_type(domain, self.objects)
        self.domain = expand_domain(domain, self.domain_of)  # exists/forall become or/and over the objects
        self.static_facts: set[_Key] = set()
        self.static_index: dict[str, list[tuple[str, ...]]] = {}
        self.indexes: dict[tuple[str, tuple[int, ...]], dict[tuple[str, ...], list[tuple[str, ...]]]] = {}
        self.plans: dict[
            tuple[int, tuple[TypedName, ...], frozenset[str], frozenset[str] | None], tuple[list[_Literal], _Plan]
        ] = {}
        self.initial: set[_Key] = set()
        self.interned: dict[_Key, _Key] = {}  # one tuple per distinct atom: less memory, quicker lookups
        for fact in problem.init:
            if fact.predicate in self.fluent:
                self.initial.add((fact.predicate, fact.terms))
            elif (fact.predicate, fact.terms) not in self.static_facts:
                self.static_facts.add((fact.predicate, fact.terms))
                self.static_index.setdefault(fact.predicate, []).append(fact.terms)

    # ----------------------------------------------------------------- types
    def domain_of(self, typed: TypedName) -> tuple[str, ...]:
        return typed_objects(self.by_type, typed)

    def tick(self, count: int = 1) -> None:
        """Count ``count`` units of work; every :data:`_TICKS` units, check the deadline."""
        self.ticks += count
        if self.ticks >= _TICKS:
            self.ticks = 0
            self.check_deadline()
            if self.reached is not None:
                self.work_left -= _TICKS
                if self.work_left < 0:
                    raise GroundingError(
                        f"grounding would create {self.estimate_text}; grounding only what is reachable "
                        f"from s0 took more than {REACH_WORK} units of work per allowed action"
                    )

    def check_deadline(self) -> None:
        if self.deadline is not None:
            self.deadline.check(_PHASE)

    # ------------------------------------------------------------------ size
    def estimate(self, schema: ActionSchema) -> int:
        """An upper bound of the number of ground actions of ``schema`` (see the module docstring)."""
        static_parts, _ = self._split_precondition(schema.precondition)
        params = schema.parameters
        everything = math.prod(len(self.domain_of(p)) for p in params)
        terms = _dnf_checked(And(tuple(static_parts)), schema)
        total = 0
        for term in terms:
            total += self._estimate_term(term, params)
            if total >= everything:
                return everything
        return total

    def _estimate_term(self, term: list[_Literal], params: tuple[TypedName, ...]) -> int:
        candidates = {p.name: len(self.domain_of(p)) for p in params}
        for lit in term:
            formula = lit.formula
            if lit.positive and isinstance(formula, Equals):
                for variable, other in ((formula.left, formula.right), (formula.right, formula.left)):
                    if is_variable(variable) and not is_variable(other) and variable in candidates:
                        candidates[variable] = min(candidates[variable], 1)
        positives = [lit.formula for lit in term if lit.positive and isinstance(lit.formula, AtomFormula)]
        positives.sort(key=lambda atom: len(self.static_index.get(atom.predicate, ())))
        bound: set[str] = set()
        size = 1
        for atom in positives:
            new = [t for t in dict.fromkeys(atom.terms) if is_variable(t) and t not in bound]
            facts = len(self.static_index.get(atom.predicate, ()))
            if not facts:
                return 0
            if new:
                size *= min(facts, math.prod(candidates.get(v, facts) for v in new))
                bound.update(new)
        for name, count in candidates.items():
            if name not in bound:
                size *= count
        return size

    def check_size(self, limit: int) -> str | None:
        """Why the estimated number of ground actions exceeds ``limit`` (``None`` when it does not)."""
        estimates = [(self.estimate(schema), -index) for index, schema in enumerate(self.domain.actions)]
        total = sum(estimate for estimate, _ in estimates)
        if total <= limit:
            return None
        largest, index = max(estimates)
        schema = self.domain.actions[-index]
        counts = " x ".join(str(len(self.domain_of(p))) for p in schema.parameters) or "1"
        variables = " ".join(p.name for p in schema.parameters)
        return (
            f"up to {total:,} actions, more than the limit of {limit:,} "
            f"(max_ground_actions, or {LIMIT_VARIABLE} for the command line): {schema.name}({variables}) "
            f"alone may have {largest:,} ({counts} candidate objects)"
        )

    def reach(self, limit: int, estimate: str) -> None:
        """Ground only what relaxed reachability from s0 allows, as Fast Downward's translator does:
        the positive fluent atoms of a precondition are joined with the facts reached so far, and
        their actions' adds are reached in turn, until nothing new is. Then :meth:`run` builds the
        actions so joined, at most ``limit`` of them, within :data:`REACH_WORK` units of join work per
        allowed action (at least :data:`REACH_FLOOR` allowed; ``estimate``, the static bound that was
        too large, is named in the error)."""
        log.info("static facts allow %s; grounding only the actions reachable from s0", estimate)
        self.reached = {}
        self.work_left = REACH_WORK * max(limit, REACH_FLOOR)
        self.estimate_text = estimate
        self.kept_limit = limit
        for key in sorted(self.initial):
            self.reached.setdefault(key[0], []).append(key[1])
        known = set(self.initial)
        # A schema's bindings change only when a predicate it joins gained facts in the last round.
        joined = {schema.name: self._joined_predicates(schema) for schema in self.domain.actions}
        # A binding joined in an earlier round added its atoms then: its effects are not built again.
        taken: dict[str, set[tuple[str, ...]]] = {schema.name: set() for schema in self.domain.actions}
        changed: set[str] | None = None  # None in the first round: every schema is joined
        rounds = 0
        self.kept = 0
        while True:
            rounds += 1
            new: set[_Key] = set()
            for schema in self.domain.actions:
                if changed is None or joined[schema.name] & changed:
                    self._reach_schema(schema, known, new, taken[schema.name])
            if not new:
                break
            for key in sorted(new):
                known.add(key)
                self.reached.setdefault(key[0], []).append(key[1])
            changed = {key[0] for key in new}
            self.indexes = {k: v for k, v in self.indexes.items() if k[0] not in changed}
        self.kept = 0
        log.debug(
            "relaxed reachability: %d fluent atoms in %d rounds, %d units of work left",
            len(known),
            rounds,
            self.work_left,
        )

    def _joined_predicates(self, schema: ActionSchema) -> set[str]:
        """The fluent predicates whose facts a reaching join of ``schema`` ranges over."""
        _, fluent_parts = self._split_precondition(schema.precondition)
        return {part.predicate for part in _reaching_atoms(fluent_parts)}

    def _reach_schema(
        self, schema: ActionSchema, known: set[_Key], new: set[_Key], taken: set[tuple[str, ...]]
    ) -> None:
        """Add to ``new`` what the ground actions of ``schema`` joined so far, but not ``taken`` in an
        earlier round, add beyond ``known``, counting them against the limit (those that change
        nothing are not counted); they join ``taken``."""
        for key, found in self.build(schema, costs_only=False, warn=False, skip=taken):
            taken.add(key)
            changes = False
            for options, add, delete, _cost in found:
                changes = changes or any(any(_changes(frozenset(pre), add, delete)) for pre in options)
                new.update(atom for atom in add if atom not in known)
            if changes:
                self._count_kept(schema, key)

    def select(self, only: ActionFilter, limit: int) -> None:
        """Build only the ground actions ``only`` accepts, refusing more than ``limit`` of them."""
        self.only = only
        self.kept_limit = limit

    def _count_kept(self, schema: ActionSchema, key: tuple[str, ...]) -> None:
        self.kept += 1
        if self.kept > self.kept_limit:
            which = "selected actions" if self.reached is None else "actions reachable from s0"
            raise GroundingError(
                f"grounding the {which} would create more than the limit of {self.kept_limit:,} "
                f"(max_ground_actions, or {LIMIT_VARIABLE} for the command line): "
                f"{Atom(schema.name, key)} is action {self.kept:,}"
            )

    # ------------------------------------------------------------------- run
    def run(self, task_name: str) -> GroundTask:
        grounded: list[_Grounded] = []
        for schema in self.domain.actions:
            self.check_deadline()
            grounded.extend(self._ground_schema(schema))
        self.check_deadline()
        grounded.sort(key=lambda g: str(g[0]))
        if self.reachable_only:
            found = len(grounded)
            # relaxed: a negative precondition is taken as reachable (deleting is never needed)
            relaxed = [
                (frozenset(k for k in pre if not k[0].startswith(NEGATED)), add) for _, pre, add, _, _ in grounded
            ]
            kept = reachable_actions(self.initial, relaxed, self._tick_atom)
            grounded = [grounded[index] for index in kept]
            log.debug("%s: %d of %d ground actions are unreachable from s0", task_name, found - len(grounded), found)
        return self._assemble(task_name, grounded)

    def _tick_atom(self) -> None:
        """A unit of the reachability fixpoint: a reached atom, which may wake many actions."""
        self.tick(64)

    def _assemble(self, task_name: str, grounded: list[_Grounded]) -> GroundTask:
        """The task of the ``grounded`` actions: their atoms and s0's, sorted, and the actions over
        them; a negative precondition ``(not (p ...))`` becomes the twin ``~p`` of
        :mod:`hbtp.logic.negation`, appended after the atoms and kept exact by the actions."""
        self.check_deadline()
        all_atoms: set[_Key] = set(self.initial)
        negated: set[_Key] = set()
        for _, pre, add, delete, _ in grounded:
            for key in pre:
                if key[0].startswith(NEGATED):
                    negated.add((key[0][len(NEGATED) :], key[1]))
                else:
                    all_atoms.add(key)
            all_atoms.update(add, delete)
        all_atoms |= negated
        keys = sorted(all_atoms)  # the order of Atom (predicate, then arguments)
        ids = {key: i for i, key in enumerate(keys)}
        twins = {(NEGATED + p, args): len(keys) + n for n, (p, args) in enumerate(sorted(negated))}
        twin_of = {ids[(p[len(NEGATED) :], args)]: twin for (p, args), twin in twins.items()}
        get = {**ids, **twins}.__getitem__
        actions: list[GroundAction] = []
        for index, (signature, pre, add, delete, cost) in enumerate(grounded):
            self.tick()
            action = GroundAction(
                index, signature, frozenset(map(get, pre)), frozenset(map(ids.__getitem__, add)),
                frozenset(map(ids.__getitem__, delete)), cost,
            )  # fmt: skip
            actions.append(with_twin_effects(action, twin_of) if twin_of else action)
        log.debug("grounded %s: %d actions, %d atoms", task_name, len(actions), len(keys) + len(twins))
        initial = {ids[a] for a in self.initial}
        initial |= {twin for atom, twin in twin_of.items() if atom not in initial}
        return GroundTask(
            name=task_name,
            atoms=(
                *(Atom(predicate, args) for predicate, args in keys),
                *(Atom(p, args, True) for p, args in sorted(negated)),
            ),
            actions=tuple(actions),
            initial_state=frozenset(initial),
            objects=tuple(o.name for o in self.problem.objects),
            constants=tuple(c.name for c in self.domain.constants),
            predicates={p: len(args) for p, args in self.domain.predicates.items() if p in self.fluent},
            static_facts=frozenset(Atom(p, args) for p, args in self.static_facts),
            static_predicates={p: len(args) for p, args in self.domain.predicates.items() if p not in self.fluent},
        )

    def _ground_schema(self, schema: ActionSchema) -> Iterator[_Grounded]:
        if isinstance(self.only, Selection) and schema.name not in self.only.predicates:
            return
        counting = self.only is not None or self.reached is not None
        names = self._alternative_names(schema)
        for key, found in self.build(schema, costs_only=False):
            number = 0
            for options, add, delete, cost in found:
                for pre in options:
                    needs = frozenset(pre)
                    adds, deletes = _changes(needs, add, delete)
                    if not adds and not deletes:
                        continue  # an action that changes nothing (Fast Downward drops it too)
                    if counting:
                        self._count_kept(schema, key)
                    name = names[number] if number < len(names) else alternative_name(schema.name, number)
                    number += 1
                    yield Atom(name, key), needs, adds, deletes, cost

    def _alternative_names(self, schema: ActionSchema) -> tuple[str, ...]:
        """The names of the schema's first ground actions per binding, checked against the declared
        action names (an alternative's name must not be one of them)."""
        declared = {a.name.lower() for a in self.domain.actions}
        names = tuple(alternative_name(schema.name, n) for n in range(8))
        for name in names[1:]:
            if name.lower() in declared:
                raise GroundingError(
                    f"action {schema.name!r}: its disjunctive precondition's alternatives are named "
                    f"{names[1]}, {names[2]}, ..., and the domain declares an action {name!r}"
                )
        return names

    def build(
        self, schema: ActionSchema, costs_only: bool, warn: bool = True, skip: Container[tuple[str, ...]] = ()
    ) -> Iterator[_Built]:
        """The ground actions of ``schema``, per binding: its arguments and its variants
        (:func:`~hbtp.domains.alternatives.variants`), each with its precondition's alternatives, add,
        delete and cost; those whose cost is undefined are left out with a warning. With
        ``costs_only``, effects are not computed and each binding has one variant, whose cost is the
        action's when no conditional effect over fluents fires. Bindings in ``skip`` are passed over."""
        try:
            yield from self._build(schema, costs_only, warn, skip)
        except TooManyAlternatives as error:
            source = self.domain.source
            where = f"{source}:{schema.line}:{schema.column}" if schema.column else f"{source}:{schema.line}"
            raise GroundingError(f"{where}: {error}" if source and schema.line else str(error)) from None

    def _build(
        self, schema: ActionSchema, costs_only: bool, warn: bool, skip: Container[tuple[str, ...]]
    ) -> Iterator[_Built]:
        compiled = self._compile(schema)
        ops = compiled.cost_ops if costs_only else compiled.ops
        dropped: list[str] = []
        for key, binding, pre in self._candidates(schema, compiled, skip):
            effects = Effects()
            try:
                for op in ops:
                    op(binding, effects)
            except _UndefinedCost as undefined:
                dropped.append(undefined.args[0])
                continue
            found = [(pre, effects)] if costs_only or not effects.cases else variants(pre, effects, schema.name)
            yield (
                key,
                [(alternatives(v), done.add, done.delete, self._cost(schema, key, done.costs)) for v, done in found],
            )
        if dropped and warn:
            # Fast Downward's translator only instantiates reachable actions, and fails on one whose cost
            # is undefined; hbtp grounds from static facts alone, so it drops them (elevators' slow lifts).
            log.warning(
                "action %r (line %d): %d ground action(s) dropped, their cost is not defined in :init (%s)",
                schema.name,
                schema.line,
                len(dropped),
                listing(dropped, 3),
            )

    def _cost(self, schema: ActionSchema, key: tuple[str, ...], costs: list[int]) -> int:
        cost = sum(costs) if self.uses_costs else 1
        if cost > MAX_ACTION_COST:
            raise GroundingError(
                f"action {Atom(schema.name, key)} costs {cost}, more than the maximum {MAX_ACTION_COST}"
            )
        return cost

    def _candidates(
        self, schema: ActionSchema, compiled: _Schema, skip: Container[tuple[str, ...]]
    ) -> Iterator[tuple[tuple[str, ...], Binding, list[_Key] | Choice]]:
        """Each binding (once) not in ``skip`` whose static precondition holds, that ``only`` accepts
        and whose fluent precondition is not false, with the fluent literals it requires (a choice of
        alternatives when a disjunction over fluents remains)."""
        names, fluent, only = compiled.names, compiled.fluent, self.only
        allowed = only.objects if isinstance(only, Selection) else None
        seen: set[tuple[str, ...]] = set()
        for binding in self._bindings(compiled.static, schema.parameters, {}, allowed):
            self.tick()
            key = tuple([binding[name] for name in names])
            if key in seen or key in skip:
                continue
            seen.add(key)
            if only is not None and not only(schema.name, key):
                continue
            pre: list[_Key] = []
            choices: list[Choice] = []
            for part in fluent:
                value = part(binding)
                if isinstance(value, Choice):
                    choices.append(value)
                elif isinstance(value, list):
                    pre.extend(value)
                elif not value:
                    break
            else:
                if not choices:
                    yield key, binding, pre
                    continue
                combined = conjoined([pre, *choices], schema.name)
                if not isinstance(combined, bool):
                    yield key, binding, combined

    # ----------------------------------------------------- static / fluent
    def _is_static(self, formula: Formula) -> bool:
        if isinstance(formula, AtomFormula):
            return formula.predicate not in self.fluent
        if isinstance(formula, Equals):
            return True
        if isinstance(formula, Not):
            return self._is_static(formula.operand)
        if isinstance(formula, And | Or):
            return all(self._is_static(p) for p in formula.parts)
        if isinstance(formula, Exists | Forall):
            return False  # expand_domain removes them; never joined as static
        return self._is_static(formula.antecedent) and self._is_static(formula.consequent)

    def _split_precondition(self, formula: Formula) -> tuple[list[Formula], list[Formula]]:
        conjuncts = _flatten_and(formula)
        static = [c for c in conjuncts if self._is_static(c)]
        fluent = [c for c in conjuncts if not self._is_static(c)]
        return static, fluent

    # --------------------------------------------------------------- compile
    def _compile(self, schema: ActionSchema) -> _Schema:
        static_parts, fluent_parts = self._split_precondition(schema.precondition)
        names = tuple(p.name for p in schema.parameters)
        outer = frozenset(names)
        static = _dnf_checked(And(tuple(static_parts)), schema)
        if self.reached is not None:  # join the positive fluent atoms with the facts reached
            joined = [_Literal(part, True) for part in _reaching_atoms(fluent_parts)]
            static = [[*term, *joined] for term in static]
        return _Schema(
            names=names,
            static=static,
            fluent=tuple(self._compile_fluent(part, schema) for part in fluent_parts),
            ops=tuple(self._compile_effect(schema.effect, schema, outer, False)),
            cost_ops=tuple(self._compile_effect(schema.effect, schema, outer, True)),
        )

    def _compile_fluent(self, formula: Formula, schema: ActionSchema) -> _Fluent:
        """:meth:`_simplify` of ``formula``, made quicker for a fluent atom or an ``imply`` over statics."""
        if isinstance(formula, AtomFormula) and formula.predicate in self.fluent:
            predicate, args, intern = formula.predicate, _getter(formula.terms), self.interned.setdefault
            return lambda binding: [intern(key := (predicate, args(binding)), key)]
        operand = formula.operand if isinstance(formula, Not) else None
        if isinstance(operand, AtomFormula) and operand.predicate in self.fluent:
            negated, args = NEGATED + operand.predicate, _getter(operand.terms)
            return lambda binding: [(negated, args(binding))]
        if isinstance(formula, Imply) and self._is_static(formula.antecedent):
            test = self._static_test(formula.antecedent)
            rest = self._compile_fluent(formula.consequent, schema)
            return lambda binding: rest(binding) if test(binding) else True
        return lambda binding: self._simplify(formula, binding, schema)

    def _static_test(self, formula: Formula) -> _Check:
        """Whether the static ``formula`` holds under a binding (what :meth:`_simplify` computes for it)."""
        if isinstance(formula, AtomFormula):
            return _fact_check(formula.predicate, formula.terms, self.static_facts, True)
        if isinstance(formula, Equals):
            return _equality_check(formula.left, formula.right, True)
        if isinstance(formula, Not):
            inner = self._static_test(formula.operand)
            return lambda binding: not inner(binding)
        if isinstance(formula, And | Or):
            parts = [self._static_test(part) for part in formula.parts]
            if isinstance(formula, And):
                return lambda binding: all(part(binding) for part in parts)
            return lambda binding: any(part(binding) for part in parts)
        assert isinstance(formula, Imply), "quantifiers are expanded first"
        antecedent, consequent = self._static_test(formula.antecedent), self._static_test(formula.consequent)
        return lambda binding: not antecedent(binding) or consequent(binding)

    def _compile_effect(
        self, effect: Effect, schema: ActionSchema, outer: frozenset[str], costs_only: bool
    ) -> list[_Op]:
        """``effect`` as operations on a binding, in order (with ``costs_only``, only what adds to the
        cost); ``outer`` names the variables bound where it applies."""
        if isinstance(effect, AndEffect):
            return [op for part in effect.parts for op in self._compile_effect(part, schema, outer, costs_only)]
        if isinstance(effect, AddEffect | DeleteEffect):
            return (
                [] if costs_only else [_atom_op(effect.atom, isinstance(effect, AddEffect), self.interned.setdefault)]
            )
        if isinstance(effect, WhenEffect):
            return self._when_op(effect, schema, outer, costs_only)
        if isinstance(effect, ForallEffect):
            body: Effect = effect.body
            guard: Formula | None = None
            if isinstance(body, WhenEffect) and self._is_static(body.condition):
                # The guard's join yields only bindings under which the condition holds.
                guard, body = body.condition, body.body
            names = frozenset(v.name for v in effect.variables)
            ops = self._compile_effect(body, schema, outer | names, costs_only)
            if costs_only and not ops:
                return []
            return [_Forall(self, schema, effect.variables, guard, tuple(ops), outer)]
        return [self._cost_op(effect, schema)]

    def _when_op(self, effect: WhenEffect, schema: ActionSchema, outer: frozenset[str], costs_only: bool) -> list[_Op]:
        body = tuple(self._compile_effect(effect.body, schema, outer, costs_only))
        if costs_only and not body:
            return []
        condition = effect.condition
        if not self._is_static(condition):
            # A condition over fluents: a case of the binding's effects (see hbtp.domains.alternatives).
            # Its static conjuncts (``(CONNECTED ?to ?c)`` under a forall) are tested first, quickly.
            simplify, name = self._simplify, schema.name
            static: Callable[[Binding], bool] | None = None
            if isinstance(condition, And):
                fluent: list[Formula] = []
                known: list[Formula] = []
                for part in condition.parts:
                    (known if self._is_static(part) else fluent).append(part)
                if known:
                    static = self._static_test(And(tuple(known)))
                    condition = And(tuple(fluent), condition.line)

            def case(binding: Binding, effects: Effects) -> None:
                if static is not None and not static(binding):
                    return  # it never fires
                inner = Effects()
                for op in body:
                    op(binding, inner)
                holds = simplify(condition, binding, schema)
                add_case(effects, holds, simplify(condition, binding, schema, False), inner, name)

            return [case]
        test = self._static_test(condition)

        def when(binding: Binding, effects: Effects) -> None:
            if test(binding):
                for op in body:
                    op(binding, effects)

        return [when]

    def _cost_op(self, effect: CostEffect, schema: ActionSchema) -> _Op:
        amount = effect.amount
        if isinstance(amount, int):
            fixed = amount
            return lambda binding, effects: effects.costs.append(fixed)
        predicate, args, numeric = amount.predicate, _getter(amount.terms), self.problem.numeric_init

        def cost(binding: Binding, effects: Effects) -> None:
            key = (predicate, args(binding))
            if key not in numeric:
                raise _UndefinedCost(f"({' '.join((key[0], *key[1]))})")
            value = numeric[key]
            if value < 0:
                raise GroundingError(
                    f"action {schema.name!r}: cost ({' '.join((key[0], *key[1]))}) is {value}, "
                    "and action costs must not be negative"
                )
            effects.costs.append(value)

        return cost

    # --------------------------------------------------------------- binding
    def _bindings(
        self,
        terms: list[list[_Literal]],
        params: tuple[TypedName, ...],
        start: Binding,
        allowed: frozenset[str] | None = None,
    ) -> Iterator[Binding]:
        """Every binding of ``params`` (extending ``start``; each value in ``allowed`` when given)
        under which some term of ``terms`` holds."""
        for term in terms:
            yield from self._join(term, params, start, allowed)

    def _join(
        self,
        term: list[_Literal],
        params: tuple[TypedName, ...],
        start: Binding,
        allowed: frozenset[str] | None = None,
    ) -> Iterator[Binding]:
        plan = self._plan(term, params, start, allowed)
        binding = dict(start)
        for equal in plan.equalities:
            bound = _bind_equal(binding, equal)
            if bound is None:
                return
            binding = bound
        if plan.checks and not all(check(binding) for check in plan.checks):
            return
        partial = [binding]
        for step in plan.steps:
            partial = self._extend(step, partial)
            if not partial:
                return
        checks, names = plan.last_checks, plan.unbound
        for binding in partial:
            if not names:
                self.tick()
                if not checks or all(check(binding) for check in checks):
                    yield binding
                continue
            for values in itertools.product(*plan.domains):
                self.tick()
                full = binding.copy()
                full.update(zip(names, values, strict=True))
                if not checks or all(check(full) for check in checks):
                    yield full

    def _extend(self, step: _Step, partial: list[Binding]) -> list[Binding]:
        """The bindings of ``partial`` extended by each fact of ``step`` that agrees with them."""
        index = self._index(step.predicate, step.positions)
        lookup, new, same, checks = step.lookup, step.new, step.same, step.checks
        extended: list[Binding] = []
        if len(new) == 1 and not same:  # the usual case, made quicker
            ((variable, position),) = new
            for binding in partial:
                facts = index.get(lookup(binding), ())
                self.tick(1 + len(facts))
                for fact in facts:
                    grown = binding.copy()
                    grown[variable] = fact[position]
                    if not checks or all(check(grown) for check in checks):
                        extended.append(grown)
            return extended
        for binding in partial:
            facts = index.get(lookup(binding), ())
            self.tick(1 + len(facts))
            for fact in facts:
                if same and any(fact[i] != fact[j] for i, j in same):
                    continue
                grown = binding
                if new:
                    grown = binding.copy()
                    for variable, position in new:
                        grown[variable] = fact[position]
                if not checks or all(check(grown) for check in checks):
                    extended.append(grown)
        return extended

    def _index(self, predicate: str, positions: tuple[int, ...]) -> dict[tuple[str, ...], list[tuple[str, ...]]]:
        """The static facts of ``predicate`` by their arguments at ``positions`` (in :init order)."""
        index = self.indexes.get((predicate, positions))
        if index is None:
            index = {}
            for fact in self._facts(predicate):
                index.setdefault(tuple([fact[i] for i in positions]), []).append(fact)
            self.indexes[predicate, positions] = index
        return index

    def _facts(self, predicate: str) -> Sequence[tuple[str, ...]]:
        """The facts a join step over ``predicate`` ranges over: static ones, or fluent ones reached."""
        if predicate in self.fluent:
            return self.reached.get(predicate, ()) if self.reached is not None else ()
        return self.static_index.get(predicate, ())

    def _plan(
        self, term: list[_Literal], params: tuple[TypedName, ...], start: Binding, allowed: frozenset[str] | None
    ) -> _Plan:
        key = (id(term), params, frozenset(start), allowed)
        cached = self.plans.get(key)
        if cached is not None and cached[0] is term:
            return cached[1]
        plan = self._make_plan(term, params, set(start), allowed)
        self.plans[key] = (term, plan)
        return plan

    def _make_plan(
        self, term: list[_Literal], params: tuple[TypedName, ...], bound: set[str], allowed: frozenset[str] | None
    ) -> _Plan:
        """The join of ``term`` when ``bound`` names the variables bound at its start (see :class:`_Plan`).

        Positive atoms are joined in increasing number of facts; every other literal, and the type of
        each parameter that a join step or the start binds, is checked as soon as its variables are bound.
        """
        equalities = tuple(lit.formula for lit in term if lit.positive and isinstance(lit.formula, Equals))
        for equal in equalities:
            left = not is_variable(equal.left) or equal.left in bound
            right = not is_variable(equal.right) or equal.right in bound
            if left != right:
                bound.add(equal.right if left else equal.left)
        positives = [lit.formula for lit in term if lit.positive and isinstance(lit.formula, AtomFormula)]
        positives.sort(key=lambda atom: len(self._facts(atom.predicate)))
        pending = [self._literal_check(lit) for lit in term if not lit.positive or isinstance(lit.formula, Equals)]
        joined = bound | {t for atom in positives for t in atom.terms if is_variable(t)}
        unique = len({p.name for p in params}) == len(params)
        for p in params:
            if p.types != (OBJECT_TYPE,) and (p.name in joined or not unique):
                pending.append(({p.name}, _member_check(p.name, frozenset(self.domain_of(p)))))
            if allowed is not None and (p.name in joined or not unique):
                pending.append(({p.name}, _member_check(p.name, allowed)))
        checks, pending = _ready(pending, bound)
        steps: list[_Step] = []
        for atom in positives:
            positions, lookup, new, same = _step_shape(atom.terms, bound)
            ready, pending = _ready(pending, bound)
            steps.append(_Step(atom.predicate, positions, _getter(lookup), new, same, ready))
        unbound = [p for p in params if p.name not in joined]
        return _Plan(
            equalities=equalities,
            checks=checks,
            steps=tuple(steps),
            unbound=tuple(p.name for p in unbound),
            domains=tuple(_within(self.domain_of(p), allowed) for p in unbound),
            last_checks=tuple(check for _, check in pending),
        )

    def _literal_check(self, literal: _Literal) -> tuple[set[str], _Check]:
        formula = literal.formula
        if isinstance(formula, Equals):
            variables = {t for t in (formula.left, formula.right) if is_variable(t)}
            return variables, _equality_check(formula.left, formula.right, literal.positive)
        variables = {t for t in formula.terms if is_variable(t)}
        return variables, _fact_check(formula.predicate, formula.terms, self.static_facts, literal.positive)

    # ------------------------------------------------------------- simplify
    def _simplify(self, formula: Formula, binding: Binding, schema: ActionSchema, positive: bool = True) -> Value:
        """Evaluate static parts (negated when not ``positive``); what remains is a conjunction of
        fluent literals, or a :class:`Choice` of such conjunctions when a disjunction over fluents
        remains (the action then has one ground action per alternative)."""
        if isinstance(formula, AtomFormula):
            terms = tuple(_subst(t, binding) for t in formula.terms)
            if formula.predicate in self.fluent:
                return [(formula.predicate if positive else NEGATED + formula.predicate, terms)]
            return ((formula.predicate, terms) in self.static_facts) == positive
        if isinstance(formula, Equals):
            return (_subst(formula.left, binding) == _subst(formula.right, binding)) == positive
        if isinstance(formula, Not):
            return self._simplify(formula.operand, binding, schema, not positive)
        if isinstance(formula, Imply):
            parts: tuple[tuple[Formula, bool], ...] = (
                (formula.antecedent, not positive),
                (formula.consequent, positive),
            )
            conjunctive = not positive
        elif isinstance(formula, And | Or):
            parts = tuple((part, positive) for part in formula.parts)
            conjunctive = isinstance(formula, And) == positive
        else:
            raise self._not_strips(schema, formula.line, "a quantifier left unexpanded")  # expand_domain removes them
        values: list[list[_Key] | Choice] = []
        for part, polarity in parts:
            value = self._simplify(part, binding, schema, polarity)
            if value is not conjunctive and isinstance(value, bool):
                return value  # False decides a conjunction, True a disjunction
            if not isinstance(value, bool):
                values.append(value)
        if not values:
            return conjunctive
        return conjoined(values, schema.name) if conjunctive else disjoined(values, schema.name)

    def _not_strips(self, schema: ActionSchema, line: int, what: str) -> GroundingError:
        where = f" (line {line})" if line else ""
        return GroundingError(f"action {schema.name!r}{where}: {what} is not STRIPS once static facts are evaluated")


class _Forall:
    """A compiled ``forall`` effect: its body applied under each binding of its variables that its
    static guard (the condition of a ``when`` body) allows.

    When no positive literal of the guard mentions an outer variable (RobotHow's ``Walk``:
    ``(and (all_objects ?y) (not (= ?y ?x)))``), the guard is joined once, without the outer binding,
    and the literals that mention outer variables are checked as the body is applied. Otherwise the
    guard's bindings depend on the outer binding only through the variables the guard mentions, so
    they are joined once per distinct value of those (unless these are every outer variable).
    """

    __slots__ = ("body", "grounder", "guard", "key_names", "memo", "names", "outer", "schema", "split", "terms")

    def __init__(
        self,
        grounder: _Grounder,
        schema: ActionSchema,
        variables: tuple[TypedName, ...],
        guard: Formula | None,
        body: tuple[_Op, ...],
        outer: frozenset[str],
    ) -> None:
        self.grounder = grounder
        self.schema = schema
        self.guard = (variables, _flatten_and(guard) if guard is not None else [])
        self.body = body
        self.outer = outer
        self.names = tuple(v.name for v in variables)
        mentioned = set(self.names) | (_variables(guard) if guard is not None else set())
        self.key_names = tuple(sorted(mentioned))
        self.memo: dict[tuple[str | None, ...], list[_Segment]] | None = None if outer <= mentioned else {}
        self.terms: list[list[_Literal]] | None = None
        self.split: list[_Segment] | None = None

    def segments(self, binding: Binding) -> list[_Segment]:
        """The values of the variables under each binding the guard allows, extending ``binding``,
        in runs whose values must also pass the run's checks."""
        variables, parts = self.guard
        terms = self.terms
        if terms is None:
            # First use: the guard's normal form (refused here when too large), then how to join it.
            terms = self.terms = _dnf_checked(And(tuple(parts)), self.schema)
            self.split = self._split(terms, variables)
        if self.split is not None:
            return self.split
        memo = self.memo
        key = tuple([binding.get(name) for name in self.key_names]) if memo is not None else ()
        found = memo.get(key) if memo is not None else None
        if found is None:
            names, joined = self.names, self.grounder._bindings(terms, variables, binding)
            found = [([tuple([full[n] for n in names]) for full in joined], ())]
            if memo is not None:
                memo[key] = found
        return found

    def _split(self, terms: list[list[_Literal]], variables: tuple[TypedName, ...]) -> list[_Segment] | None:
        """Each term's bindings joined without the outer binding, with the checks of its literals that
        mention outer variables; ``None`` when a positive literal mentions one (or a variable of the
        forall hides an outer one), as a join step would then depend on the outer binding."""
        if self.outer & set(self.names):
            return None
        inner_terms: list[list[_Literal]] = []
        outer_checks: list[tuple[_Check, ...]] = []
        for term in terms:
            inner: list[_Literal] = []
            checks: list[_Check] = []
            for literal in term:
                used, check = self.grounder._literal_check(literal)
                if not used & self.outer:
                    inner.append(literal)
                elif literal.positive:
                    return None
                else:
                    checks.append(check)
            inner_terms.append(inner)
            outer_checks.append(tuple(checks))
        names = self.names
        return [
            ([tuple([full[n] for n in names]) for full in self.grounder._join(inner, variables, {})], checks)
            for inner, checks in zip(inner_terms, outer_checks, strict=True)
        ]

    def __call__(self, binding: Binding, effects: Effects) -> None:
        names, body = self.names, self.body
        extended = binding.copy()
        for values, checks in self.segments(binding):
            self.grounder.tick(1 + len(values))
            if len(names) == 1 and len(body) == 1:  # the usual case, made quicker
                name, op = names[0], body[0]
                for (value,) in values:
                    extended[name] = value
                    if not checks or all(check(extended) for check in checks):
                        op(extended, effects)
                continue
            for row in values:
                extended.update(zip(names, row, strict=True))
                if not checks or all(check(extended) for check in checks):
                    for op in body:
                        op(extended, effects)


# ======================================================================= helpers
def _changes(needs: frozenset[_Key], add: set[_Key], delete: set[_Key]) -> tuple[frozenset[_Key], frozenset[_Key]]:
    """What a ground action really adds and deletes: adding what the precondition requires changes
    nothing, and what is both deleted and added stays (delete, then add)."""
    return frozenset(add) - needs, frozenset(delete - add)


def _reaching_atoms(fluent_parts: Iterable[Formula]) -> list[AtomFormula]:
    """The positive fluent atoms of a precondition's conjuncts: what relaxed reachability joins."""
    return [part for part in fluent_parts if isinstance(part, AtomFormula)]


class _UndefinedCost(Exception):
    """A ground action's cost names a function value that :init does not define."""


def _flatten_and(formula: Formula) -> list[Formula]:
    if isinstance(formula, And):
        out: list[Formula] = []
        for part in formula.parts:
            out.extend(_flatten_and(part))
        return out
    return [formula]


def _variables(formula: Formula) -> set[str]:
    """The variables ``formula`` mentions."""
    if isinstance(formula, AtomFormula):
        return {t for t in formula.terms if is_variable(t)}
    if isinstance(formula, Equals):
        return {t for t in (formula.left, formula.right) if is_variable(t)}
    if isinstance(formula, Not):
        return _variables(formula.operand)
    if isinstance(formula, And | Or):
        return set().union(*(_variables(part) for part in formula.parts))
    if isinstance(formula, Exists | Forall):
        return _variables(formula.body) - {v.name for v in formula.variables}
    return _variables(formula.antecedent) | _variables(formula.consequent)


def _dnf_size(formula: Formula, positive: bool = True) -> int:
    """The number of terms :func:`_dnf` gives, computed without building them."""
    if isinstance(formula, AtomFormula | Equals):
        return 1
    if isinstance(formula, Not):
        return _dnf_size(formula.operand, not positive)
    if isinstance(formula, Imply):
        return _dnf_size(Or((Not(formula.antecedent), formula.consequent)), positive)
    assert not isinstance(formula, Exists | Forall), "quantifiers are expanded first"
    sizes = [_dnf_size(part, positive) for part in formula.parts]
    return math.prod(sizes) if isinstance(formula, And) == positive else sum(sizes)


def _dnf_checked(formula: Formula, schema: ActionSchema) -> list[list[_Literal]]:
    """:func:`_dnf`, refusing a static condition whose normal form would exceed :data:`MAX_DNF_TERMS`."""
    size = _dnf_size(formula)
    if size > MAX_DNF_TERMS:
        raise GroundingError(
            f"action {schema.name!r}: its static condition has {size:,} cases in disjunctive normal form, "
            f"more than the limit of {MAX_DNF_TERMS:,}"
        )
    return _dnf(formula)


def _dnf(formula: Formula, positive: bool = True) -> list[list[_Literal]]:
    """Disjunctive normal form of a static formula (negations pushed to the literals)."""
    if isinstance(formula, AtomFormula | Equals):
        return [[_Literal(formula, positive)]]
    if isinstance(formula, Not):
        return _dnf(formula.operand, not positive)
    if isinstance(formula, Imply):
        return _dnf(Or((Not(formula.antecedent), formula.consequent)), positive)
    assert not isinstance(formula, Exists | Forall), "quantifiers are expanded first"
    conjunctive = isinstance(formula, And) == positive
    children = [_dnf(part, positive) for part in formula.parts]
    if not conjunctive:
        return [term for child in children for term in child]
    terms: list[list[_Literal]] = [[]]
    for child in children:
        terms = [left + right for left in terms for right in child]
    return terms


def _subst(term: str, binding: Binding) -> str:
    return binding[term] if is_variable(term) else term


def _getter(terms: Iterable[str]) -> Callable[[Binding], tuple[str, ...]]:
    """A function giving ``terms`` with their variables replaced by their values in a binding."""
    template: _Template = tuple((is_variable(t), t) for t in terms)
    if not template:
        return lambda binding: ()
    if len(template) == 1:
        variable, name = template[0]
        return (lambda binding: (binding[name],)) if variable else (lambda binding: (name,))
    if len(template) == 2:
        (first_variable, first), (second_variable, second) = template
        if first_variable and second_variable:
            return lambda binding: (binding[first], binding[second])
        if second_variable:
            return lambda binding: (first, binding[second])
        if first_variable:
            return lambda binding: (binding[first], second)
    return lambda binding: tuple([binding[name] if variable else name for variable, name in template])


def _atom_op(atom: AtomFormula, positive: bool, intern: Callable[[_Key, _Key], _Key]) -> _Op:
    predicate, args = atom.predicate, _getter(atom.terms)
    if positive:
        return lambda binding, effects: effects.add.add(intern(key := (predicate, args(binding)), key))
    return lambda binding, effects: effects.delete.add(intern(key := (predicate, args(binding)), key))


def _fact_check(predicate: str, terms: tuple[str, ...], facts: set[_Key], positive: bool) -> _Check:
    args = _getter(terms)
    if positive:
        return lambda binding: (predicate, args(binding)) in facts
    return lambda binding: (predicate, args(binding)) not in facts


def _equality_check(left: str, right: str, positive: bool) -> _Check:
    first, second = _getter((left, right)), positive

    def check(binding: Binding) -> bool:
        a, b = first(binding)
        return (a == b) == second

    return check


def _within(values: tuple[str, ...], allowed: frozenset[str] | None) -> tuple[str, ...]:
    return values if allowed is None else tuple(v for v in values if v in allowed)


def _member_check(variable: str, members: frozenset[str]) -> _Check:
    return lambda binding: binding[variable] in members


def _ready(
    pending: list[tuple[set[str], _Check]], bound: set[str]
) -> tuple[tuple[_Check, ...], list[tuple[set[str], _Check]]]:
    """The checks of ``pending`` whose variables are all ``bound``, and the others."""
    ready = tuple(check for variables, check in pending if variables <= bound)
    return ready, [(variables, check) for variables, check in pending if not variables <= bound]


def _step_shape(
    terms: tuple[str, ...], bound: set[str]
) -> tuple[tuple[int, ...], tuple[str, ...], tuple[tuple[str, int], ...], tuple[tuple[int, int], ...]]:
    """A join step over an atom's ``terms``: its bound positions and their terms, the variables it
    binds (with their first position), the later positions of those; adds them to ``bound``."""
    positions: list[int] = []
    lookup: list[str] = []
    first: dict[str, int] = {}
    same: list[tuple[int, int]] = []
    for position, term in enumerate(terms):
        if not is_variable(term) or term in bound:
            positions.append(position)
            lookup.append(term)
        elif term in first:
            same.append((position, first[term]))
        else:
            first[term] = position
    bound.update(first)
    return tuple(positions), tuple(lookup), tuple(first.items()), tuple(same)


def _bind_equal(binding: Binding, equal: Equals) -> Binding | None:
    left, right = equal.left, equal.right
    left_value = binding.get(left) if is_variable(left) else left
    right_value = binding.get(right) if is_variable(right) else right
    if left_value is not None and right_value is not None:
        return binding if left_value == right_value else None
    if left_value is None and right_value is not None:
        return {**binding, left: right_value}
    if right_value is None and left_value is not None:
        return {**binding, right: left_value}
    return binding
