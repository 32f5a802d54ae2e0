"""Compile ``exists`` and ``forall`` conditions away over a problem's finite objects.

``(exists (?v - t) body)`` becomes the disjunction, and ``(forall (?v - t) body)`` the conjunction,
of ``body`` with ``?v`` replaced by each object of type ``t`` (constants included), as Fast
Downward's translator does for quantifiers it cannot keep. Variables the quantifier does not bind
(an action's parameters) are left for the grounder to bind; an inner quantifier that binds the same
name hides the outer one. The expansion is bounded: a formula that would grow past
:data:`MAX_EXPANDED_LITERALS` literals is refused with a one-line :class:`~hbtp.errors.GroundingError`.
"""

from __future__ import annotations

import dataclasses
import itertools
from collections.abc import Callable, Mapping, Sequence

from hbtp.domains.lifted import (
    ActionSchema,
    And,
    AndEffect,
    AtomFormula,
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
    TypedName,
    WhenEffect,
)
from hbtp.errors import GroundingError

__all__ = ["MAX_EXPANDED_LITERALS", "expand_domain", "expand_formula", "has_quantifier"]

#: The most literals one condition may have once its quantifiers are expanded.
MAX_EXPANDED_LITERALS = 200_000

#: The objects (and constants) a typed variable ranges over.
ObjectsOf = Callable[[TypedName], Sequence[str]]


def has_quantifier(formula: Formula) -> bool:
    """Whether ``formula`` contains ``exists`` or ``forall``."""
    if isinstance(formula, Exists | Forall):
        return True
    if isinstance(formula, Not):
        return has_quantifier(formula.operand)
    if isinstance(formula, And | Or):
        return any(has_quantifier(part) for part in formula.parts)
    if isinstance(formula, Imply):
        return has_quantifier(formula.antecedent) or has_quantifier(formula.consequent)
    return False


def expand_formula(formula: Formula, objects_of: ObjectsOf, what: str = "a condition") -> Formula:
    """``formula`` without quantifiers (see the module docstring); ``what`` names it in errors."""
    if not has_quantifier(formula):
        return formula
    budget = [MAX_EXPANDED_LITERALS]
    return _expand(formula, {}, objects_of, budget, what)


def _expand(
    formula: Formula, mapping: Mapping[str, str], objects_of: ObjectsOf, budget: list[int], what: str
) -> Formula:
    """``formula`` with the variables in ``mapping`` replaced and its quantifiers expanded."""
    if isinstance(formula, AtomFormula):
        _spend(budget, what, formula.line)
        if not mapping:
            return formula
        return AtomFormula(formula.predicate, tuple(mapping.get(t, t) for t in formula.terms), formula.line)
    if isinstance(formula, Equals):
        _spend(budget, what, formula.line)
        return Equals(mapping.get(formula.left, formula.left), mapping.get(formula.right, formula.right), formula.line)
    if isinstance(formula, Not):
        return Not(_expand(formula.operand, mapping, objects_of, budget, what), formula.line)
    if isinstance(formula, And | Or):
        parts = tuple(_expand(part, mapping, objects_of, budget, what) for part in formula.parts)
        return type(formula)(parts, formula.line)
    if isinstance(formula, Imply):
        antecedent = _expand(formula.antecedent, mapping, objects_of, budget, what)
        return Imply(antecedent, _expand(formula.consequent, mapping, objects_of, budget, what), formula.line)
    names = [v.name for v in formula.variables]
    inner = {k: v for k, v in mapping.items() if k not in names}  # the quantifier hides outer names
    cases = tuple(
        _expand(formula.body, {**inner, **dict(zip(names, values, strict=True))}, objects_of, budget, what)
        for values in itertools.product(*(objects_of(v) for v in formula.variables))
    )
    return (Or if isinstance(formula, Exists) else And)(cases, formula.line)


def _spend(budget: list[int], what: str, line: int) -> None:
    budget[0] -= 1
    if budget[0] < 0:
        where = f" (line {line})" if line else ""
        raise GroundingError(
            f"{what}{where} has more than {MAX_EXPANDED_LITERALS:,} literals once its exists/forall are "
            "expanded over the objects"
        )


def _expand_effect(effect: Effect, objects_of: ObjectsOf, what: str) -> Effect:
    """``effect`` with the quantifiers of its ``when`` conditions expanded."""
    if isinstance(effect, AndEffect):
        return AndEffect(tuple(_expand_effect(part, objects_of, what) for part in effect.parts))
    if isinstance(effect, ForallEffect):
        return dataclasses.replace(effect, body=_expand_effect(effect.body, objects_of, what))
    if isinstance(effect, WhenEffect):
        condition = expand_formula(effect.condition, objects_of, what)
        return dataclasses.replace(effect, condition=condition, body=_expand_effect(effect.body, objects_of, what))
    return effect


def expand_domain(domain: Domain, objects_of: ObjectsOf) -> Domain:
    """``domain`` with the quantified conditions of its actions expanded (the same domain when it has none)."""
    actions: list[ActionSchema] = []
    changed = False
    for schema in domain.actions:
        where = f"{domain.source}:{schema.line}:{schema.column}: " if domain.source and schema.line else ""
        what = f"{where}action {schema.name!r}"
        precondition = expand_formula(schema.precondition, objects_of, f"{what}: the precondition")
        effect = _expand_effect(schema.effect, objects_of, f"{what}: a when condition")
        if precondition is not schema.precondition or effect != schema.effect:
            changed = True
            schema = dataclasses.replace(schema, precondition=precondition, effect=effect)
        actions.append(schema)
    return dataclasses.replace(domain, actions=tuple(actions)) if changed else domain
