"""LLM-free heuristics computed from the initial state.

``h_max`` (Bonet & Geffner): the cost of the most expensive literal of a condition in the delete
relaxation, computed forward from s0 once per action space. For the backward search it is
admissible and consistent: ``h(c) <= D(a) + h(regress(c, a))`` because every literal that ``a``
adds costs at most ``D(a)`` plus the most expensive precondition, and the preconditions are part of
the regressed condition. So OBTEA ordered by ``g + h_max`` is A* and stays optimal. Literals that
are unreachable even in the relaxation get ``inf``: a condition holding one is a dead end.
"""

from __future__ import annotations

import heapq
import math
from collections.abc import Iterable, Sequence

from hbtp.logic.task import GroundAction, GroundTask


def hmax_table(task: GroundTask, actions: Sequence[GroundAction]) -> list[float]:
    """For each atom id, the h_max cost of reaching it from s0 with ``actions`` (``inf`` if never)."""
    cost = [math.inf] * len(task.atoms)
    waiting = [len(a.pre) for a in actions]
    users: dict[int, list[int]] = {}
    for position, action in enumerate(actions):
        for atom in action.pre:
            users.setdefault(atom, []).append(position)
    heap: list[tuple[float, int]] = []
    for atom in sorted(task.initial_state):
        cost[atom] = 0.0
        heapq.heappush(heap, (0.0, atom))
    ready: list[int] = [p for p, action in enumerate(actions) if not action.pre]
    done = [False] * len(task.atoms)
    for position in ready:
        _relax(actions[position], 0.0, cost, heap)
    while heap:
        value, atom = heapq.heappop(heap)
        if done[atom] or value > cost[atom]:
            continue
        done[atom] = True
        for position in users.get(atom, ()):
            waiting[position] -= 1
            if waiting[position] == 0:
                action = actions[position]
                _relax(action, max(cost[p] for p in action.pre), cost, heap)
    return cost


def _relax(action: GroundAction, pre_cost: float, cost: list[float], heap: list[tuple[float, int]]) -> None:
    value = pre_cost + action.cost
    for atom in action.add:
        if value < cost[atom]:
            cost[atom] = value
            heapq.heappush(heap, (value, atom))


def hmax(table: Sequence[float], condition: Iterable[int]) -> float:
    """h_max of a condition: its most expensive literal (0 for the empty condition)."""
    return max((table[a] for a in condition), default=0.0)
