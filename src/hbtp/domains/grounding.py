"""Compile a lifted PDDL domain and problem into a :class:`~hbtp.logic.GroundTask`.

Static predicates (no action changes them) are evaluated against the problem's initial facts and
disappear: guards such as ``(imply (hasplug ?y) (IsPlugged ?y))`` become plain STRIPS preconditions,
and ``(forall (?z) (when (not (= ?z ?x)) (not (IsNear self ?z))))`` becomes a list of delete effects.

Bindings are enumerated by joining the static facts that an action's precondition requires (each
disjunct of its static part in turn), so an action over 126 objects never tries all pairs blindly.

With ``reachable_only``, only the actions reachable from s0 under the delete relaxation are kept
(:func:`~hbtp.domains.reachability.reachable_actions`), with the atoms s0 or they mention.

Before enumerating, the number of ground actions of each schema is bounded from above (the join's
size: per static atom, at most its number of facts; per remaining parameter, the objects of its
type). A task whose bound exceeds ``max_ground_actions`` (by default ``$HBTP_MAX_GROUND_ACTIONS``, else
:data:`MAX_GROUND_ACTIONS`; a ground action takes about 1-2 KB of memory) is refused with a one-line
:class:`~hbtp.errors.GroundingError` before any memory is spent; a ``deadline`` stops grounding with
:class:`~hbtp.deadline.TimeLimitReached`.
"""

from __future__ import annotations

import dataclasses
import itertools
import logging
import math
import os
from collections.abc import Iterable, Iterator
from dataclasses import dataclass

from hbtp.deadline import Deadline, TimeLimitReached
from hbtp.domains.lifted import (
    MAX_ACTION_COST,
    OBJECT_TYPE,
    ActionSchema,
    AddEffect,
    And,
    AndEffect,
    AtomFormula,
    DeleteEffect,
    Domain,
    Effect,
    Equals,
    ForallEffect,
    Formula,
    Imply,
    Not,
    Or,
    Problem,
    TypedName,
    WhenEffect,
    is_variable,
)
from hbtp.domains.reachability import reachable_actions
from hbtp.errors import GroundingError, InputError
from hbtp.logic.atoms import Atom
from hbtp.logic.task import GroundAction, GroundTask, listing

log = logging.getLogger(__name__)

Binding = dict[str, str]

#: The default bound on the number of ground actions (see the module docstring).
MAX_GROUND_ACTIONS = 1_000_000
#: The most disjuncts a static precondition or ``when`` guard may have once put in disjunctive normal form.
MAX_DNF_TERMS = 10_000
_PHASE = "grounding"
LIMIT_VARIABLE = "HBTP_MAX_GROUND_ACTIONS"


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
    """
    if max_ground_actions is None:
        max_ground_actions = ground_actions_limit()
    if max_ground_actions < 1:
        raise InputError(f"max_ground_actions must be at least 1, not {max_ground_actions}")
    grounder = _Grounder(domain, problem, frozenset(keep_fluent), deadline, reachable_only)
    grounder.check_size(max_ground_actions)
    stopped = ""
    try:
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
    unknown = [c for c in categories if c not in task.categories]
    if unknown:
        raise InputError(f"object category {unknown[0]!r} is not a unary static predicate with members")
    objects = tuple(sorted({o for c in categories for o in task.categories[c]}))
    everything = dict.fromkeys((*task.constants, *task.objects))
    constants = tuple(sorted(s for s in everything if s not in set(objects)))
    return dataclasses.replace(task, objects=objects, constants=constants)


class _Grounder:
    def __init__(
        self,
        domain: Domain,
        problem: Problem,
        keep_fluent: frozenset[str],
        deadline: Deadline | None = None,
        reachable_only: bool = False,
    ) -> None:
        self.domain = domain
        self.reachable_only = reachable_only
        self.problem = problem
        self.deadline = deadline
        self.ticks = 0
        unknown = sorted(keep_fluent - set(domain.predicates))
        if unknown:
            raise InputError(f"keep_fluent names unknown predicate(s): {', '.join(unknown)}")
        self.fluent = _effect_predicates(domain.actions) | keep_fluent
        self.objects: tuple[TypedName, ...] = (*domain.constants, *problem.objects)
        self.by_type = self._objects_by_type()
        self.static_facts: set[tuple[str, tuple[str, ...]]] = set()
        self.static_index: dict[str, list[tuple[str, ...]]] = {}
        self.initial: set[Atom] = set()
        for fact in problem.init:
            if fact.predicate in self.fluent:
                self.initial.add(Atom(fact.predicate, fact.terms))
            elif (fact.predicate, fact.terms) not in self.static_facts:
                self.static_facts.add((fact.predicate, fact.terms))
                self.static_index.setdefault(fact.predicate, []).append(fact.terms)

    # ----------------------------------------------------------------- types
    def _objects_by_type(self) -> dict[str, tuple[str, ...]]:
        parents = self.domain.types
        table: dict[str, list[str]] = {OBJECT_TYPE: []}
        for obj in self.objects:
            for declared in obj.types:
                current: str | None = declared
                seen: set[str] = set()
                while current is not None and current not in seen:
                    seen.add(current)
                    table.setdefault(current, []).append(obj.name)
                    current = parents.get(current, OBJECT_TYPE if current != OBJECT_TYPE else None)
        return {t: tuple(dict.fromkeys(names)) for t, names in table.items()}

    def domain_of(self, typed: TypedName) -> tuple[str, ...]:
        if len(typed.types) == 1:
            return self.by_type.get(typed.types[0], ())
        merged: list[str] = []
        for t in typed.types:
            merged.extend(self.by_type.get(t, ()))
        return tuple(dict.fromkeys(merged))

    def tick(self) -> None:
        """Count a unit of work; every 4096 units, check the deadline."""
        self.ticks += 1
        if self.ticks & 4095 == 0 and self.deadline is not None:
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

    def check_size(self, limit: int) -> None:
        """Refuse a task whose estimated number of ground actions exceeds ``limit``."""
        estimates = [(self.estimate(schema), -index) for index, schema in enumerate(self.domain.actions)]
        total = sum(estimate for estimate, _ in estimates)
        if total <= limit:
            return
        largest, index = max(estimates)
        schema = self.domain.actions[-index]
        counts = " x ".join(str(len(self.domain_of(p))) for p in schema.parameters) or "1"
        variables = " ".join(p.name for p in schema.parameters)
        raise GroundingError(
            f"grounding would create up to {total:,} actions, more than the limit of {limit:,} "
            f"(max_ground_actions, or {LIMIT_VARIABLE} for the command line): {schema.name}({variables}) "
            f"alone may have {largest:,} ({counts} candidate objects)"
        )

    # ------------------------------------------------------------------- run
    def run(self, task_name: str) -> GroundTask:
        grounded: list[tuple[Atom, frozenset[Atom], frozenset[Atom], frozenset[Atom], int]] = []
        for schema in self.domain.actions:
            if self.deadline is not None:
                self.deadline.check(_PHASE)
            grounded.extend(self._ground_schema(schema))
        grounded.sort(key=lambda g: str(g[0]))
        if self.reachable_only:
            found = len(grounded)
            kept = reachable_actions(self.initial, [(pre, add) for _, pre, add, _, _ in grounded], self.tick)
            grounded = [grounded[index] for index in kept]
            log.debug("%s: %d of %d ground actions are unreachable from s0", task_name, found - len(grounded), found)
        all_atoms: set[Atom] = set(self.initial)
        for _, pre, add, delete, _ in grounded:
            all_atoms |= pre | add | delete
        atoms = tuple(sorted(all_atoms))
        ids = {atom: i for i, atom in enumerate(atoms)}
        actions = tuple(
            GroundAction(
                index,
                signature,
                frozenset(ids[a] for a in pre),
                frozenset(ids[a] for a in add),
                frozenset(ids[a] for a in delete),
                cost,
            )
            for index, (signature, pre, add, delete, cost) in enumerate(grounded)
        )
        log.debug("grounded %s: %d actions, %d atoms", task_name, len(actions), len(atoms))
        return GroundTask(
            name=task_name,
            atoms=atoms,
            actions=actions,
            initial_state=frozenset(ids[a] for a in self.initial),
            objects=tuple(o.name for o in self.problem.objects),
            constants=tuple(c.name for c in self.domain.constants),
            predicates={p: len(args) for p, args in self.domain.predicates.items() if p in self.fluent},
            static_facts=frozenset(Atom(p, args) for p, args in self.static_facts),
        )

    def _ground_schema(
        self, schema: ActionSchema
    ) -> Iterator[tuple[Atom, frozenset[Atom], frozenset[Atom], frozenset[Atom], int]]:
        static_parts, fluent_parts = self._split_precondition(schema.precondition)
        seen: set[tuple[str, ...]] = set()
        dropped: list[str] = []
        yield from self._ground_bindings(schema, static_parts, fluent_parts, seen, dropped)
        if dropped:
            # Fast Downward's translator only instantiates reachable actions, and fails on one whose cost
            # is undefined; hbtp grounds from static facts alone, so it drops them (elevators' slow lifts).
            log.warning(
                "action %r (line %d): %d ground action(s) dropped, their cost is not defined in :init (%s)",
                schema.name,
                schema.line,
                len(dropped),
                listing(dropped, 3),
            )

    def _ground_bindings(
        self,
        schema: ActionSchema,
        static_parts: list[Formula],
        fluent_parts: list[Formula],
        seen: set[tuple[str, ...]],
        dropped: list[str],
    ) -> Iterator[tuple[Atom, frozenset[Atom], frozenset[Atom], frozenset[Atom], int]]:
        params = schema.parameters
        for binding in self._bindings(static_parts, params, {}, schema):
            self.tick()
            key = tuple(binding[p.name] for p in params)
            if key in seen:
                continue
            seen.add(key)
            pre: list[Atom] = []
            possible = True
            for part in fluent_parts:
                value = self._simplify(part, binding, schema)
                if value is False:
                    possible = False
                    break
                if value is not True:
                    pre.extend(value)
            if not possible:
                continue
            add: set[Atom] = set()
            delete: set[Atom] = set()
            costs: list[int] = []
            try:
                self._apply_effect(schema.effect, binding, schema, add, delete, costs)
            except _UndefinedCost as undefined:
                dropped.append(undefined.args[0])
                continue
            cost = sum(costs) if self.domain.uses_action_costs else 1
            if cost > MAX_ACTION_COST:
                raise GroundingError(
                    f"action {Atom(schema.name, key)} costs {cost}, more than the maximum {MAX_ACTION_COST}"
                )
            yield Atom(schema.name, key), frozenset(pre), frozenset(add), frozenset(delete - add), cost

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
        return self._is_static(formula.antecedent) and self._is_static(formula.consequent)

    def _split_precondition(self, formula: Formula) -> tuple[list[Formula], list[Formula]]:
        conjuncts = _flatten_and(formula)
        static = [c for c in conjuncts if self._is_static(c)]
        fluent = [c for c in conjuncts if not self._is_static(c)]
        return static, fluent

    # --------------------------------------------------------------- binding
    def _bindings(
        self, static_parts: list[Formula], params: Iterable[TypedName], start: Binding, schema: ActionSchema
    ) -> Iterator[Binding]:
        """Every binding of ``params`` (extending ``start``) under which ``static_parts`` all hold."""
        params = tuple(params)
        for term in _dnf_checked(And(tuple(static_parts)), schema):
            yield from self._join(term, params, start)

    def _join(self, term: list[_Literal], params: tuple[TypedName, ...], start: Binding) -> Iterator[Binding]:
        partial: list[Binding] = [dict(start)]
        positives = [lit.formula for lit in term if lit.positive and isinstance(lit.formula, AtomFormula)]
        positives.sort(key=lambda atom: len(self.static_index.get(atom.predicate, ())))
        for lit in term:
            if lit.positive and isinstance(lit.formula, Equals):
                partial = [b for b in (_bind_equal(b, lit.formula) for b in partial) if b is not None]
        for atom in positives:
            facts = self.static_index.get(atom.predicate, [])
            extended: list[Binding] = []
            for binding in partial:
                self.tick()
                for fact in facts:
                    new = _unify(atom.terms, fact, binding)
                    if new is not None:
                        extended.append(new)
            partial = extended
            if not partial:
                return
        for binding in partial:
            unbound = [p for p in params if p.name not in binding]
            domains = [self.domain_of(p) for p in unbound]
            for values in itertools.product(*domains):
                self.tick()
                full = dict(binding)
                full.update(zip((p.name for p in unbound), values, strict=True))
                if self._types_ok(params, full) and all(self._holds(lit, full) for lit in term):
                    yield full

    def _types_ok(self, params: tuple[TypedName, ...], binding: Binding) -> bool:
        return all(p.types == (OBJECT_TYPE,) or binding[p.name] in self.domain_of(p) for p in params)

    def _holds(self, literal: _Literal, binding: Binding) -> bool:
        formula = literal.formula
        if isinstance(formula, Equals):
            value = _subst(formula.left, binding) == _subst(formula.right, binding)
        else:
            value = (formula.predicate, tuple(_subst(t, binding) for t in formula.terms)) in self.static_facts
        return value == literal.positive

    # ------------------------------------------------------------- simplify
    def _simplify(self, formula: Formula, binding: Binding, schema: ActionSchema) -> bool | list[Atom]:
        """Evaluate static parts; what remains must be a conjunction of positive fluent atoms."""
        if isinstance(formula, AtomFormula):
            terms = tuple(_subst(t, binding) for t in formula.terms)
            if formula.predicate in self.fluent:
                return [Atom(formula.predicate, terms)]
            return (formula.predicate, terms) in self.static_facts
        if isinstance(formula, Equals):
            return _subst(formula.left, binding) == _subst(formula.right, binding)
        if isinstance(formula, Not):
            inner = self._simplify(formula.operand, binding, schema)
            if isinstance(inner, bool):
                return not inner
            raise self._not_strips(schema, formula.line, "a negated fluent condition")
        if isinstance(formula, And):
            atoms: list[Atom] = []
            for part in formula.parts:
                value = self._simplify(part, binding, schema)
                if value is False:
                    return False
                if value is not True:
                    atoms.extend(value)
            return atoms or True
        if isinstance(formula, Or):
            remaining: list[list[Atom]] = []
            for part in formula.parts:
                value = self._simplify(part, binding, schema)
                if value is True:
                    return True
                if value is not False:
                    remaining.append(value)
            if not remaining:
                return False
            if len(remaining) == 1:
                return remaining[0]
            raise self._not_strips(schema, formula.line, "a disjunction over fluents")
        antecedent = self._simplify(formula.antecedent, binding, schema)
        if not isinstance(antecedent, bool):
            raise self._not_strips(schema, formula.line, "(imply ...) with a fluent antecedent")
        return self._simplify(formula.consequent, binding, schema) if antecedent else True

    def _not_strips(self, schema: ActionSchema, line: int, what: str) -> GroundingError:
        where = f" (line {line})" if line else ""
        return GroundingError(f"action {schema.name!r}{where}: {what} is not STRIPS once static facts are evaluated")

    # --------------------------------------------------------------- effects
    def _apply_effect(
        self,
        effect: Effect,
        binding: Binding,
        schema: ActionSchema,
        add: set[Atom],
        delete: set[Atom],
        costs: list[int],
    ) -> None:
        if isinstance(effect, AddEffect):
            add.add(Atom(effect.atom.predicate, tuple(_subst(t, binding) for t in effect.atom.terms)))
        elif isinstance(effect, DeleteEffect):
            delete.add(Atom(effect.atom.predicate, tuple(_subst(t, binding) for t in effect.atom.terms)))
        elif isinstance(effect, AndEffect):
            for part in effect.parts:
                self._apply_effect(part, binding, schema, add, delete, costs)
        elif isinstance(effect, WhenEffect):
            if not self._is_static(effect.condition):
                raise self._not_strips(schema, effect.line, "a conditional effect on fluents")
            if self._simplify(effect.condition, binding, schema) is True:
                self._apply_effect(effect.body, binding, schema, add, delete, costs)
        elif isinstance(effect, ForallEffect):
            guard: list[Formula] = []
            if isinstance(effect.body, WhenEffect) and self._is_static(effect.body.condition):
                guard = _flatten_and(effect.body.condition)
            for extended in self._bindings(guard, effect.variables, binding, schema):
                self._apply_effect(effect.body, extended, schema, add, delete, costs)
        else:
            amount = effect.amount
            if isinstance(amount, int):
                costs.append(amount)
            else:
                key = (amount.predicate, tuple(_subst(t, binding) for t in amount.terms))
                if key not in self.problem.numeric_init:
                    raise _UndefinedCost(f"({' '.join((key[0], *key[1]))})")
                value = self.problem.numeric_init[key]
                if value < 0:
                    raise GroundingError(
                        f"action {schema.name!r}: cost ({' '.join((key[0], *key[1]))}) is {value}, "
                        "and action costs must not be negative"
                    )
                costs.append(value)


# ======================================================================= helpers
class _UndefinedCost(Exception):
    """A ground action's cost names a function value that :init does not define."""


def _effect_predicates(actions: Iterable[ActionSchema]) -> set[str]:
    found: set[str] = set()

    def visit(effect: Effect) -> None:
        if isinstance(effect, AddEffect | DeleteEffect):
            found.add(effect.atom.predicate)
        elif isinstance(effect, AndEffect):
            for part in effect.parts:
                visit(part)
        elif isinstance(effect, ForallEffect | WhenEffect):
            visit(effect.body)

    for action in actions:
        visit(action.effect)
    return found


def _flatten_and(formula: Formula) -> list[Formula]:
    if isinstance(formula, And):
        out: list[Formula] = []
        for part in formula.parts:
            out.extend(_flatten_and(part))
        return out
    return [formula]


def _dnf_size(formula: Formula, positive: bool = True) -> int:
    """The number of terms :func:`_dnf` gives, computed without building them."""
    if isinstance(formula, AtomFormula | Equals):
        return 1
    if isinstance(formula, Not):
        return _dnf_size(formula.operand, not positive)
    if isinstance(formula, Imply):
        return _dnf_size(Or((Not(formula.antecedent), formula.consequent)), positive)
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


def _unify(terms: tuple[str, ...], fact: tuple[str, ...], binding: Binding) -> Binding | None:
    new: Binding | None = None
    for term, value in zip(terms, fact, strict=True):
        if is_variable(term):
            bound = (new or binding).get(term)
            if bound is None:
                if new is None:
                    new = dict(binding)
                new[term] = value
            elif bound != value:
                return None
        elif term != value:
            return None
    return new if new is not None else dict(binding)


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
