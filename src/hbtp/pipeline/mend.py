"""A goal's literals replaced one by one: the step the checks that mend a taught model's answer
against its instruction share (:mod:`hbtp.pipeline.polarity`, :mod:`hbtp.pipeline.unspoken`)."""

from __future__ import annotations

import logging
from collections.abc import Callable

from hbtp.domains.scenarios import Scenario
from hbtp.errors import InputError
from hbtp.logic.atoms import Atom
from hbtp.logic.goals import Dnf, format_goal, parse_goal

log = logging.getLogger(__name__)

#: Given a literal and its conjunction, the literal to put in its place, or ``None`` to keep it.
Replacement = Callable[[Atom, tuple[Atom, ...]], Atom | None]


def known(scenario: Scenario, literal: Atom) -> bool:
    """Whether ``literal``'s atom is one of ``scenario``'s: a literal a replacement may give."""
    try:
        scenario.task.atom_id(literal.positive)
    except InputError:
        return False
    return True


def parsed(goal: str) -> Dnf | None:
    """The terms of ``goal``, or ``None`` when it does not parse: a check leaves such a goal as it
    is, for :func:`hbtp.pipeline.instruct.check_goal` to judge."""
    try:
        return parse_goal(goal)
    except InputError:
        return None


def literals_replaced(goal: str, replacement: Replacement, why: str) -> str:
    """``goal`` with each literal that ``replacement`` gives another for replaced by it; a literal of a
    conjunction, or an alternative, that becomes one already there is kept once. The changes are
    logged with ``why``. A goal that does not parse is returned as it is (the checks judge it)."""
    terms = parsed(goal)
    if terms is None:
        return goal
    mended: dict[frozenset[Atom], tuple[Atom, ...]] = {}
    moved: list[str] = []
    for term in terms:
        new = [replacement(literal, term) or literal for literal in term]
        moved += [f"{old.underscored} -> {now.underscored}" for old, now in zip(term, new, strict=True) if old != now]
        kept = tuple(dict.fromkeys(new))
        mended.setdefault(frozenset(kept), kept)
    if not moved:
        return goal
    log.info("instruction: %s (%s)", ", ".join(moved), why)
    return format_goal(list(mended.values()))


__all__ = ["Replacement", "known", "literals_replaced", "parsed"]
