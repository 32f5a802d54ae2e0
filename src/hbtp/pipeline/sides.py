"""A goal's alternatives taken from the sides of an instruction's "or": "either put the juice in the
fridge and close it, or leave it on the kitchen table" read as ``IsIn_juice_fridge &
IsOn_juice_kitchentable | IsClose_fridge``.

A taught model writes the literals of each choice but, for a choice of several literals, now and
then joins the wrong ones. Where the instruction offers its choices as clauses, its words split
into *sides* at each cut: an "or" after punctuation or after an "either" (and, with no "and"
before it in its sentence, the punctuation before it there: the items of a list, "the fridge, the
microwave, or the cabinet"), an "otherwise", and an "if" after punctuation that points back
("..., if that's too much trouble, ...", "if there's no time", "if not"). A literal belongs to
the side of the last object it names that no other side names ("leave it on the kitchen table":
the table's side, not the juice's). Where every literal of the goal is positive and belongs to a
side, and two sides or more have literals, the goal is one alternative per side, its literals
joined (:func:`sides_as_said`).
"""

from __future__ import annotations

import logging
import re
from collections.abc import Sequence

from hbtp.domains.scenarios import Scenario
from hbtp.domains.words import spoken_words, words_for
from hbtp.logic.atoms import Atom
from hbtp.logic.goals import format_goal
from hbtp.pipeline.clauses import objects_of
from hbtp.pipeline.mend import parsed

log = logging.getLogger(__name__)

_TOKEN = re.compile(r"[a-z0-9]+|[^\sa-z0-9'\u2019-]")
#: Words after an "if" that point back at what was asked before ("if that's a hassle", "if not").
_BACK = frozenset(("that", "it", "this", "there", "not"))


def sides_as_said(scenario: Scenario, text: str, goal: str) -> str:
    """``goal`` as one alternative for each side of ``text`` that its literals belong to (see the
    module docstring), or as it is; a goal that does not parse is returned as it is."""
    terms = parsed(goal)
    if terms is None:
        return goal
    literals = list(dict.fromkeys(literal for term in terms for literal in term))
    cuts = _cuts(text)
    if not cuts or any(literal.negated for literal in literals):
        return goal
    words = words_for(scenario)
    mentions = words.named_at(text)
    sides: dict[int, list[Atom]] = {}
    for literal in literals:
        side = _side(objects_of(words, literal), mentions, cuts)
        if side is None:
            return goal
        sides.setdefault(side, []).append(literal)
    if len(sides) < 2:
        return goal
    grouped = [tuple(sides[side]) for side in sorted(sides)]
    read = format_goal(grouped)
    if {frozenset(term) for term in grouped} == {frozenset(term) for term in terms}:
        return goal
    log.info("instruction: alternatives taken from the sides of its 'or' (%s -> %s)", goal, read)
    return read


def _side(about: set[str], mentions: Sequence[tuple[int, int, str]], cuts: Sequence[int]) -> int | None:
    """The side of the last of the objects ``about`` that the ``mentions`` (where each object is
    named, :meth:`hbtp.domains.words.Words.named_at`) name on one side only, or ``None``."""
    seen: dict[str, set[int]] = {}
    last: dict[str, int] = {}
    for start, _, name in mentions:
        if name in about:
            seen.setdefault(name, set()).add(sum(cut <= start for cut in cuts))
            last[name] = start
    own = [name for name in seen if len(seen[name]) == 1]
    if not own:
        return None
    return next(iter(seen[max(own, key=last.__getitem__)]))


def _cuts(text: str) -> list[int]:
    """Where each side after the first starts, counted in the :func:`spoken_words` of ``text``; the
    items of a list that an "or" ends ("the fridge, the microwave, or the cabinet") are sides too,
    unless an "and" comes before it in its sentence ("the AC on, the milk on table 1 and the coffee
    at the station; or, if you can't, ...")."""
    cuts: list[int] = []
    parts: list[int] = []  # where each part of the sentence so far starts, after punctuation
    joined = False  # an "and" in the sentence so far: its list, if any, is not one of choices
    count = 0
    after_break = True
    either = False
    tokens = _TOKEN.findall(text.lower())
    for at, token in enumerate(tokens):
        if not token.isalnum():
            after_break = True
            either = either and token not in ".!?"
            parts = [] if token in ".!?" else [*parts, count]
            joined = joined and token not in ".!?"
            continue
        following = tokens[at + 1 : at + 2]
        if token == "or" and (after_break or either):
            cuts += [count] if joined else [*parts, count]
        elif token == "otherwise" or (token == "if" and after_break and bool(set(following) & _BACK)):
            cuts.append(count)
        either = either or token == "either"
        joined = joined or token == "and"
        after_break = False
        count += len(spoken_words(token))
    return sorted(set(cuts))


__all__ = ["sides_as_said"]
