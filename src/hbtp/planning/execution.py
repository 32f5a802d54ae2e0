"""Run the tree of a search from a state: Fallback(goal, Sequence(c1,a1), Sequence(c2,a2), ...).

The branches are ordered by (real cost from the condition to the goal, expansion index): at every
tick the cheapest explored condition that holds selects its action. The action of a branch leads to
a state satisfying its parent, whose cost to the goal is lower by the action's cost and which was
expanded earlier, so the key of the selected branch strictly decreases and the run reaches the goal
in at most one step per branch; and the cost actually paid is at most the cost to the goal of the
first branch that holds, so a tree built from an optimal search costs exactly the optimum.

(Algorithm 1 appends branches in expansion order, which is the same order for OBTEA; under A* or
HBTP's discounted costs the expansion order can put a costlier condition first.)

This is the executor of D(T) for the planners; :mod:`hbtp.bt` builds and ticks the real tree.
"""

from __future__ import annotations

from collections.abc import Sequence
from dataclasses import dataclass

from hbtp.logic.task import GroundTask, State
from hbtp.planning.result import Expansion


def branch_order(expansions: Sequence[Expansion]) -> list[int]:
    """The expansions of the tree's branches (all but the goal), cheapest cost to the goal first."""
    return sorted(range(1, len(expansions)), key=lambda i: (expansions[i].cost_to_goal, i))


@dataclass(frozen=True)
class Run:
    reached: bool
    actions: tuple[int, ...]
    cost: int
    final_state: State


def execute_expansions(
    task: GroundTask,
    goal: frozenset[int],
    expansions: Sequence[Expansion],
    state: State | None = None,
    max_steps: int | None = None,
) -> Run:
    """Tick the expansion tree from ``state`` (default s0) until the goal holds or nothing applies."""
    current = task.initial_state if state is None else state
    limit = max_steps if max_steps is not None else len(expansions) + 1
    branches = [expansions[i] for i in branch_order(expansions)]
    done: list[int] = []
    cost = 0
    for _ in range(limit):
        if goal <= current:
            return Run(True, tuple(done), cost, current)
        for expansion in branches:
            if expansion.action is not None and expansion.condition <= current:
                action = task.actions[expansion.action]
                current = action.progress(current)
                done.append(action.index)
                cost += action.cost
                break
        else:
            return Run(False, tuple(done), cost, current)
    return Run(goal <= current, tuple(done), cost, current)
