"""Deeds an instruction asks for that make a literal false: "leave the bar and go to table 1" read
as ``RobotNear_Table1``, where the robot is to be away from the bar too.

A deed that undoes a literal is said with no negation word ("leave the bar", "move away from the
fridge"), and a taught model, taught negations by their negation words, leaves it out. The words
file gives such deeds as a phrasing's ``undo`` (:class:`hbtp.domains.words.Phrasing`), the object
last. A literal is *said undone* when a clause of the instruction
(:func:`hbtp.pipeline.clauses.clauses`) says one of them with the name of the literal's object
right after its words, ending the clause ("leave table 1 clean" asks for a clean table), and has no
negation ("don't leave the bar" asks for the opposite); its other arguments are the robot. Such a
literal is added negated to a goal of one conjunction that does not have it, and a positive one
becomes its negation (:func:`undone_added`); the checks then judge the goal as they judge any
other.
"""

from __future__ import annotations

import logging
from collections.abc import Iterator

from hbtp.domains.scenarios import Scenario
from hbtp.domains.words import NEGATION, SLOT, Words, spoken_words, words_for
from hbtp.logic.atoms import Atom
from hbtp.logic.goals import format_goal
from hbtp.logic.task import GroundTask
from hbtp.pipeline.clauses import clauses, world_objects
from hbtp.pipeline.mend import parsed

log = logging.getLogger(__name__)


def undone_added(scenario: Scenario, text: str, goal: str) -> str:
    """``goal`` with each literal ``text`` says undone negated (see the module docstring); a goal of
    more than one conjunction, or that does not parse, is returned as it is."""
    terms = parsed(goal)
    if terms is None:
        return goal
    if len(terms) != 1:
        return goal
    term = list(terms[0])
    changed = []
    for atom in said_undone(words_for(scenario), scenario.task, text, world_objects(scenario)):
        if atom.negate() in term:
            continue
        if atom in term:
            term[term.index(atom)] = atom.negate()
        else:
            term.append(atom.negate())
        changed.append(atom.underscored)
    if not changed:
        return goal
    log.info("instruction: %s said undone", ", ".join(changed))
    return format_goal([tuple(term)])


def said_undone(words: Words, task: GroundTask, text: str, world: frozenset[str]) -> list[Atom]:
    """The positive atoms of ``task`` that a clause of ``text`` says undone (see the module
    docstring), in the order said; only the ``world``'s objects count as named."""
    found: list[Atom] = []
    undoing = [(predicate, phrasing.undo) for predicate, phrasing in sorted(words.predicates.items()) if phrasing.undo]
    for clause in clauses(text):
        said = " ".join(clause)
        if NEGATION.search(said):
            continue
        words_said = spoken_words(said)
        for start, width, name in words.named_at(said):
            if name not in world or start + width < len(words_said):
                continue
            for predicate, deeds in undoing:
                found += [a for a in _atoms(words, task, predicate, deeds, name, words_said[:start]) if a not in found]
    return found


def _atoms(
    words: Words, task: GroundTask, predicate: str, deeds: tuple[str, ...], name: str, before: tuple[str, ...]
) -> Iterator[Atom]:
    """The atoms of ``predicate`` about ``name`` whose undoing deeds (one of ``deeds``, its object
    last) end with the words ``before`` the name; their other arguments are the robot."""
    arity = task.predicates.get(predicate)
    robots = sorted(x for x in task.symbols if words.noun(x).agent)
    for deed in deeds:
        slots = list(SLOT.finditer(deed))
        if arity is None or len(slots) != 1 or deed[slots[0].end() :].strip():
            continue
        run = spoken_words(deed[: slots[0].start()])
        if not run or before[-len(run) :] != run:
            continue
        at = int(slots[0].group(2))
        for robot in robots if arity > 1 else [name]:
            atom = Atom(predicate, tuple(name if i == at else robot for i in range(arity)))
            if atom in task.atom_ids:
                yield atom
