"""Grounding's estimate stage: a static bound on the number of ground actions, and the limit on it.

Gets the :class:`~hbtp.domains.ground_context.Prepared` task; gives, per action schema, an upper
bound of the number of its ground actions (the join's size: per static atom, at most its number of
facts; per remaining parameter, the objects of its type), and :func:`check_size`'s refusal when their
sum exceeds the limit (``max_ground_actions``, by default :func:`ground_actions_limit`; a ground
action takes about 1-2 KB of memory). Then only what is reachable from s0 is grounded
(:mod:`hbtp.domains.ground_reach`).
"""

from __future__ import annotations

import math
import os

from hbtp.domains.ground_compile import dnf_checked, split_precondition
from hbtp.domains.ground_context import Prepared
from hbtp.domains.ground_join import StaticLiteral
from hbtp.domains.lifted import ActionSchema, And, AtomFormula, Equals, TypedName, is_variable
from hbtp.errors import InputError

#: The default bound on the number of ground actions (see the module docstring).
MAX_GROUND_ACTIONS = 1_000_000
LIMIT_VARIABLE = "HBTP_MAX_GROUND_ACTIONS"


def ground_actions_limit() -> int:
    """The default bound on ground actions: ``$HBTP_MAX_GROUND_ACTIONS`` when set, else :data:`MAX_GROUND_ACTIONS`."""
    text = os.environ.get(LIMIT_VARIABLE, "").strip()
    if not text:
        return MAX_GROUND_ACTIONS
    if not text.isascii() or not text.isdigit() or int(text) < 1:
        raise InputError(f"{LIMIT_VARIABLE} must be a whole number of at least 1, not {text!r}")
    return int(text)


def check_size(prepared: Prepared, limit: int) -> str | None:
    """Why the estimated number of ground actions exceeds ``limit`` (``None`` when it does not)."""
    actions = prepared.domain.actions
    estimates = [(estimate(prepared, schema), -index) for index, schema in enumerate(actions)]
    total = sum(estimate for estimate, _ in estimates)
    if total <= limit:
        return None
    largest, index = max(estimates)
    schema = actions[-index]
    counts = " x ".join(str(len(prepared.domain_of(p))) for p in schema.parameters) or "1"
    variables = " ".join(p.name for p in schema.parameters)
    return (
        f"up to {total:,} actions, more than the limit of {limit:,} "
        f"(max_ground_actions, or {LIMIT_VARIABLE} for the command line): {schema.name}({variables}) "
        f"alone may have {largest:,} ({counts} candidate objects)"
    )


def estimate(prepared: Prepared, schema: ActionSchema) -> int:
    """An upper bound of the number of ground actions of ``schema`` (see the module docstring)."""
    static_parts, _ = split_precondition(schema.precondition, prepared.fluent)
    params = schema.parameters
    everything = math.prod(len(prepared.domain_of(p)) for p in params)
    terms = dnf_checked(And(tuple(static_parts)), schema)
    total = 0
    for term in terms:
        total += _estimate_term(prepared, term, params)
        if total >= everything:
            return everything
    return total


def _estimate_term(prepared: Prepared, term: list[StaticLiteral], params: tuple[TypedName, ...]) -> int:
    candidates = {p.name: len(prepared.domain_of(p)) for p in params}
    for lit in term:
        formula = lit.formula
        if lit.positive and isinstance(formula, Equals):
            for variable, other in ((formula.left, formula.right), (formula.right, formula.left)):
                if is_variable(variable) and not is_variable(other) and variable in candidates:
                    candidates[variable] = min(candidates[variable], 1)
    static_index = prepared.static_index
    positives = [lit.formula for lit in term if lit.positive and isinstance(lit.formula, AtomFormula)]
    positives.sort(key=lambda atom: len(static_index.get(atom.predicate, ())))
    bound: set[str] = set()
    size = 1
    for atom in positives:
        new = [t for t in dict.fromkeys(atom.terms) if is_variable(t) and t not in bound]
        facts = len(static_index.get(atom.predicate, ()))
        if not facts:
            return 0
        if new:
            size *= min(facts, math.prod(candidates.get(v, facts) for v in new))
            bound.update(new)
    for name, count in candidates.items():
        if name not in bound:
            size *= count
    return size
