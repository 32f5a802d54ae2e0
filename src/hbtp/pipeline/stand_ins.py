"""An object the instruction never names, written where it names one the goal leaves out: "Bright
table 6 is still waiting for their milk drink" read as ``On_MilkDrink_Table1``.

A taught model knows which literal is asked for and now and then misreads one of its objects (a
table's number, one container for another). In a goal read from an instruction that names no thing
the world lacks, a literal with exactly one object that the instruction never names (by the world's
words for it or its spelling, :func:`hbtp.pipeline.clauses.spoken_objects`) takes in its place an
object the instruction names and the goal leaves out, when exactly one such object makes it a
literal of the world (``On_MilkDrink_BrightTable6``; "put the milk in the fridge or on the kitchen
table" read as ``IsIn_milk_kitchencabinet | IsOn_milk_fryingpan`` becomes ``IsIn_milk_fridge |
IsOn_milk_kitchentable``); an object placed is not placed again. A literal that repeats another of
its conjunction but for that object, named in the other (``IsOn_towel_cabinet`` beside
``IsOn_crayons_cabinet``: :func:`hbtp.pipeline.clauses.has_twin`), is one more item of a list the
model went on with, not a misread: it is left for the check of unsaid literals, which drops it.
Where the instruction names a thing the world lacks, an unnamed object may stand in for it, and the
goal is left for the substitution check (:func:`hbtp.pipeline.instruct.substituted`).
"""

from __future__ import annotations

import logging

from hbtp.domains.scenarios import Scenario
from hbtp.domains.words import Words, words_for
from hbtp.logic.atoms import Atom
from hbtp.logic.goals import format_goal
from hbtp.pipeline.clauses import has_twin, objects_of, spoken_objects
from hbtp.pipeline.mend import parsed

log = logging.getLogger(__name__)


def named_in_place(scenario: Scenario, text: str, goal: str) -> str:
    """``goal`` with each literal's one object that ``text`` never names replaced by the one object
    it names, that the goal leaves out, which makes a literal of the world (see the module
    docstring); a goal that does not parse is returned as it is."""
    words = words_for(scenario)
    terms = parsed(goal)
    if terms is None:
        return goal
    if words.lacking_in(text):
        return goal
    spoken = spoken_objects(words, text)
    unused = sorted(spoken - {x for term in terms for literal in term for x in objects_of(words, literal)})
    placed: list[str] = []
    read = []
    for term in terms:
        new = []
        for literal in term:
            extra = has_twin(words, literal, term, spoken)  # one more of a list: left for the unsaid check
            better = _in_place(scenario, words, literal, spoken, unused) if unused and not extra else None
            if better is not None:
                placed.append(f"{literal.underscored} -> {better.underscored}")
                unused = [x for x in unused if x not in better.args]
            new.append(better or literal)
        read.append(tuple(new))
    if not placed:
        return goal
    log.info("instruction: %s (objects the instruction names, in place of others)", ", ".join(placed))
    return format_goal(read)


def _in_place(
    scenario: Scenario, words: Words, literal: Atom, spoken: frozenset[str], unused: list[str]
) -> Atom | None:
    """``literal`` with its one object outside ``spoken`` replaced by the one of ``unused`` that makes
    it a literal of the world, or ``None``."""
    about = objects_of(words, literal)
    strangers = [at for at, x in enumerate(literal.args) if x in about and x not in spoken]
    if len(strangers) != 1:
        return None
    at = strangers[0]
    atoms = scenario.task.atom_ids
    fits = [Atom(literal.predicate, (*literal.args[:at], x, *literal.args[at + 1 :])) for x in unused]
    fits = [atom for atom in fits if atom in atoms]
    if len(fits) != 1:
        return None
    return fits[0].negate() if literal.negated else fits[0]


__all__ = ["named_in_place"]
