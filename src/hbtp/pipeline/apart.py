"""Literals about two things the instruction never names together: "put the wine glass on the
bookshelf, open the magazine, and make sure the candle is off" read with ``IsOn_candle_bookshelf``.

A taught model reading a long instruction now and then ties a thing of one clause to a thing of
another. A positive literal about two things is *apart* when both are named and no span of the
instruction names both (:func:`hbtp.pipeline.clauses.list_spans`: cut at punctuation, "but",
"then", "so", "while"; lists kept whole, across commas too), nor one of them and, by "it" or
"them" (or "there"), the other one named in the span before (:func:`hbtp.pipeline.clauses.readings`).
Such a literal becomes

* the same kind about the thing kept and the other thing of the one clause that says its kind, in
  words not all plain ("put ... on", not "on": "... with the milk beside the plate on the table"
  may mean another table), and names one of its things beside one thing more ("put the pancake in
  the frying pan, put the pan on the stove": ``IsOn_pancake_stove`` becomes
  ``IsOn_fryingpan_stove``), else
* the one kind about one thing that the spans naming just one of its things say ("make sure the
  candle is off": ``IsSwitchedOff_candle``), when no span of those negates, and not a fact about
  the robot itself;

when it makes a literal of the world that its conjunction does not hold yet, and whose thing left
out another literal of the conjunction holds (nothing named is lost), and exactly one does.
Otherwise it is kept. A predicate whose words are made up from its PDDL name is never judged.
"""

from __future__ import annotations

from collections.abc import Sequence

from hbtp.domains.scenarios import Scenario
from hbtp.domains.words import Words, words_for
from hbtp.logic.atoms import Atom
from hbtp.pipeline.clauses import (
    PLAIN,
    clauses,
    in_order,
    list_spans,
    negating,
    objects_of,
    phrasing_runs,
    readings,
    says,
    world_objects,
)
from hbtp.pipeline.mend import known, literals_replaced


def apart_mended(scenario: Scenario, text: str, goal: str) -> str:
    """``goal`` with each literal about two things no span of ``text`` names together replaced as
    the module docstring says; a goal that does not parse is returned as it is."""
    words = words_for(scenario)
    world = world_objects(scenario)
    pieces = [(said, words.named_in(" ".join(said)) & world) for said in list_spans(words, text)]
    together = _together(pieces)
    named = {x for _, these in pieces for x in these}
    parts = [(said, words.named_in(" ".join(said)) & world) for said in clauses(text)]

    def instead(literal: Atom, term: tuple[Atom, ...]) -> Atom | None:
        objects = objects_of(words, literal)
        if literal.negated or len(objects) != 2 or not objects <= named or words.phrasing(literal).derived:
            return None
        if any(objects <= these for these in together):
            return None
        others = {x for other in term if other != literal for x in objects_of(words, other)}
        for found in (_swapped(words, literal, parts), _alone(scenario, words, literal, pieces)):
            fits = [
                made
                for made in found
                if made not in term and known(scenario, made) and objects - objects_of(words, made) <= others
            ]
            if fits:
                return fits[0] if len(fits) == 1 else None
        return None

    return literals_replaced(goal, instead, "its things are never named together")


def _together(pieces: Sequence[tuple[tuple[str, ...], frozenset[str]]]) -> list[frozenset[str]]:
    """The sets of things each piece may be about: those it names, with one named in the piece
    before when it says "it", "them" or "there" ("... at the bar; have a dessert waiting there")."""
    found: list[frozenset[str]] = []
    before: frozenset[str] = frozenset()
    for said, named in pieces:
        found += readings(named, tuple("it" if word == "there" else word for word in said), before)
        before = named or before
    return found


def _swapped(words: Words, literal: Atom, parts: Sequence[tuple[tuple[str, ...], frozenset[str]]]) -> list[Atom]:
    """``literal`` with one thing put in the place of the other, for each clause of ``parts`` that
    says its kind in words not all plain ("put ... on", not "on") and names exactly one of its things
    and one thing more."""
    objects = objects_of(words, literal)
    runs = [run for run in phrasing_runs(words.phrasing(literal)) if set(run) - PLAIN]
    found = []
    for said, named in parts:
        kept, more = named & objects, named - objects
        if len(named) == 2 and len(kept) == 1 and any(in_order(run, said) for run in runs):
            (thing,), (other,) = kept, more
            args = tuple(other if x in objects and x != thing else x for x in literal.args)
            found.append(Atom(literal.predicate, args))
    return list(dict.fromkeys(found))


def _alone(
    scenario: Scenario, words: Words, literal: Atom, pieces: Sequence[tuple[tuple[str, ...], frozenset[str]]]
) -> list[Atom]:
    """The literals of one thing of ``literal`` (not about the robot) that the spans naming just that
    thing say, unless one of those spans negates."""
    found = []
    for thing in sorted(objects_of(words, literal)):
        own = [said for said, named in pieces if named == {thing}]
        if any(negating(said) for said in own):
            return []
        found += [
            made
            for predicate, width in sorted(scenario.task.predicates.items())
            if width == 1
            for made in (Atom(predicate, (thing,)),)
            if not words.phrasing(made).derived
            and not words.about_robot(made)
            and any(says(words, made, said) for said in own)
        ]
    return list(dict.fromkeys(found))


__all__ = ["apart_mended"]
