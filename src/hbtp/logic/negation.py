"""Negative literals, compiled into STRIPS: the twin atom ``~p`` that holds exactly when ``p`` does not.

A task that must reason about ``~p`` (a goal ``~IsOpen(fridge)``, a PDDL precondition
``(not (open ?d))``) gets a twin atom for ``p``, appended after the existing atoms so that every id
stays valid. The twin is kept exact by the actions: an action that adds ``p`` deletes ``~p``, one
that deletes ``p`` without adding it adds ``~p``, and s0 holds ``~p`` when it lacks ``p``. Then
regression is the ordinary one and stays sound: an action achieves ``~p`` by deleting ``p``, and a
condition holding ``p`` and ``~p`` is pruned by the mutex ``{p, ~p}`` (proved by the same induction,
see :func:`hbtp.domains.mutex.with_negation_groups`). Every planner, heuristic, tree and executor
works on the compiled task unchanged; exporters show ``~p`` as an inverted condition on ``p``.

States given from outside (an observation, an edited state) list what is true; :meth:`GroundTask.complete`
adds the twins of the atoms that are absent.
"""

from __future__ import annotations

import dataclasses
from collections.abc import Iterable

from hbtp.logic.tables import TaskTable
from hbtp.logic.task import GroundAction, GroundTask


def with_negations(task: GroundTask, atom_ids: Iterable[int]) -> GroundTask:
    """``task`` with a negated twin for each atom of ``atom_ids`` that has none (``task`` itself when
    none is missing). The result is kept with ``task``, so asking again gives the same object."""
    missing = tuple(sorted({i for i in atom_ids if i not in task.negation_ids and not task.atoms[i].negated}))
    if not missing:
        return task
    return _NEGATED.of(task, lambda: _compiled(task, missing), key=missing)


#: The task with negated twins for some atoms (keyed by those atoms).
_NEGATED: TaskTable[GroundTask] = TaskTable("the task with negated twins")


def _compiled(task: GroundTask, missing: tuple[int, ...]) -> GroundTask:
    first = len(task.atoms)
    twin = {atom: first + offset for offset, atom in enumerate(missing)}
    atoms = (*task.atoms, *(task.atoms[atom].negate() for atom in missing))
    actions = tuple(with_twin_effects(action, twin) for action in task.actions)
    initial = task.initial_state | {twin[atom] for atom in missing if atom not in task.initial_state}
    return dataclasses.replace(task, atoms=atoms, actions=actions, initial_state=frozenset(initial))


def with_twin_effects(action: GroundAction, twin: dict[int, int]) -> GroundAction:
    """``action`` keeping the twins exact: it deletes ``twin[p]`` when it adds ``p`` and adds it
    when it deletes ``p`` without adding it (``action`` itself when it touches no twinned atom)."""
    made_true = {twin[atom] for atom in action.delete - action.add if atom in twin}
    made_false = {twin[atom] for atom in action.add if atom in twin}
    if not made_true and not made_false:
        return action
    return dataclasses.replace(action, add=action.add | made_true, delete=action.delete | made_false)


__all__ = ["with_negations", "with_twin_effects"]
