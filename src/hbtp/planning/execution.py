"""Run the tree of a search from a state: Fallback(goal, Sequence(c1,a1), Sequence(c2,a2), ...).

At every tick the first expanded condition that holds selects its action (the goal first). The
action of expansion ``i`` leads to a state satisfying its parent, which was expanded earlier, so the
selected index strictly decreases and the run reaches the goal in at most one step per expansion.
This is the executor of D(T) for the planners; :mod:`hbtp.bt` builds and ticks the real tree.
"""

from __future__ import annotations

from collections.abc import Sequence
from dataclasses import dataclass

from hbtp.logic.task import GroundTask, State
from hbtp.planning.result import Expansion


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
    done: list[int] = []
    cost = 0
    for _ in range(limit):
        if goal <= current:
            return Run(True, tuple(done), cost, current)
        for expansion in expansions:
            if expansion.action is not None and expansion.condition <= current:
                action = task.actions[expansion.action]
                current = action.progress(current)
                done.append(action.index)
                cost += action.cost
                break
        else:
            return Run(False, tuple(done), cost, current)
    return Run(goal <= current, tuple(done), cost, current)
