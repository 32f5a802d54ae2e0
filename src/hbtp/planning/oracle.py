"""Oracle hints: the optimal plan of a task, as if an LLM had answered perfectly."""

from __future__ import annotations

from collections.abc import Callable
from typing import Protocol

from hbtp.domains.mutex import Mutexes
from hbtp.domains.scenarios import Scenario
from hbtp.errors import InputError, PlanningError
from hbtp.logic.task import Goal, GroundTask
from hbtp.planning.heuristic_names import HeuristicName
from hbtp.planning.hints import Hints
from hbtp.planning.limits import Limits
from hbtp.planning.planners import Space, plan


def optimal_plan(
    task: GroundTask, goal: Goal, mutexes: Mutexes | None = None, limits: Limits | None = None
) -> list[int]:
    """The actions of a cost-optimal plan (OBTEA with the landmark heuristic over the full action space).

    Only the *proved* ``mutexes`` prune: declared ones may be false and could cut off the optimum.
    """
    proved = mutexes.proved_only() if mutexes is not None else None
    result = plan(task, goal, "obtea", space=Space.FULL, mutexes=proved, heuristic=HeuristicName.LM, limits=limits)
    if not result.solved:
        raise PlanningError(f"no optimal plan for the oracle: {result.status.value} ({result.message})")
    return list(result.solution)


def oracle_hints(task: GroundTask, goal: Goal, mutexes: Mutexes | None = None, limits: Limits | None = None) -> Hints:
    """p̂ = an optimal plan, Q̂ and Ô = its action predicates and objects."""
    return Hints.from_plan(task, optimal_plan(task, goal, mutexes, limits))


class HasGoal(Protocol):
    """Anything with a goal text (a dataset record)."""

    @property
    def goal(self) -> str: ...


def optimal_cost_function(scenario: Scenario, limits: Limits | None = None) -> Callable[[HasGoal], int | None]:
    """Record -> the optimal cost of its goal (``None`` when unknown): OBTEA with the landmark
    heuristic over the full action space, pruning only with *proved* mutexes."""
    mutexes = scenario.mutexes.proved_only()

    def optimal_cost(record: HasGoal) -> int | None:
        try:
            result = plan(
                scenario.task,
                record.goal,
                "obtea",
                space=Space.FULL,
                mutexes=mutexes,
                heuristic=HeuristicName.LM,
                limits=limits,
            )
        except InputError:
            return None
        return result.cost if result.solved else None

    return optimal_cost
