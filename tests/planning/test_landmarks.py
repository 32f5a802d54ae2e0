"""The fact landmarks of every atom: the greatest fixpoint of their definition, computed naively
here over every action until nothing changes, on random tasks and a scaled RobotHow."""

from __future__ import annotations

import math

import pytest
from tests.helpers import random_case

from hbtp.domains.scale import scaled_scenario
from hbtp.logic.task import GroundTask
from hbtp.planning.heuristics import _explore, landmark_table, span_lists


def naive_landmarks(task: GroundTask) -> list[frozenset[int] | None]:
    """``LM(f) = {f} | ⋂ over the achievers a of f of ⋃ LM(pre(a))`` (s0 atoms: themselves), from
    "every atom" downwards by full passes over the actions; ``None``: unreachable."""
    everything = frozenset(range(len(task.atoms)))
    reached = set(task.initial_state)
    changed = True
    while changed:  # the relaxed reachable atoms
        changed = False
        for action in task.actions:
            if action.pre <= reached and not action.add <= reached:
                reached |= action.add
                changed = True
    table: list[frozenset[int] | None] = [
        frozenset((f,)) if f in task.initial_state else (everything if f in reached else None)
        for f in range(len(task.atoms))
    ]
    changed = True
    while changed:
        changed = False
        for f in reached - task.initial_state:
            meet = everything
            for action in task.actions:
                if f in action.add and action.pre <= reached:
                    meet &= frozenset().union(*(table[p] or everything for p in action.pre))
            new = meet | {f}
            if new != table[f]:
                table[f], changed = new, True
    return table


@pytest.mark.parametrize("seed", range(12))
def test_the_landmarks_are_the_greatest_fixpoint(seed: int) -> None:
    task = random_case(seed).task
    hmax, order = _explore(task, task.actions)
    assert list(landmark_table(task, task.actions, hmax, None, order)) == naive_landmarks(task)
    assert [math.isinf(h) for h in hmax] == [part is None for part in naive_landmarks(task)]


def test_the_landmarks_of_a_grown_world_stay_small() -> None:
    task = scaled_scenario("robothow-small", 2).task
    hmax, order = _explore(task, task.actions)
    table = landmark_table(task, task.actions, hmax, None, order)
    assert list(table) == naive_landmarks(task)
    sizes = [len(part) for part in table if part is not None]
    assert max(sizes) < 20  # a handful of atoms each, whatever the world's size


def test_span_lists_are_the_kernels_form() -> None:
    spans, items = span_lists([{3, 1}, None, set()])
    assert list(memoryview(spans).cast("i")) == [0, 2, -1, -1, 2, 2]
    assert list(memoryview(items).cast("i")) == [1, 3]
