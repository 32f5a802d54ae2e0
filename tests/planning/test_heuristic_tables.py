"""The heuristics' tables (h_max, fact landmarks) against naive fixpoints written here, on random
tasks, for the full action space, pruned spaces, and tasks re-started from other states."""

from __future__ import annotations

import math
import random

import pytest

from hbtp.logic.task import GroundAction, GroundTask
from hbtp.planning.heuristics import SpaceAnalysis
from helpers import random_task


def naive_hmax(task: GroundTask, actions: list[GroundAction]) -> list[float]:
    cost = [math.inf] * len(task.atoms)
    for atom in task.initial_state:
        cost[atom] = 0.0
    changed = True
    while changed:
        changed = False
        for action in actions:
            pre = max((cost[p] for p in action.pre), default=0.0)
            for atom in action.add:
                if pre + action.cost < cost[atom]:
                    cost[atom] = pre + action.cost
                    changed = True
    return cost


def naive_landmarks(task: GroundTask, actions: list[GroundAction]) -> list[frozenset[int] | None]:
    """The greatest fixpoint of LM(f) = {f} | ⋂ over achievers a of ⋃ LM(pre(a)), from 'all atoms'."""
    everything = frozenset(range(len(task.atoms)))
    reachable = naive_hmax(task, actions)
    table = [frozenset((a,)) if a in task.initial_state else everything for a in range(len(task.atoms))]
    changed = True
    while changed:
        changed = False
        for atom in range(len(task.atoms)):
            if atom in task.initial_state or math.isinf(reachable[atom]):
                continue
            options = [
                frozenset().union(*(table[p] for p in a.pre))
                for a in actions
                if atom in a.add and all(not math.isinf(reachable[p]) for p in a.pre)
            ]
            new = frozenset.intersection(*options) | {atom}
            if new != table[atom]:
                table[atom], changed = new, True
    return [None if math.isinf(reachable[a]) else table[a] for a in range(len(task.atoms))]


@pytest.mark.parametrize("seed", range(60))
def test_tables_equal_the_naive_fixpoints(seed: int) -> None:
    task, _goal = random_task(seed)
    rng = random.Random(seed)
    state = frozenset(a for a in range(len(task.atoms)) if rng.random() < 0.3)
    for world in (task, task.from_state(state)):
        full = list(world.actions)
        pruned = [a for a in full if rng.random() < 0.6]
        for actions in (full, pruned):
            analysis = SpaceAnalysis(world, actions)
            assert analysis.hmax == naive_hmax(world, actions)
            assert list(analysis.landmarks) == naive_landmarks(world, actions)


def test_a_restarted_task_shares_the_state_free_tables_only() -> None:
    task, _goal = random_task(3)
    first = SpaceAnalysis(task, task.actions)
    moved = task.from_state(frozenset())
    second = SpaceAnalysis(moved, moved.actions)
    assert second.shares is first.shares  # costs and adds only: shared
    assert second.hmax != first.hmax or task.initial_state == frozenset()
