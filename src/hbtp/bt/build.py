"""Build behavior trees from a search (Algorithm 1).

The full tree is ``Fallback(goal, Sequence(c1, a1), ..., Sequence(cn, an))`` over every expanded
condition, cheapest cost to the goal first (see :mod:`hbtp.planning.execution` for why this order
reaches the goal and, after an optimal search, at the optimal cost): it acts from any state that
satisfies an explored condition. The
path-only tree keeps just the conditions of the solution path (what the reference implementation
outputs); it is smaller but gives up when a disturbance leaves that path.
"""

from __future__ import annotations

from collections.abc import Sequence as Seq

from hbtp.bt.nodes import Action, Condition, Fallback, Node, Sequence
from hbtp.planning.execution import branch_order, goal_roots
from hbtp.planning.result import Expansion, PlanResult


def full_tree(expansions: Seq[Expansion]) -> Node:
    """Every expanded condition as ``Sequence(c, a)`` under the goal's fallback (whose first
    children check the goal, one Condition per disjunct)."""
    branches = _goal_checks(expansions)
    for index in branch_order(expansions):
        expansion = expansions[index]
        assert expansion.action is not None
        branches.append(Sequence((Condition(expansion.condition), Action(expansion.action))))
    return Fallback(tuple(branches))


def path_tree(expansions: Seq[Expansion], final: int | None = None) -> Node:
    """Only the solution path: the last expansion (or ``final``) and its ancestors."""
    branches = _goal_checks(expansions)
    index = len(expansions) - 1 if final is None else final
    chain: list[Expansion] = []
    while expansions[index].action is not None:
        chain.append(expansions[index])
        index = expansions[index].parent
    chain.reverse()
    for expansion in chain:
        assert expansion.action is not None
        branches.append(Sequence((Condition(expansion.condition), Action(expansion.action))))
    return Fallback(tuple(branches))


def _goal_checks(expansions: Seq[Expansion]) -> list[Node]:
    """The Conditions of the goal's disjuncts, the first children of the root."""
    roots = goal_roots(expansions)
    if not roots:
        raise ValueError("a tree needs at least the goal expansion")
    return [Condition(expansions[index].condition) for index in roots]


def tree_of(result: PlanResult, kind: str = "full") -> Node:
    """The tree of a planning result: ``full`` (default) or ``path``."""
    if kind == "full":
        return full_tree(result.expansions)
    if kind == "path":
        if not result.solved:
            raise ValueError("a path-only tree needs a solved result")
        return path_tree(result.expansions, result.final)
    raise ValueError(f"unknown tree kind {kind!r}; choose full or path")
