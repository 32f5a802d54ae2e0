"""Grounding's join stage: binding an action's parameters.

Gets the :class:`~hbtp.domains.ground_context.Prepared` task's static facts (and, when only what is
reachable from s0 is grounded, the fluent facts reached so far) and a static condition in
disjunctive normal form (terms of :class:`StaticLiteral`); gives every binding under which a term
holds and, per action, its candidates: the bindings that the grounding's filter accepts and whose
fluent precondition is not false, with the fluent literals each requires.

Bindings are enumerated by joining the static facts that a term requires, so an action over 126
objects never tries all pairs blindly. Each join step looks its facts up in an index keyed by the
arguments already bound.
"""

from __future__ import annotations

import itertools
from collections.abc import Callable, Container, Iterable, Iterator, Sequence
from dataclasses import dataclass

from hbtp.domains.alternatives import Choice, Value, conjoined
from hbtp.domains.ground_context import ActionFilter, Binding, Check, Key, Prepared, Selection, Work
from hbtp.domains.lifted import OBJECT_TYPE, ActionSchema, AtomFormula, Equals, TypedName, is_variable

#: A compiled part of a fluent precondition, evaluated under a binding (see ``Compiler.simplify``).
FluentPart = Callable[[Binding], Value]
_Template = tuple[tuple[bool, str], ...]  # (is a variable, name) per argument


@dataclass(frozen=True, slots=True)
class StaticLiteral:
    """A static literal in a DNF term: an atom or an equality, possibly negated."""

    formula: AtomFormula | Equals
    positive: bool


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
    checks: tuple[Check, ...]


@dataclass(frozen=True, slots=True)
class _Plan:
    """How one DNF term is joined: equalities bind, ``checks`` filter, the steps extend, then the
    parameters still ``unbound`` range over their ``domains`` and ``last_checks`` filter."""

    equalities: tuple[Equals, ...]
    checks: tuple[Check, ...]
    steps: tuple[_Step, ...]
    unbound: tuple[str, ...]
    domains: tuple[tuple[str, ...], ...]
    last_checks: tuple[Check, ...]


class Joiner:
    """The joins of one grounding, with their indexes and plans kept from one join to the next.

    With ``reaching``, the fluent facts reached from s0 (:meth:`reach`) are joined like static facts.
    """

    def __init__(self, prepared: Prepared, work: Work, only: ActionFilter | None, reaching: bool) -> None:
        self.static_facts = prepared.static_facts
        self.static_index = prepared.static_index
        self.fluent = prepared.fluent
        self.domain_of = prepared.domain_of
        self.only = only
        self.tick = work.tick
        # With reaching: the fluent facts reached from s0 by predicate, joined like static facts.
        self.reached: dict[str, list[tuple[str, ...]]] | None = {} if reaching else None
        self.indexes: dict[tuple[str, tuple[int, ...]], dict[tuple[str, ...], list[tuple[str, ...]]]] = {}
        self.plans: dict[
            tuple[int, tuple[TypedName, ...], frozenset[str], frozenset[str] | None], tuple[list[StaticLiteral], _Plan]
        ] = {}

    def reach(self, keys: Sequence[Key]) -> None:
        """Join the fluent facts ``keys`` too from now on, after those reached before (in this order)."""
        assert self.reached is not None, "only a joiner made for reaching joins fluent facts"
        for predicate, args in keys:
            self.reached.setdefault(predicate, []).append(args)
        changed = {key[0] for key in keys}
        self.indexes = {k: v for k, v in self.indexes.items() if k[0] not in changed}

    def candidates(
        self,
        schema: ActionSchema,
        static: list[list[StaticLiteral]],
        fluent: tuple[FluentPart, ...],
        skip: Container[tuple[str, ...]],
    ) -> Iterator[tuple[tuple[str, ...], Binding, list[Key] | Choice]]:
        """Each binding (once) not in ``skip`` under which a term of ``static`` holds, that ``only``
        accepts and whose ``fluent`` precondition is not false, with the fluent literals it requires
        (a choice of alternatives when a disjunction over fluents remains)."""
        names, only, tick = tuple(p.name for p in schema.parameters), self.only, self.tick
        allowed = only.objects if isinstance(only, Selection) else None
        seen: set[tuple[str, ...]] = set()
        for binding in self.bindings(static, schema.parameters, {}, allowed):
            tick()
            key = tuple([binding[name] for name in names])
            if key in seen or key in skip:
                continue
            seen.add(key)
            if only is not None and not only(schema.name, key):
                continue
            pre: list[Key] = []
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

    def bindings(
        self,
        terms: list[list[StaticLiteral]],
        params: tuple[TypedName, ...],
        start: Binding,
        allowed: frozenset[str] | None = None,
    ) -> Iterator[Binding]:
        """Every binding of ``params`` (extending ``start``; each value in ``allowed`` when given)
        under which some term of ``terms`` holds."""
        for term in terms:
            yield from self.join(term, params, start, allowed)

    def join(
        self,
        term: list[StaticLiteral],
        params: tuple[TypedName, ...],
        start: Binding,
        allowed: frozenset[str] | None = None,
    ) -> Iterator[Binding]:
        """Every binding of ``params`` (extending ``start``; each value in ``allowed`` when given)
        under which ``term`` holds."""
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
        checks, names, tick = plan.last_checks, plan.unbound, self.tick
        for binding in partial:
            if not names:
                tick()
                if not checks or all(check(binding) for check in checks):
                    yield binding
                continue
            for values in itertools.product(*plan.domains):
                tick()
                full = binding.copy()
                full.update(zip(names, values, strict=True))
                if not checks or all(check(full) for check in checks):
                    yield full

    def _extend(self, step: _Step, partial: list[Binding]) -> list[Binding]:
        """The bindings of ``partial`` extended by each fact of ``step`` that agrees with them."""
        index = self._index(step.predicate, step.positions)
        lookup, new, same, checks, tick = step.lookup, step.new, step.same, step.checks, self.tick
        extended: list[Binding] = []
        if len(new) == 1 and not same:  # the usual case, made quicker
            ((variable, position),) = new
            for binding in partial:
                facts = index.get(lookup(binding), ())
                tick(1 + len(facts))
                for fact in facts:
                    grown = binding.copy()
                    grown[variable] = fact[position]
                    if not checks or all(check(grown) for check in checks):
                        extended.append(grown)
            return extended
        for binding in partial:
            facts = index.get(lookup(binding), ())
            tick(1 + len(facts))
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
        self, term: list[StaticLiteral], params: tuple[TypedName, ...], start: Binding, allowed: frozenset[str] | None
    ) -> _Plan:
        key = (id(term), params, frozenset(start), allowed)
        cached = self.plans.get(key)
        if cached is not None and cached[0] is term:
            return cached[1]
        plan = self._make_plan(term, params, set(start), allowed)
        self.plans[key] = (term, plan)
        return plan

    def _make_plan(
        self, term: list[StaticLiteral], params: tuple[TypedName, ...], bound: set[str], allowed: frozenset[str] | None
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
        pending = [self.literal_check(lit) for lit in term if not lit.positive or isinstance(lit.formula, Equals)]
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
            steps.append(_Step(atom.predicate, positions, getter(lookup), new, same, ready))
        unbound = [p for p in params if p.name not in joined]
        return _Plan(
            equalities=equalities,
            checks=checks,
            steps=tuple(steps),
            unbound=tuple(p.name for p in unbound),
            domains=tuple(_within(self.domain_of(p), allowed) for p in unbound),
            last_checks=tuple(check for _, check in pending),
        )

    def literal_check(self, literal: StaticLiteral) -> tuple[set[str], Check]:
        """The variables of ``literal`` and whether it holds under a binding."""
        formula = literal.formula
        if isinstance(formula, Equals):
            variables = {t for t in (formula.left, formula.right) if is_variable(t)}
            return variables, equality_check(formula.left, formula.right, literal.positive)
        variables = {t for t in formula.terms if is_variable(t)}
        return variables, fact_check(formula.predicate, formula.terms, self.static_facts, literal.positive)


def getter(terms: Iterable[str]) -> Callable[[Binding], tuple[str, ...]]:
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


def fact_check(predicate: str, terms: tuple[str, ...], facts: set[Key], positive: bool) -> Check:
    """Whether the atom of ``predicate`` over ``terms`` is (or, not ``positive``, is not) in ``facts``."""
    args = getter(terms)
    if positive:
        return lambda binding: (predicate, args(binding)) in facts
    return lambda binding: (predicate, args(binding)) not in facts


def equality_check(left: str, right: str, positive: bool) -> Check:
    """Whether ``left`` and ``right`` are (or, not ``positive``, are not) the same object."""
    first, second = getter((left, right)), positive

    def check(binding: Binding) -> bool:
        a, b = first(binding)
        return (a == b) == second

    return check


def _within(values: tuple[str, ...], allowed: frozenset[str] | None) -> tuple[str, ...]:
    return values if allowed is None else tuple(v for v in values if v in allowed)


def _member_check(variable: str, members: frozenset[str]) -> Check:
    return lambda binding: binding[variable] in members


def _ready(
    pending: list[tuple[set[str], Check]], bound: set[str]
) -> tuple[tuple[Check, ...], list[tuple[set[str], Check]]]:
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
