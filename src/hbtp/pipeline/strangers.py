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
"""

from __future__ import annotations

from hbtp.domains.scenarios import Scenario
from hbtp.domains.words import Words, words_for
from hbtp.logic.atoms import Atom
from hbtp.pipeline.clauses import PLAIN, clauses, in_order, phrasing_runs, world_objects

#: Words that may stand beside a thing said alone in a list ("and the box", "either the cereal").
_ALONE = frozenset(("the", "a", "an", "my", "your", "some", "either", "both", "neither", "also", "too", "nor"))


def asked_about(scenario: Scenario, text: str) -> tuple[str, ...]:
    """The things ``text`` asks about that the world lacks (see the module docstring), as said, in
    the order said."""
    words = words_for(scenario)
    if not words.lacking_in(text):
        return ()
    world = world_objects(scenario)
    runs = [run for run in _world_runs(words, scenario) if set(run) - PLAIN]
    parts = words.parts()
    said = clauses(text)
    says = [any(in_order(run, clause) for run in runs) for clause in said]
    found: list[str] = []
    for at, clause in enumerate(said):
        spoken = " ".join(clause)
        strangers = [thing for thing in words.lacking_in(spoken) if thing.split()[-1] not in parts]
        if not strangers or words.named_in(spoken) & world:
            continue
        alone = set(clause) <= _ALONE | {w for thing in strangers for w in thing.split()}
        if says[at] or (alone and any(says[max(at - 1, 0) : at + 2])):
            found += strangers
    return tuple(dict.fromkeys(found))


def _world_runs(words: Words, scenario: Scenario) -> list[tuple[str, ...]]:
    """The words of every predicate of the world (:func:`hbtp.pipeline.clauses.phrasing_runs`)."""
    runs: list[tuple[str, ...]] = []
    for predicate, arity in sorted(scenario.task.predicates.items()):
        runs += phrasing_runs(words.phrasing(Atom(predicate, tuple(f"x{i}" for i in range(arity)))))
    return list(dict.fromkeys(runs))
