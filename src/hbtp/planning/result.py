"""Typed results of a planning run: a status, the expansion record (the tree), and statistics."""

from __future__ import annotations

import enum
from dataclasses import dataclass, field
from typing import Any

from hbtp.logic.task import Goal, GroundTask


class Status(enum.Enum):
    """How a planning run ended."""

    SOLVED = "solved"
    UNSOLVABLE = "unsolvable"  # proved: the open list emptied (in the action space used)
    TIMEOUT = "timeout"
    NODE_LIMIT = "node-limit"
    MEMORY_LIMIT = "memory-limit"
    ERROR = "error"  # an internal error of the search (a bug): nothing is proved
    NOT_PLANNED = "not-planned"  # no search ran (the LLM gave nothing and no fallback was allowed): no verdict

    @property
    def solved(self) -> bool:
        return self is Status.SOLVED


@dataclass(frozen=True, slots=True)
class Expansion:
    """An expanded condition: ``condition`` regressed from expansion ``parent`` through ``action``.

    The goal is expansion 0 with no action and parent -1. Every other expansion becomes the subtree
    ``Sequence(condition, action)`` of the behavior tree, in expansion order (Algorithm 1, line 21).
    """

    condition: frozenset[int]
    action: int | None
    parent: int
    cost_to_goal: int  # real cost D of the actions from this condition to the goal along the parents


@dataclass(frozen=True)
class SearchStats:
    """What the search did: |S⁻| (explored: conditions expanded, the goal included), and more."""

    explored: int = 0
    generated: int = 0
    pruned_subset: int = 0
    pruned_mutex: int = 0
    pruned_dead_end: int = 0
    time_s: float = 0.0
    action_space: int = 0
    tree_conditions: int = 0  # conditions in the tree: explored, plus any robustness expansions
    reopened: int = 0  # expanded conditions reached again more cheaply (only under lmcut)
    pruned_symmetric: int = 0  # conditions symmetric to one held at no higher g (SearchConfig.symmetry)

    def to_dict(self) -> dict[str, Any]:
        return {
            "explored": self.explored,
            "generated": self.generated,
            "pruned_subset": self.pruned_subset,
            "pruned_mutex": self.pruned_mutex,
            "pruned_dead_end": self.pruned_dead_end,
            "time_s": self.time_s,
            "action_space": self.action_space,
            "tree_conditions": self.tree_conditions,
            "reopened": self.reopened,
            "pruned_symmetric": self.pruned_symmetric,
        }


@dataclass(frozen=True)
class PlanResult:
    """The outcome of one planning run.

    ``expansions`` is the whole search record (also on a limit: the partial tree); ``solution`` the
    actions of the path found, from s0 to the goal; ``executed`` and ``cost`` what happens when the
    tree is run from s0 (D(T)).
    """

    status: Status
    planner: str
    goal: Goal
    expansions: tuple[Expansion, ...] = ()
    solution: tuple[int, ...] = ()
    executed: tuple[int, ...] = ()
    cost: int | None = None
    stats: SearchStats = field(default_factory=SearchStats)
    message: str = ""
    final: int | None = None  # the expansion whose condition holds in s0 (the end of the solution path)

    @property
    def solved(self) -> bool:
        return self.status.solved

    def to_dict(self, task: GroundTask) -> dict[str, Any]:
        """The JSON record of ``hbtp plan --json``."""
        return {
            "status": self.status.value,
            "planner": self.planner,
            "goal": str(self.goal),
            "cost": self.cost,
            "explored": self.stats.explored,
            "generated": self.stats.generated,
            "time_s": round(self.stats.time_s, 6),
            "action_space": self.stats.action_space,
            "executed": [task.actions[i].name for i in self.executed],
            "solution": [task.actions[i].name for i in self.solution],
            "message": self.message,
        }
