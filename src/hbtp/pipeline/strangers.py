"""Things an instruction asks about that the world lacks, read from the instruction's own clauses.

A model under a grammar answers with the world's objects: asked to "clean the TV and the box" in a
world without a box, it answers ``IsClean_tv``, the box quietly dropped. A thing of the words file
the world lacks (:meth:`hbtp.domains.words.Words.lacking_in`) is *asked about* when a clause of the
instruction (:func:`hbtp.pipeline.clauses.clauses`) names it, names none of the world's objects,
and says a state or a deed of one of the world's predicates ("the box should be clean", "connect
the flower vase to the power"), or is the thing alone beside a clause that says one ("clean the TV
| and the box", "either the cereal | or the coffee machine must be switched on"). A thing named
beside what is asked ("a bowl for my cereal", "the match is about to start") is not: its clause
names an object the world has, or says no state or deed of the world; nor is a part of things
("shut the door" of the fridge: ``part`` in the words file).

Beside a goal read from the instruction, such a thing is asked about too (:func:`asked_beside`) when
it is listed with an object a literal of the goal is about ("the skateboard and the peach in the
fridge" read as ``IsIn_peach_fridge``: the clause ends with the thing and the next begins with the
object, or the clause begins with the thing, the rest naming an object of the world or nothing, and
the clause before ends with the object), or when its clause names objects of the world too and says a
state or a deed of the world, and no literal of the goal is about those objects alone ("make sure
the pie is sitting on the bedside table" read as ``IsOn_chips_nightstand``). A thing the world lacks
whose words name an object of the world ("chairs" beside a café's ``Chairs``) is none.
"""

from __future__ import annotations

from collections.abc import Sequence

from hbtp.domains.scenarios import Scenario
from hbtp.domains.words import Words, spoken_words, words_for
from hbtp.logic.atoms import Atom
from hbtp.pipeline.clauses import PLAIN, clauses, in_order, objects_of, phrasing_runs, wanted, world_objects

#: Words that may stand beside a thing said alone in a list ("and the box", "either the cereal").
_ALONE = frozenset(("the", "a", "an", "my", "your", "some", "either", "both", "neither", "also", "too", "nor"))


def asked_about(scenario: Scenario, text: str) -> tuple[str, ...]:
    """The things ``text`` asks about that the world lacks (see the module docstring), as said, in
    the order said."""
    words = words_for(scenario)
    if not words.lacking_in(text):
        return ()
    world = world_objects(scenario)
    parts = words.parts()
    said = clauses(text)
    says = _says(words, scenario, text)
    found: list[str] = []
    for at, clause in enumerate(said):
        spoken = " ".join(clause)
        strangers = [thing for thing in words.lacking_in(spoken) if thing.split()[-1] not in parts]
        if not strangers or words.named_in(spoken) & world:
            continue
        alone = set(clause) <= _ALONE | {w for thing in strangers for w in thing.split()}
        if says[at] or (alone and any(says[max(at - 1, 0) : at + 2])):
            found += strangers
    return _whole(found)


def asked_beside(scenario: Scenario, text: str, goal: Sequence[Sequence[Atom]]) -> tuple[str, ...]:
    """The things ``text`` asks about that the world lacks, read beside ``goal`` (see the module
    docstring), as said, in the order said."""
    words = words_for(scenario)
    if not words.lacking_in(text):
        return ()
    world = world_objects(scenario)
    about = [objects_of(words, literal) for term in goal for literal in term]
    said = clauses(text)
    says = _says(words, scenario, text)
    found: list[str] = []
    for at, clause in enumerate(said):
        named = words.named_in(" ".join(clause)) & world
        unsaid = bool(named) and says[at]
        for thing in _strangers(words, world, clause):
            mates = _listed_with(words, world, said, at, tuple(thing.split()))
            if any(mates & objects for objects in about) or (unsaid and not _told(words, goal, named, clause)):
                found.append(thing)
    return _whole(found)


def _whole(things: Sequence[str]) -> tuple[str, ...]:
    """``things`` once each, in their order, those said within another left out ("air conditioning"
    beside "air conditioning temperature")."""
    return tuple(t for t in dict.fromkeys(things) if not any(t != o and f" {t} " in f" {o} " for o in things))


def _told(words: Words, goal: Sequence[Sequence[Atom]], named: frozenset[str], clause: tuple[str, ...]) -> bool:
    """Whether a literal of ``goal`` is about objects ``clause`` names (``named``) alone and is said by
    the clause's words ("the air conditioning is in the microwave" does not say
    ``IsSwitchedOn_microwave``)."""
    for literal in (literal for term in goal for literal in term):
        objects = objects_of(words, literal)
        runs = phrasing_runs(words.phrasing(literal))
        if objects and objects <= named and any(in_order(run, clause) for run in runs):
            return True
    return False


def _strangers(words: Words, world: frozenset[str], clause: tuple[str, ...]) -> list[str]:
    """The things the world lacks that ``clause`` names, parts of things and things called as an
    object of the world is aside."""
    parts = words.parts()
    found = words.lacking_in(" ".join(clause))
    return [thing for thing in found if thing.split()[-1] not in parts and not words.named_in(thing) & world]


def _listed_with(
    words: Words, world: frozenset[str], said: Sequence[tuple[str, ...]], at: int, thing: tuple[str, ...]
) -> frozenset[str]:
    """The objects of the world listed with ``thing``, named in clause ``at`` of ``said``: named first
    in the next clause when the thing ends its own, or last in the clause before when the thing
    begins its own and the rest of it names an object of the world or nothing."""
    clause = _bare(said[at])
    mates: frozenset[str] = frozenset()
    if clause[-len(thing) :] == thing and at + 1 < len(said):
        mates |= _named_by(words, world, _bare(said[at + 1]), first=True)
    rest = clause[len(thing) :]
    if clause[: len(thing)] == thing and at and (not rest or words.named_in(" ".join(rest)) & world):
        mates |= _named_by(words, world, said[at - 1], first=False)
    return mates


def _bare(clause: tuple[str, ...]) -> tuple[str, ...]:
    """``clause`` without the determiners it begins with."""
    start = 0
    while start < len(clause) and clause[start] in _ALONE:
        start += 1
    return clause[start:]


def _named_by(words: Words, world: frozenset[str], clause: tuple[str, ...], first: bool) -> frozenset[str]:
    """The objects of the world one of whose names (maybe in the plural) is the first (or the last)
    words of ``clause``."""
    for width in range(min(4, len(clause)), 0, -1):
        run = spoken_words(" ".join(clause[:width] if first else clause[-width:]))
        named = frozenset(x for x in words.named_in(" ".join(run)) & world if _called(words, x, run))
        if named:
            return named
    return frozenset()


def _called(words: Words, name: str, run: tuple[str, ...]) -> bool:
    """Whether ``run`` is one of the names of the object ``name``, maybe in the plural."""
    for spoken in words.noun(name).names:
        said = spoken_words(spoken)
        if run in (said, (*said[:-1], said[-1] + "s"), (*said[:-1], said[-1] + "es")):
            return True
    return False


def _says(words: Words, scenario: Scenario, text: str) -> list[bool]:
    """For each clause of ``text``, whether it says a state or a deed of the world's predicates: words
    that do on their own ("switched on", "put ... in"), or plain ones ("on", "on top of") where
    words before them in the sentence ask for a state (:func:`hbtp.pipeline.clauses.wanted`: "the
    radio must be on top of the bed")."""
    every = _world_runs(words, scenario)
    saying = [run for run in every if set(run) - PLAIN]
    return [
        any(in_order(run, clause) for run in (every if asked else saying))
        for clause, asked in zip(clauses(text), wanted(text), strict=True)
    ]


def _world_runs(words: Words, scenario: Scenario) -> list[tuple[str, ...]]:
    """The words of every predicate of the world (:func:`hbtp.pipeline.clauses.phrasing_runs`)."""
    runs: list[tuple[str, ...]] = []
    for predicate, arity in sorted(scenario.task.predicates.items()):
        runs += phrasing_runs(words.phrasing(Atom(predicate, tuple(f"x{i}" for i in range(arity)))))
    return list(dict.fromkeys(runs))
