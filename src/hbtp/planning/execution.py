"""The tree of a search as a policy: Fallback(goal, Sequence(c1,a1), Sequence(c2,a2), ...).

The goal is the first expansions without an action: one per disjunct of the goal (a conjunctive
goal has one), each a success branch.

The branches are ordered by (real cost from the condition to the goal, expansion index): at every
tick the cheapest explored condition that holds selects its action. The action of a branch leads to
a state satisfying its parent, whose cost to the goal is lower by the action's cost and which was
expanded earlier, so the key of the selected branch strictly decreases and the run reaches the goal
in at most one step per branch; and the cost actually paid is at most the cost to the goal of the
first branch that holds, so a tree built from an optimal search costs exactly the optimum.

(Algorithm 1 appends branches in expansion order, which is the same order for OBTEA; under A* or
HBTP's discounted costs the expansion order can put a costlier condition first.)

The search runs this policy with the one executor (:func:`hbtp.logic.execution.execute`) to get D(T);
:func:`hbtp.bt.build.full_tree` builds the same branches as nodes.
"""

from __future__ import annotations

from collections.abc import Sequence

from hbtp.logic.execution import Run, execute, first_match
from hbtp.logic.task import GroundTask, State
from hbtp.planning.result import Expansion


def goal_roots(expansions: Sequence[Expansion]) -> list[int]:
    """The expansions of the goal's disjuncts (those without an action), in order."""
    return [index for index, expansion in enumerate(expansions) if expansion.action is None]


def branch_order(expansions: Sequence[Expansion]) -> list[int]:
    """The expansions of the tree's action branches (all but the goal's), cheapest cost to the goal
    first, then in expansion order (the sort is stable)."""
    costs = [expansion.cost_to_goal for expansion in expansions]
    branches = [index for index, expansion in enumerate(expansions) if expansion.action is not None]
    return sorted(branches, key=costs.__getitem__)


def execute_expansions(task: GroundTask, expansions: Sequence[Expansion], state: State | None = None) -> Run:
    """Tick the expansion tree from ``state`` (default s0) until the goal holds or nothing applies.

    A branch's condition was regressed through its action, so it includes the action's
    precondition: the first-match list of (goal disjunct, success)..., then (c_i, a_i), is the tree.
    """
    table: list[tuple[frozenset[int], int | None]] = [(expansions[i].condition, None) for i in goal_roots(expansions)]
    table += [(expansions[i].condition, expansions[i].action) for i in branch_order(expansions)]
    return execute(first_match(table), task, state, max_ticks=len(expansions) + 1)


__all__ = ["branch_order", "execute_expansions", "goal_roots"]
