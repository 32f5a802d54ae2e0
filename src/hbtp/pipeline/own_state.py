"""Literals about the robot itself that an instruction never asks for: "someone at the second bar
wants a soft drink; could you leave one there?" read as ``On_Softdrink_Bar2 & RobotNear_Bar``.

A taught model has seen people ask for the robot's own state beside the world's ("... and keep the
cup in your hands"), and now and then adds such a literal where nobody asked: where it stands, what
it holds. A literal about the robot itself (:meth:`hbtp.domains.words.Words.about_robot`) is *said*
when one span of the instruction (:func:`hbtp.pipeline.clauses.spans`: a list keeps its verb) names
each of its objects ("it" may stand for one named before) and says one of its words (its phrasing's
state, deed or unwanted deed, :func:`hbtp.pipeline.clauses.phrasing_runs`, the plain "at" or "by"
of where it stands included): "go to the bar", "pick up the cup and the plate", "wait by table 1". In a
goal that also asks for something about the world, a positive literal about the robot that is not
said is left out (:func:`unasked_own_dropped`); an alternative left with nothing goes with it.
"""

from __future__ import annotations

import logging
from collections.abc import Sequence

from hbtp.domains.scenarios import Scenario
from hbtp.domains.words import Words, words_for
from hbtp.logic.atoms import Atom
from hbtp.logic.goals import format_goal
from hbtp.pipeline.clauses import in_order, objects_of, phrasing_runs, readings, spans, world_objects
from hbtp.pipeline.mend import parsed

log = logging.getLogger(__name__)


def unasked_own_dropped(scenario: Scenario, text: str, goal: str) -> str:
    """``goal`` without the positive literals about the robot itself that ``text`` does not say, when
    it asks for something about the world too (see the module docstring); a goal that does not
    parse is returned as it is."""
    terms = parsed(goal)
    if terms is None:
        return goal
    words = words_for(scenario)
    if all(words.about_robot(literal) for term in terms for literal in term):
        return goal
    said = spans(text)
    world = world_objects(scenario)
    kept: dict[frozenset[Atom], tuple[Atom, ...]] = {}
    dropped: list[str] = []
    for term in terms:
        asked = tuple(literal for literal in term if not _unasked(words, said, literal, world))
        dropped += [literal.underscored for literal in term if literal not in asked]
        if asked:
            kept.setdefault(frozenset(asked), asked)
    if not dropped:
        return goal
    log.info("instruction: left out %s (about the robot, not asked for)", ", ".join(dropped))
    return format_goal(list(kept.values()))


def _unasked(words: Words, said: Sequence[tuple[str, ...]], literal: Atom, world: frozenset[str]) -> bool:
    """Whether ``literal`` is a positive literal about the robot itself that ``said`` does not say."""
    return not literal.negated and words.about_robot(literal) and not own_said(words, said, literal, world)


def own_said(words: Words, said: Sequence[tuple[str, ...]], literal: Atom, world: frozenset[str]) -> bool:
    """Whether one of the spans ``said`` (their words) names the objects of ``literal`` and says one
    of its words (see the module docstring); only the ``world``'s objects count as named."""
    objects = objects_of(words, literal)
    runs = phrasing_runs(words.phrasing(literal))
    before: frozenset[str] = frozenset()
    for span in said:
        named = words.named_in(" ".join(span)) & world
        if any(objects <= reading for reading in readings(named, span, before)) and any(
            in_order(run, span) for run in runs
        ):
            return True
        before = named or before
    return False


__all__ = ["own_said", "unasked_own_dropped"]
