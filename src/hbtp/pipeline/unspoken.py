"""Literals whose kind of fact an instruction never speaks of: "could table 1 get a glass of water?"
read as ``On_Water_Table1 & IsClean_Table1``, "walk over to the candle" as ``IsNear_self_candle &
IsSwitchedOn_candle``.

A taught model that has written the literal asked for now and then goes on with a state of one of
its objects that nobody mentioned. Every phrasing of a predicate the words file gives
(:class:`hbtp.domains.words.Phrasing`) has words that say it: a state's complement ("clean",
"switched on"), a deed ("wipe", "turn on"), an unwanted deed ("leave on"), framing words aside
(:func:`hbtp.pipeline.clauses.phrasing_runs`). A literal is *unspoken* when none of those runs of
words comes, in order, anywhere in the instruction. In a conjunction of several literals, an
unspoken literal whose objects all belong to other literals of that conjunction (it names nothing
new) is left out (:func:`unspoken_dropped`). Before that, an unspoken literal about one object that
no other literal holds, and that the instruction lists with an object of another literal whose kind
it speaks of ("the rug and the toaster", "the chicken, the peach"), takes that literal's kind: "clean
the rug and the toaster" read as ``IsClean_rug & IsSwitchedOn_toaster`` becomes ``IsClean_rug &
IsClean_toaster`` (:func:`unspoken_listed`), when exactly one such literal of the world offers
itself. A positive literal whose words no clause naming its things says (not one naming just them
nor with others, nor one that may speak of them by a pronoun) takes the one predicate over the same
arguments whose words a clause naming just those things says, when it makes a literal of the world
("... and the bar of soap in the nightstand": ``IsOn_soap_nightstand`` becomes
``IsIn_soap_nightstand``; :func:`kind_as_said`). For a literal about one thing the pieces are
spans, lists kept whole ("turn off the TV, then ...": ``IsSwitchedOn_tv`` becomes
``IsSwitchedOff_tv``); a piece with a negation word, or that only names things (an item of a list),
leaves the literal as it is. A predicate whose words are made up from its PDDL name (a world without
words) is never judged, nor is a literal about no object.
"""

from __future__ import annotations

import logging
from collections.abc import Sequence
from itertools import pairwise

from hbtp.domains.scenarios import Scenario
from hbtp.domains.words import SLOT, Words, spoken_words, words_for
from hbtp.logic.atoms import Atom
from hbtp.logic.goals import format_goal
from hbtp.pipeline.clauses import (
    LISTING,
    PRONOUNS,
    clauses,
    ends_naming,
    in_order,
    negating,
    objects_of,
    phrasing_runs,
    says,
    spans,
    starts_naming,
    tokens,
    world_objects,
)
from hbtp.pipeline.mend import known, literals_replaced, parsed

log = logging.getLogger(__name__)


def unspoken_dropped(scenario: Scenario, text: str, goal: str) -> str:
    """``goal`` without the literals of its conjunctions whose kind of fact ``text`` never speaks of
    and whose objects other literals of their conjunction hold (see the module docstring); a goal
    that does not parse is returned as it is."""
    terms = parsed(goal)
    if terms is None:
        return goal
    words = words_for(scenario)
    said = tokens(text)
    kept, dropped = [], []
    for term in terms:
        spoken = tuple(literal for literal in term if not _unspoken(words, said, literal, term))
        dropped += [literal.underscored for literal in term if literal not in spoken]
        kept.append(spoken or term)
    if not dropped:
        return goal
    log.info("instruction: left out %s (a kind of fact the instruction never speaks of)", ", ".join(dropped))
    return format_goal(kept)


def unspoken_listed(scenario: Scenario, text: str, goal: str) -> str:
    """``goal`` with each unspoken literal about one object that ``text`` lists with an object of a
    literal it speaks of given that literal's kind (see the module docstring); a goal that does not
    parse is returned as it is."""
    words = words_for(scenario)
    said = tokens(text)
    listed = _listed(words, text)
    return literals_replaced(
        goal,
        lambda literal, term: _mate_kind(scenario, words, said, listed, literal, term),
        "a kind of fact the instruction never speaks of, listed",
    )


def kind_as_said(scenario: Scenario, text: str, goal: str) -> str:
    """``goal`` with each positive literal given the kind the instruction's own clause (span, for a
    literal about one thing) about its things says, where that never says its own (see the module
    docstring); a goal that does not parse is returned as it is."""
    words = words_for(scenario)
    cuts = (clauses(text), spans(text))
    world = world_objects(scenario)

    def said_instead(literal: Atom, _: tuple[Atom, ...]) -> Atom | None:
        objects = objects_of(words, literal)
        if literal.negated or not objects or words.phrasing(literal).derived:
            return None
        return _said_kind(scenario, words, cuts[len(objects) == 1], world, literal)

    return literals_replaced(goal, said_instead, "the kind its clause says")


def _said_kind(
    scenario: Scenario, words: Words, said: Sequence[tuple[str, ...]], world: frozenset[str], literal: Atom
) -> Atom | None:
    """The literal of another predicate over ``literal``'s arguments that the pieces of ``said``
    naming just its objects say, where they never say ``literal``'s own; ``None`` unless exactly one."""
    objects = objects_of(words, literal)
    named = [words.named_in(" ".join(clause)) & world for clause in said]
    own = [clause for clause, these in zip(said, named, strict=True) if these == objects]
    # "make sure the TV isn't off"; "the TV, the mouse and the radio plugged in": an item of a list
    if any(negating(clause) or _bare(words, clause) for clause in own):
        return None
    # its own kind may be said where they are named beside others ("the fridge and the TV plugged
    # in") or by a pronoun ("... or on top of it")
    near = [
        clause
        for clause, these in zip(said, named, strict=True)
        if objects <= these or (these <= objects and PRONOUNS & set(clause))
    ]
    # "get the microwave, the dishwasher and the stove open": a list goes on in the next piece
    near += [
        after
        for clause, after in pairwise(said)
        if ends_naming(words, clause) in objects and starts_naming(words, after)
    ]
    if not own or any(says(words, literal, clause) for clause in near):
        return None
    arity = len(literal.args)
    found = {
        made
        for predicate, width in scenario.task.predicates.items()
        if width == arity and predicate != literal.predicate
        for made in (Atom(predicate, literal.args),)
        if not words.phrasing(made).derived and any(says(words, made, clause) for clause in own)
    }
    fits = [made for made in found if known(scenario, made)]
    return fits[0] if len(fits) == 1 else None


def _bare(words: Words, clause: Sequence[str]) -> bool:
    """Whether ``clause`` says nothing but the names of things (articles and "and", "or" aside)."""
    text = " ".join(clause)
    said = spoken_words(text)
    return len(said) == sum(width for _, width, _ in words.named_at(text)) + sum(w in LISTING for w in said)


def _listed(words: Words, text: str) -> set[frozenset[str]]:
    """The pairs of objects ``text`` names one right after the other, or with "and" / "or" between."""
    said = spoken_words(text)
    named = words.named_at(text)
    return {
        frozenset((x, y))
        for (start, width, x), (after, _, y) in pairwise(named)
        if x != y and set(said[start + width : after]) <= LISTING
    }


def _mate_kind(
    scenario: Scenario,
    words: Words,
    said: Sequence[str],
    listed: set[frozenset[str]],
    literal: Atom,
    term: Sequence[Atom],
) -> Atom | None:
    """The literal of the world that ``literal`` becomes, given the kind of a literal of ``term``
    about an object listed with its one object; ``None`` unless exactly one offers itself."""
    objects = objects_of(words, literal)
    others = {x for other in term if other != literal for x in objects_of(words, other)}
    if len(objects) != 1 or objects <= others or not _unspoken_kind(words, said, literal):
        return None
    (thing,) = objects
    found = {
        Atom(other.predicate, (*other.args[:at], thing, *other.args[at + 1 :]), other.negated)
        for other in term
        if other != literal and not _unspoken_kind(words, said, other)
        for at, mate in enumerate(other.args)
        if frozenset((thing, mate)) in listed
    }
    fits = [made for made in found if known(scenario, made)]
    return fits[0] if len(fits) == 1 else None


def _unspoken(words: Words, said: Sequence[str], literal: Atom, term: Sequence[Atom]) -> bool:
    """Whether ``literal`` of the conjunction ``term`` names nothing its other literals do not, and
    its kind of fact is never spoken of in ``said`` (:func:`_unspoken_kind`)."""
    objects = objects_of(words, literal)
    if not objects or len(term) < 2:
        return False
    others = {x for other in term if other != literal for x in objects_of(words, other)}
    return objects <= others and _unspoken_kind(words, said, literal)


def _unspoken_kind(words: Words, said: Sequence[str], literal: Atom) -> bool:
    """Whether ``literal``'s phrasing, read from the words file, has no run of words that ``said``
    says in order (a phrasing made up from the PDDL name is never judged)."""
    phrasing = words.phrasing(literal)
    if phrasing.derived:
        return False
    undo = [tokens(SLOT.sub(" ", deed)) for deed in phrasing.undo]
    return not any(in_order(run, said) for run in (*phrasing_runs(phrasing), *undo))


__all__ = ["kind_as_said", "unspoken_dropped", "unspoken_listed"]
