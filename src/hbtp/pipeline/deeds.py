"""Deeds an instruction asks for that a goal leaves out: "load the dish bowl into the dishwasher
and run it" read as ``IsIn_dishbowl_dishwasher`` alone.

A taught model reading a long instruction now and then stops before its last deed. A clause of the
instruction (:func:`hbtp.pipeline.clauses.clauses`) with no negation word *asks unanswered* when it
says, in words not all plain ("run", "switch on", not a bare "on"), a literal of the world about
things it names (or, by "it" or "them", things the clause before named: "run it" after "... into the
dishwasher"; a thing said short for one named before may be that one,
:func:`hbtp.pipeline.referents.said_short`), and no literal of the goal, of either sign, is about
those things with words the clause says. Words inside a name of a thing say nothing ("a slice of
bread" asks for no cut), literals about the robot itself or about a part of things ("shut the
door" of a microwave) are not offered. :func:`unanswered` gives, for each such clause, the literals
it says; the goal is then continued with one of them (the model chooses when there are several:
:func:`hbtp.pipeline.instruct.goal_from_instruction`), which the checks judge as any answer.
"""

from __future__ import annotations

from collections.abc import Sequence

from hbtp.domains.scenarios import Scenario
from hbtp.domains.words import Words, spoken_words, words_for
from hbtp.logic.atoms import Atom
from hbtp.pipeline.clauses import (
    PLAIN,
    clauses,
    in_order,
    negating,
    objects_of,
    phrasing_runs,
    readings,
    says,
    world_objects,
)
from hbtp.pipeline.referents import said_short


def unanswered(scenario: Scenario, text: str, term: Sequence[Atom]) -> list[tuple[Atom, ...]]:
    """For each clause of ``text`` that asks unanswered by the conjunction ``term`` (see the module
    docstring), the world's positive literals it says, in the world's order."""
    words = words_for(scenario)
    world = world_objects(scenario)
    short = said_short(words, text, world)[0]
    parts = words.parts()
    atoms = [
        a
        for a in scenario.task.atoms
        if not a.negated and a.predicate in scenario.task.predicates and not words.about_robot(a)
        and not {x.lower() for x in a.args} & parts
    ]  # fmt: skip
    found: list[tuple[Atom, ...]] = []
    before: frozenset[str] = frozenset()
    for said in clauses(text):
        named = words.named_in(" ".join(said)) & world
        about = [these for these in readings(named, said, before) if these]
        about += [meant for these in about if (meant := frozenset(short.get(x, x) for x in these)) != these]
        before = named or before
        if not about or negating(said) or any(_answers(words, literal, said, about) for literal in term):
            continue
        bare = _unnamed(words, said)
        offered = tuple(a for a in atoms if _asked(words, a, bare, about) and a not in term)
        if offered:
            found.append(offered)
    return found


def _answers(words: Words, literal: Atom, said: Sequence[str], about: Sequence[frozenset[str]]) -> bool:
    """Whether ``literal`` (either sign) is about things the clause ``said`` may be about, with words it says."""
    objects = objects_of(words, literal)
    return bool(objects) and any(objects <= these for these in about) and says(words, literal, said)


def _unnamed(words: Words, said: Sequence[str]) -> tuple[str, ...]:
    """The words of the clause ``said`` that are not in a name of a thing ("slice" of "a slice of
    bread" says no cut), articles aside."""
    text = " ".join(said)
    inside = {at for start, width, _ in words.named_at(text) for at in range(start, start + width)}
    return tuple(word for at, word in enumerate(spoken_words(text)) if at not in inside)


def _asked(words: Words, atom: Atom, said: Sequence[str], about: Sequence[frozenset[str]]) -> bool:
    """Whether the clause ``said`` asks for ``atom``: about all of the things of one of its readings,
    said in words not all plain."""
    phrasing = words.phrasing(atom)
    if phrasing.derived or objects_of(words, atom) not in about:
        return False
    runs = (
        tuple(w for w in run if w in spoken)
        for run in phrasing_runs(phrasing)
        for spoken in (set(spoken_words(" ".join(run))),)
    )
    return any(in_order(run, said) for run in runs if set(run) - PLAIN)


__all__ = ["unanswered"]
