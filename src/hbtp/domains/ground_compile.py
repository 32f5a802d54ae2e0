"""Grounding's compile stage: action schemas into what builds their STRIPS ground actions.

Gets an action schema of the :class:`~hbtp.domains.ground_context.Prepared` task, whose quantifiers
:mod:`hbtp.domains.quantifiers` has already expanded; gives a :class:`CompiledSchema`: its static
precondition in disjunctive normal form (what the join stage joins), its fluent precondition's parts
(evaluated per binding, static parts first: a disjunction over fluents left becomes a choice of
alternatives, :mod:`hbtp.domains.alternatives`), and its effects as operations on a binding.

Static predicates (no action changes them) are evaluated against the problem's initial facts and
disappear: guards such as ``(imply (hasplug ?y) (IsPlugged ?y))`` become plain STRIPS preconditions,
and ``(forall (?z) (when (not (= ?z ?x)) (not (IsNear self ?z))))`` becomes a list of delete effects.
A ``when`` whose condition is over fluents becomes a case of the binding's effects, which may give it
several ground actions (:mod:`hbtp.domains.alternatives`); a ``forall`` effect's guard is joined
once per distinct value of the outer variables it mentions.
"""

from __future__ import annotations

import math
from collections.abc import Callable, Iterable
from dataclasses import dataclass

from hbtp.domains.alternatives import Choice, Effects, Value, add_case, conjoined, disjoined
from hbtp.domains.ground_context import NEGATED, Binding, Check, Key, Prepared
from hbtp.domains.ground_join import FluentPart, Joiner, StaticLiteral, equality_check, fact_check, getter
from hbtp.domains.lifted import (
    ActionSchema,
    AddEffect,
    And,
    AndEffect,
    AtomFormula,
    CostEffect,
    DeleteEffect,
    Effect,
    Equals,
    Exists,
    Forall,
    ForallEffect,
    Formula,
    Imply,
    Not,
    Or,
    TypedName,
    WhenEffect,
    is_variable,
)
from hbtp.errors import GroundingError

#: The most disjuncts a static precondition or ``when`` guard may have once put in disjunctive normal form.
MAX_DNF_TERMS = 10_000

Op = Callable[[Binding, Effects], None]
_Segment = tuple[list[tuple[str, ...]], tuple[Check, ...]]  # a forall's values, with their checks


@dataclass(frozen=True, slots=True)
class FixedCost:
    """The operation of a cost effect by a number: it adds ``amount`` under every binding."""

    amount: int

    def __call__(self, binding: Binding, effects: Effects) -> None:
        effects.costs.append(self.amount)


class UndefinedCost(Exception):
    """A ground action's cost names a function value that :init does not define."""


@dataclass(frozen=True, slots=True)
class CompiledSchema:
    """An action schema compiled for grounding: its static precondition in DNF, its fluent
    precondition parts, and its effects (all of them, or only what adds to the cost)."""

    static: list[list[StaticLiteral]]
    fluent: tuple[FluentPart, ...]
    ops: tuple[Op, ...]
    cost_ops: tuple[Op, ...]
    #: Every fluent part is a (possibly negated) fluent atom: it never rules a binding out, so a
    #: binding's existence and cost do not depend on it.
    fluent_atoms_only: bool = False


class Compiler:
    """Compiles the schemas of one grounding; with ``joiner.reached``, a schema's positive fluent
    atoms are joined too, with the fluent facts reached from s0."""

    def __init__(self, prepared: Prepared, joiner: Joiner) -> None:
        self.fluent = prepared.fluent
        self.static_facts = prepared.static_facts
        self.numeric = prepared.problem.numeric_init
        self.joiner = joiner
        self.interned: dict[Key, Key] = {}  # one tuple per distinct atom: less memory, quicker lookups

    def compile(self, schema: ActionSchema) -> CompiledSchema:
        static_parts, fluent_parts = split_precondition(schema.precondition, self.fluent)
        outer = frozenset(p.name for p in schema.parameters)
        static = dnf_checked(And(tuple(static_parts)), schema)
        if self.joiner.reached is not None:  # join the positive fluent atoms with the facts reached
            joined = [StaticLiteral(part, True) for part in reaching_atoms(fluent_parts)]
            static = [[*term, *joined] for term in static]
        return CompiledSchema(
            static=static,
            fluent=tuple(self._compile_fluent(part, schema) for part in fluent_parts),
            ops=tuple(self._compile_effect(schema.effect, schema, outer, False)),
            cost_ops=tuple(self._compile_effect(schema.effect, schema, outer, True)),
            fluent_atoms_only=all(self._is_fluent_literal(part) for part in fluent_parts),
        )

    def _is_fluent_literal(self, formula: Formula) -> bool:
        """``formula`` is a fluent literal, or one behind an ``imply`` over statics: :meth:`_compile_fluent`
        makes it a part that never rules a binding out."""
        if isinstance(formula, Imply) and is_static(formula.antecedent, self.fluent):
            return self._is_fluent_literal(formula.consequent)
        atom = formula.operand if isinstance(formula, Not) else formula
        return isinstance(atom, AtomFormula) and atom.predicate in self.fluent

    def _compile_fluent(self, formula: Formula, schema: ActionSchema) -> FluentPart:
        """:meth:`simplify` of ``formula``, made quicker for a fluent atom or an ``imply`` over statics."""
        if isinstance(formula, AtomFormula) and formula.predicate in self.fluent:
            predicate, args, intern = formula.predicate, getter(formula.terms), self.interned.setdefault
            return lambda binding: [intern(key := (predicate, args(binding)), key)]
        operand = formula.operand if isinstance(formula, Not) else None
        if isinstance(operand, AtomFormula) and operand.predicate in self.fluent:
            negated, args = NEGATED + operand.predicate, getter(operand.terms)
            return lambda binding: [(negated, args(binding))]
        if isinstance(formula, Imply) and is_static(formula.antecedent, self.fluent):
            test = self._static_test(formula.antecedent)
            rest = self._compile_fluent(formula.consequent, schema)
            return lambda binding: rest(binding) if test(binding) else True
        return lambda binding: self.simplify(formula, binding, schema)

    def _static_test(self, formula: Formula) -> Check:
        """Whether the static ``formula`` holds under a binding (what :meth:`simplify` computes for it)."""
        if isinstance(formula, AtomFormula):
            return fact_check(formula.predicate, formula.terms, self.static_facts, True)
        if isinstance(formula, Equals):
            return equality_check(formula.left, formula.right, True)
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
    ) -> list[Op]:
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
            if isinstance(body, WhenEffect) and is_static(body.condition, self.fluent):
                # The guard's join yields only bindings under which the condition holds.
                guard, body = body.condition, body.body
            names = frozenset(v.name for v in effect.variables)
            ops = self._compile_effect(body, schema, outer | names, costs_only)
            if costs_only and not ops:
                return []
            return [_Forall(self.joiner, schema, effect.variables, guard, tuple(ops), outer)]
        return [self._cost_op(effect, schema)]

    def _when_op(self, effect: WhenEffect, schema: ActionSchema, outer: frozenset[str], costs_only: bool) -> list[Op]:
        body = tuple(self._compile_effect(effect.body, schema, outer, costs_only))
        if costs_only and not body:
            return []
        condition = effect.condition
        if not is_static(condition, self.fluent):
            # A condition over fluents: a case of the binding's effects (see hbtp.domains.alternatives).
            # Its static conjuncts (``(CONNECTED ?to ?c)`` under a forall) are tested first, quickly.
            simplify, name = self.simplify, schema.name
            static: Callable[[Binding], bool] | None = None
            if isinstance(condition, And):
                fluent: list[Formula] = []
                known: list[Formula] = []
                for part in condition.parts:
                    (known if is_static(part, self.fluent) else fluent).append(part)
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

    def _cost_op(self, effect: CostEffect, schema: ActionSchema) -> Op:
        amount = effect.amount
        if isinstance(amount, int):
            return FixedCost(amount)
        predicate, args, numeric = amount.predicate, getter(amount.terms), self.numeric

        def cost(binding: Binding, effects: Effects) -> None:
            key = (predicate, args(binding))
            if key not in numeric:
                raise UndefinedCost(f"({' '.join((key[0], *key[1]))})")
            value = numeric[key]
            if value < 0:
                raise GroundingError(
                    f"action {schema.name!r}: cost ({' '.join((key[0], *key[1]))}) is {value}, "
                    "and action costs must not be negative"
                )
            effects.costs.append(value)

        return cost

    def simplify(self, formula: Formula, binding: Binding, schema: ActionSchema, positive: bool = True) -> Value:
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
            return self.simplify(formula.operand, binding, schema, not positive)
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
            raise _not_strips(schema, formula.line, "a quantifier left unexpanded")  # expand_domain removes them
        values: list[list[Key] | Choice] = []
        for part, polarity in parts:
            value = self.simplify(part, binding, schema, polarity)
            if value is not conjunctive and isinstance(value, bool):
                return value  # False decides a conjunction, True a disjunction
            if not isinstance(value, bool):
                values.append(value)
        if not values:
            return conjunctive
        return conjoined(values, schema.name) if conjunctive else disjoined(values, schema.name)


def _not_strips(schema: ActionSchema, line: int, what: str) -> GroundingError:
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

    __slots__ = ("body", "guard", "joiner", "key_names", "memo", "names", "outer", "schema", "split", "terms")

    def __init__(
        self,
        joiner: Joiner,
        schema: ActionSchema,
        variables: tuple[TypedName, ...],
        guard: Formula | None,
        body: tuple[Op, ...],
        outer: frozenset[str],
    ) -> None:
        self.joiner = joiner
        self.schema = schema
        self.guard = (variables, flatten_and(guard) if guard is not None else [])
        self.body = body
        self.outer = outer
        self.names = tuple(v.name for v in variables)
        mentioned = set(self.names) | (_variables(guard) if guard is not None else set())
        self.key_names = tuple(sorted(mentioned))
        self.memo: dict[tuple[str | None, ...], list[_Segment]] | None = None if outer <= mentioned else {}
        self.terms: list[list[StaticLiteral]] | None = None
        self.split: list[_Segment] | None = None

    def segments(self, binding: Binding) -> list[_Segment]:
        """The values of the variables under each binding the guard allows, extending ``binding``,
        in runs whose values must also pass the run's checks."""
        variables, parts = self.guard
        terms = self.terms
        if terms is None:
            # First use: the guard's normal form (refused here when too large), then how to join it.
            terms = self.terms = dnf_checked(And(tuple(parts)), self.schema)
            self.split = self._split(terms, variables)
        if self.split is not None:
            return self.split
        memo = self.memo
        key = tuple([binding.get(name) for name in self.key_names]) if memo is not None else ()
        found = memo.get(key) if memo is not None else None
        if found is None:
            names, joined = self.names, self.joiner.bindings(terms, variables, binding)
            found = [([tuple([full[n] for n in names]) for full in joined], ())]
            if memo is not None:
                memo[key] = found
        return found

    def _split(self, terms: list[list[StaticLiteral]], variables: tuple[TypedName, ...]) -> list[_Segment] | None:
        """Each term's bindings joined without the outer binding, with the checks of its literals that
        mention outer variables; ``None`` when a positive literal mentions one (or a variable of the
        forall hides an outer one), as a join step would then depend on the outer binding."""
        if self.outer & set(self.names):
            return None
        inner_terms: list[list[StaticLiteral]] = []
        outer_checks: list[tuple[Check, ...]] = []
        for term in terms:
            inner: list[StaticLiteral] = []
            checks: list[Check] = []
            for literal in term:
                used, check = self.joiner.literal_check(literal)
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
            ([tuple([full[n] for n in names]) for full in self.joiner.join(inner, variables, {})], checks)
            for inner, checks in zip(inner_terms, outer_checks, strict=True)
        ]

    def __call__(self, binding: Binding, effects: Effects) -> None:
        names, body = self.names, self.body
        extended = binding.copy()
        for values, checks in self.segments(binding):
            self.joiner.tick(1 + len(values))
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


def is_static(formula: Formula, fluent: set[str]) -> bool:
    """Whether ``formula`` mentions no ``fluent`` predicate (and no quantifier)."""
    if isinstance(formula, AtomFormula):
        return formula.predicate not in fluent
    if isinstance(formula, Equals):
        return True
    if isinstance(formula, Not):
        return is_static(formula.operand, fluent)
    if isinstance(formula, And | Or):
        return all(is_static(p, fluent) for p in formula.parts)
    if isinstance(formula, Exists | Forall):
        return False  # expand_domain removes them; never joined as static
    return is_static(formula.antecedent, fluent) and is_static(formula.consequent, fluent)


def split_precondition(formula: Formula, fluent: set[str]) -> tuple[list[Formula], list[Formula]]:
    """The static conjuncts of a precondition, and the others (over ``fluent`` predicates)."""
    conjuncts = flatten_and(formula)
    static = [c for c in conjuncts if is_static(c, fluent)]
    other = [c for c in conjuncts if not is_static(c, fluent)]
    return static, other


def reaching_atoms(fluent_parts: Iterable[Formula]) -> list[AtomFormula]:
    """The positive fluent atoms of a precondition's conjuncts: what relaxed reachability joins."""
    return [part for part in fluent_parts if isinstance(part, AtomFormula)]


def flatten_and(formula: Formula) -> list[Formula]:
    """The conjuncts of ``formula``, nested conjunctions flattened."""
    if isinstance(formula, And):
        out: list[Formula] = []
        for part in formula.parts:
            out.extend(flatten_and(part))
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


def dnf_checked(formula: Formula, schema: ActionSchema) -> list[list[StaticLiteral]]:
    """:func:`_dnf`, refusing a static condition whose normal form would exceed :data:`MAX_DNF_TERMS`."""
    size = _dnf_size(formula)
    if size > MAX_DNF_TERMS:
        raise GroundingError(
            f"action {schema.name!r}: its static condition has {size:,} cases in disjunctive normal form, "
            f"more than the limit of {MAX_DNF_TERMS:,}"
        )
    return _dnf(formula)


def _dnf(formula: Formula, positive: bool = True) -> list[list[StaticLiteral]]:
    """Disjunctive normal form of a static formula (negations pushed to the literals)."""
    if isinstance(formula, AtomFormula | Equals):
        return [[StaticLiteral(formula, positive)]]
    if isinstance(formula, Not):
        return _dnf(formula.operand, not positive)
    if isinstance(formula, Imply):
        return _dnf(Or((Not(formula.antecedent), formula.consequent)), positive)
    assert not isinstance(formula, Exists | Forall), "quantifiers are expanded first"
    conjunctive = isinstance(formula, And) == positive
    children = [_dnf(part, positive) for part in formula.parts]
    if not conjunctive:
        return [term for child in children for term in child]
    terms: list[list[StaticLiteral]] = [[]]
    for child in children:
        terms = [left + right for left in terms for right in child]
    return terms


def _subst(term: str, binding: Binding) -> str:
    return binding[term] if is_variable(term) else term


def _atom_op(atom: AtomFormula, positive: bool, intern: Callable[[Key, Key], Key]) -> Op:
    predicate, args = atom.predicate, getter(atom.terms)
    if positive:
        return lambda binding, effects: effects.add.add(intern(key := (predicate, args(binding)), key))
    return lambda binding, effects: effects.delete.add(intern(key := (predicate, args(binding)), key))
