"""Negations an instruction says and a goal read from it left out: "switch on the AC and never turn
the temperature down" read as ``Active_AC & Low_ACTemperature``.

A small model under a grammar writes the literal an instruction talks about, and often misses the
"not" around it. A positive literal of a goal is *said negated* when one clause of the instruction
(cut at punctuation and at "and", "but", "then", "or", "so", "while") has a negation that governs it:

* a forbidden deed or an unwanted state, "don't", "do not", "never", "not to", "I don't want", with
  the objects of the literal and no others, and the literal's words (its phrasing's state,
  deed or unwanted deed, :class:`hbtp.domains.words.Phrasing`), after the negation: "never turn the
  temperature down", "take care not to close the curtain";
* a state that must not hold, "should not be", "mustn't be", "isn't supposed to be", or "is not" /
  "isn't" after "make sure", "ensure" or "see to it": the objects of the literal and no others
  anywhere in the clause, the literal's words after the negation: "make sure the fridge isn't open".

A negation that reports a state ("the microwave isn't plugged in, could you plug it in?"), softens
a request ("don't forget to switch on the TV") or sets things aside ("the plain milk, not the AD
milk") does not govern the literal, nor does a "not" that is part of a name ("the
not-from-concentrate juice"). Such a literal becomes its negation (:func:`negations_mended`);
the checks then judge the goal as they judge any other (one that now holds at the start is refused).

The other way, a negated literal that asks for nothing (its atom does not hold at the start) is
*said positive* when a clause with no negation word ("not", "n't", "never", "no", ...) names its
objects and no others and has its words (:func:`said_positive`: "the milk can go either into the
fridge or onto the table" read as ``~IsIn_milk_fridge | ...``), no clause says it negated (as
above) and none says a deed that undoes it ("leave the bar"). Such a literal becomes positive.
A literal whose words are derived from its PDDL name is never judged so.
"""

from __future__ import annotations

from collections.abc import Sequence

from hbtp.domains.scenarios import Scenario
from hbtp.domains.words import SLOT, Words, words_for
from hbtp.errors import InputError
from hbtp.logic.atoms import Atom
from hbtp.pipeline.clauses import (
    clauses,
    in_order,
    negating,
    objects_of,
    phrasing_runs,
    readings,
    tokens,
    world_objects,
)
from hbtp.pipeline.mend import literals_replaced

#: Negations of a deed or of an unwanted state: the objects and the words follow them.
_DEED = (("don't",), ("do", "not"), ("never",), ("not", "to"), ("don't", "want"), ("do", "not", "want"))
#: Negations of a state: the objects may come before them (the subject), the words follow.
_STATE = (("shouldn't",), ("should", "not"), ("mustn't",), ("must", "not"), ("isn't", "supposed"),
          ("aren't", "supposed"), ("is", "not", "supposed"), ("are", "not", "supposed"))  # fmt: skip
#: "is not" is a report ("the microwave isn't plugged in") unless a clause asks for it.
_ASKED_STATE = (("isn't",), ("aren't",), ("is", "not"), ("are", "not"))
#: A bare "not" after these words reports a state ("the TV is not on") or hedges ("if not").
_REPORTING = frozenset(("is", "are", "was", "were", "am", "be", "been", "do", "does", "did", "if", "or", "whether",
                        "could", "can", "would", "will", "has", "have", "had"))  # fmt: skip
#: A bare "not" before these words sets a thing aside ("the milk, not the juice").
_ASIDE = frozenset(("the", "a", "an", "my", "your", "this", "that", "those", "these", "any", "only", "just"))
_ASKING = (("make", "sure"), ("ensure",), ("see", "to", "it"), ("see", "that"))
#: Words after "don't" that soften a request rather than forbid a deed.
_SOFTENERS = frozenset(("forget", "hesitate", "mind", "fail", "worry", "know", "think", "care", "need"))


def negations_mended(scenario: Scenario, text: str, goal: str) -> str:
    """``goal`` with each positive literal the instruction ``text`` says negated turned into its
    negation, and each negated one it says positive into its atom (see the module docstring), an
    alternative that becomes another kept once; a goal that does not parse is returned as it is."""
    words = words_for(scenario)
    said = clauses(text)
    world = world_objects(scenario)

    def turned(literal: Atom, _: tuple[Atom, ...]) -> Atom | None:
        if said_negated(words, said, literal, world):
            return literal.negate()
        if not _at_start(scenario, literal) and said_positive(words, said, literal, world):
            return literal.negate()
        return None

    return literals_replaced(goal, turned, "said with the other sign")


def said_negated(words: Words, clauses: Sequence[tuple[str, ...]], literal: Atom, world: frozenset[str]) -> bool:
    """Whether one of ``clauses`` (their words, :func:`hbtp.pipeline.clauses.clauses`) has a negation
    that governs the positive ``literal`` (see the module docstring); only the ``world``'s objects
    count as named."""
    if literal.negated:
        return False
    objects = objects_of(words, literal)
    if not objects:
        return False
    runs = phrasing_runs(words.phrasing(literal))
    before: frozenset[str] = frozenset()
    for said in clauses:
        named = words.named_in(" ".join(said)) & world
        if objects not in readings(named, said, before):
            before = named or before
            continue
        inside = _in_names(words, said, named)
        for at, width, deed in _negations(said):
            if at in inside:  # "the not-from-concentrate juice" names a thing
                continue
            after = said[at + width :]
            if deed and objects not in readings(words.named_in(" ".join(after)) & world, after, before):
                continue
            if any(in_order(run, after) for run in runs):
                return True
        before = named or before
    return False


def said_positive(words: Words, clauses: Sequence[tuple[str, ...]], literal: Atom, world: frozenset[str]) -> bool:
    """Whether the negated ``literal`` is said positive in ``clauses`` (see the module docstring)."""
    phrasing = words.phrasing(literal.positive)
    objects = objects_of(words, literal)
    if not literal.negated or not objects or phrasing.derived:
        return False
    if said_negated(words, clauses, literal.positive, world):
        return False
    undo = [tokens(SLOT.sub(" ", text)) for text in phrasing.undo]
    runs = phrasing_runs(phrasing)
    before: frozenset[str] = frozenset()
    positive = False
    for said in clauses:
        named = words.named_in(" ".join(said)) & world
        if objects in readings(named, said, before):
            if any(in_order(run, said) for run in undo):
                return False
            positive = positive or (not negating(said) and any(in_order(run, said) for run in runs))
        before = named or before
    return positive


def _at_start(scenario: Scenario, literal: Atom) -> bool:
    """Whether ``literal``'s atom holds at the start (an atom the world does not know never does)."""
    try:
        return scenario.task.atom_id(literal.positive) in scenario.task.initial_state
    except InputError:
        return False


def _in_names(words: Words, said: tuple[str, ...], named: frozenset[str]) -> set[int]:
    """The places in ``said`` of the words of a name of the objects ``named``."""
    inside: set[int] = set()
    for name in named:
        for spoken in words.noun(name).names:
            run = tokens(spoken)
            run = run[1:] if run[:1] in (("the",), ("a",), ("an",)) else run
            inside.update(
                at + i for at in range(len(said) - len(run) + 1) if _at(said, at, run) for i in range(len(run))
            )
    return inside


def _negations(said: tuple[str, ...]) -> list[tuple[int, int, bool]]:
    """The negations in the words of a clause: where each starts, its width, and whether it is one of
    a deed (:data:`_DEED`) or of a state."""
    asking = any(_at(said, at, run) for at in range(len(said)) for run in _ASKING)
    found = []
    for at in range(len(said)):
        for runs, deed in ((_DEED, True), (_STATE, False), (_ASKED_STATE if asking else (), False)):
            for run in runs:
                following = said[at + len(run) : at + len(run) + 1]
                if _at(said, at, run) and not (deed and set(following) & _SOFTENERS):
                    found.append((at, len(run), deed))
        # "the fridge not open", not "the milk, not the juice"
        if said[at] == "not" and at and said[at - 1] not in _REPORTING and not set(said[at + 1 : at + 2]) & _ASIDE:
            found.append((at, 1, False))
    return found


def _at(said: Sequence[str], at: int, run: tuple[str, ...]) -> bool:
    return tuple(said[at : at + len(run)]) == run
