"""A goal's alternatives grouped as its instruction joins their objects: "the juice or a soft drink"
read as ``On_Juice_Table6 & On_Softdrink_Table6``, "a coffee and a dessert, or else the chips" as
three alternatives.

A taught model writes the literals asked for but now and then joins them with the wrong connective.
Two positive literals of the goal that are one another but for one object (*twins*: ``On_Juice_T``
and ``On_Softdrink_T``) are said by naming those two objects. The words between two names said one
after the other (the other objects of the twins aside) join them with "or" or with "and"; words
that say neither join them with the next pair's connective, as in a list ("the cup, the plate or
the bowl"); numbers that go on a numbered name ("tables 1 and 2") join nothing. Where every such
pair of the two objects is joined by "or" alone, twins in one conjunction are alternatives: the
conjunction becomes one for each twin so joined to another (directly or along a list), without the
others. Where every pair is joined by "and" alone, twins in two alternatives that are the same but
for them are one conjunction. Negated twins are left as they are ("don't switch on the TV or the
radio" asks for neither). Each step is taken while one applies, conjunctions split first.
"""

from __future__ import annotations

import logging
from collections.abc import Sequence

from hbtp.domains.scenarios import Scenario
from hbtp.domains.words import Words, is_number, spoken_words, words_for
from hbtp.logic.atoms import Atom
from hbtp.logic.goals import format_goal
from hbtp.pipeline.clauses import objects_of, twin_at
from hbtp.pipeline.mend import parsed

log = logging.getLogger(__name__)

Mention = tuple[int, int, str]
Term = tuple[Atom, ...]


def regrouped(scenario: Scenario, text: str, goal: str) -> str:
    """``goal`` with its twins grouped as ``text`` joins their objects (see the module docstring); a
    goal that does not parse is returned as it is."""
    terms = parsed(goal)
    if terms is None:
        return goal
    words = words_for(scenario)
    about = {x for term in terms for literal in term for x in objects_of(words, literal)}
    said = spoken_words(text)
    mentions = [m for m in words.named_at(text) if m[2] in about]
    grouped = list(terms)
    for _ in range(sum(map(len, terms))):  # each step splits a conjunction or joins two alternatives
        step = _split(grouped, said, mentions, words) or _joined(grouped, said, mentions, words)
        if step is None:
            break
        grouped = step
    if grouped == list(terms):
        return goal
    log.info("instruction: alternatives grouped as said (%s -> %s)", goal, format_goal(grouped))
    return format_goal(grouped)


def _split(terms: list[Term], said: Sequence[str], mentions: Sequence[Mention], words: Words) -> list[Term] | None:
    """``terms`` with the first conjunction whose twins are said as alternatives split: one
    conjunction for each twin said with "or" to another, directly or through a list, without the
    others."""
    for at, term in enumerate(terms):
        for literal in term:
            group = [literal]
            for member in group:  # grows as twins joined to a member by "or" are found
                group += [x for x in term if x not in group and _connective(member, x, said, mentions, words) == "or"]
            if len(group) > 1:
                split = [tuple(x for x in term if x == one or x not in group) for one in group]
                return [*terms[:at], *split, *terms[at + 1 :]]
    return None


def _joined(terms: list[Term], said: Sequence[str], mentions: Sequence[Mention], words: Words) -> list[Term] | None:
    """``terms`` with the first two alternatives, the same but for twins said together, made one."""
    for at, term in enumerate(terms):
        for later in range(at + 1, len(terms)):
            for literal in term:
                for other in terms[later]:
                    alike = {x for x in term if x != literal} == {x for x in terms[later] if x != other}
                    if alike and _connective(literal, other, said, mentions, words) == "and":
                        merged = (*term, other)
                        return [*terms[:at], merged, *terms[at + 1 : later], *terms[later + 1 :]]
    return None


def _connective(
    literal: Atom, other: Atom, said: Sequence[str], mentions: Sequence[Mention], words: Words
) -> str | None:
    """The connective ("or" or "and") when ``literal`` and ``other`` are twins whose two objects
    every pair of names said one after the other joins so; else ``None``."""
    at = None if literal.negated else twin_at(literal, other)
    if at is None:
        return None
    pair = {literal.args[at], other.args[at]}
    if not pair <= objects_of(words, literal) | objects_of(words, other):
        return None
    shared = set(literal.args) - pair
    named = [m for m in mentions if m[2] not in shared]
    found = {_between(said, named, k) for k in range(len(named) - 1) if {named[k][2], named[k + 1][2]} == pair}
    return found.pop() if len(found) == 1 else None


def _between(said: Sequence[str], named: Sequence[Mention], k: int) -> str | None:
    """The connective of the words between the ``k``-th name and the next: "or" or "and" when they
    say one and not the other; the next pair's when they say neither (a list: "the TV, the radio or
    the lamp", "the TV should be on, the radio ought to be on or ..."); ``None`` after a number that
    goes on a numbered name."""
    while k + 1 < len(named):
        start, width, _ = named[k]
        if is_number(said[named[k + 1][0]]):
            return None  # "tables 1 and 2" lists names: the connective of the things asked is elsewhere
        between = set(said[start + width : named[k + 1][0]])
        either, both = "or" in between, "and" in between
        if either or both:
            return ("or" if either else "and") if either != both else None
        k += 1
    return None


__all__ = ["regrouped"]
