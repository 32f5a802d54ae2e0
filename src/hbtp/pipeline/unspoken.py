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
new) is left out (:func:`unspoken_dropped`). A predicate whose words are made up from its PDDL name
(a world without words) is never judged, nor is a literal about no object.
"""

from __future__ import annotations

import logging
from collections.abc import Sequence

from hbtp.domains.scenarios import Scenario
from hbtp.domains.words import SLOT, Words, words_for
from hbtp.errors import InputError
from hbtp.logic.atoms import Atom
from hbtp.logic.goals import format_goal, parse_goal
from hbtp.pipeline.clauses import in_order, objects_of, phrasing_runs, tokens

log = logging.getLogger(__name__)


def unspoken_dropped(scenario: Scenario, text: str, goal: str) -> str:
    """``goal`` without the literals of its conjunctions whose kind of fact ``text`` never speaks of
    and whose objects other literals of their conjunction hold (see the module docstring); a goal
    that does not parse is returned as it is."""
    try:
        terms = parse_goal(goal)
    except InputError:
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


def _unspoken(words: Words, said: Sequence[str], literal: Atom, term: Sequence[Atom]) -> bool:
    """Whether ``literal`` of the conjunction ``term`` names nothing its other literals do not, and
    its phrasing, read from the words file, has no run of words that ``said`` says in order."""
    phrasing = words.phrasing(literal)
    objects = objects_of(words, literal)
    if phrasing.derived or not objects or len(term) < 2:
        return False
    others = {x for other in term if other != literal for x in objects_of(words, other)}
    undo = [tokens(SLOT.sub(" ", deed)) for deed in phrasing.undo]
    return objects <= others and not any(in_order(run, said) for run in (*phrasing_runs(phrasing), *undo))


__all__ = ["unspoken_dropped"]
