"""The planners as configurations of the one search, and :func:`plan`, the entry point."""

from __future__ import annotations

import dataclasses
from typing import Literal

from hbtp.domains.mutex import Mutexes
from hbtp.errors import InputError
from hbtp.logic.task import Goal, GroundTask
from hbtp.planning.heuristics import HEURISTICS, HeuristicName
from hbtp.planning.hints import Hints, ResolvedHints, pruned_action_space, resolve_hints
from hbtp.planning.limits import Limits
from hbtp.planning.result import PlanResult
from hbtp.planning.search import Number, SearchConfig, search

PLANNERS: dict[str, SearchConfig] = {
    "bte": SearchConfig("bte", "unit"),
    "obtea": SearchConfig("obtea", "cost"),
    "hbtp-o": SearchConfig("hbtp-o", "optimal-heuristic"),
    "hbtp-s": SearchConfig("hbtp-s", "satisficing-heuristic"),
}
PLANNER_DESCRIPTIONS = {
    "bte": "BT Expansion: breadth-first, costs ignored (sound and complete, not optimal)",
    "obtea": "OBTEA: cost-optimal BT expansion",
    "hbtp-o": "HBTP-O: heuristic path discounted by 1/alpha (optimal when p-hat has no wrong actions)",
    "hbtp-s": "HBTP-S: heuristic path actions cost 0 while owed (fastest, satisficing)",
}
Space = Literal["full", "pruned"]


def planner_config(name: str, *, heuristic: HeuristicName = "none", alpha: Number = 10_000) -> SearchConfig:
    """The :class:`SearchConfig` of a registered planner, with the given options."""
    try:
        base = PLANNERS[name]
    except KeyError:
        raise InputError(f"unknown planner {name!r}; choose one of: {', '.join(PLANNERS)}") from None
    if heuristic not in HEURISTICS:
        raise InputError(f"unknown heuristic {heuristic!r}; choose one of: {', '.join(HEURISTICS)}")
    if not alpha > 0:
        raise InputError(f"alpha must be positive, not {alpha}")
    return dataclasses.replace(base, heuristic=heuristic, alpha=alpha)


def plan(
    task: GroundTask,
    goal: Goal | str,
    planner: str = "hbtp-s",
    *,
    hints: Hints | ResolvedHints | None = None,
    space: Space = "full",
    mutexes: Mutexes | None = None,
    heuristic: HeuristicName = "none",
    alpha: Number = 10_000,
    limits: Limits | None = None,
    extra_expansions: int = 0,
) -> PlanResult:
    """Plan a behavior tree for ``goal``.

    ``space="pruned"`` searches A⁻ = (Q⁻ × O⁻) ∩ A built from the hints; ``"full"`` every action.
    Hints naming unknown actions, predicates or objects are reported in the log and ignored.
    ``extra_expansions`` explores that many more conditions after the solution (a more reactive tree).
    """
    config = planner_config(planner, heuristic=heuristic, alpha=alpha)
    resolved_goal = task.resolve_goal(goal) if isinstance(goal, str) else goal
    resolved: ResolvedHints | None
    if hints is None:
        resolved = None
    elif isinstance(hints, ResolvedHints):
        resolved = hints
    else:
        resolved = resolve_hints(task, hints)
    if space == "pruned":
        if resolved is None:
            raise InputError("a pruned action space needs hints (heuristic path, predicates, objects)")
        actions = task.restricted(pruned_action_space(task, resolved))
    elif space == "full":
        actions = task.actions
    else:
        raise InputError(f"unknown action space {space!r}; choose full or pruned")
    if extra_expansions < 0:
        raise InputError(f"extra expansions must not be negative, not {extra_expansions}")
    return search(
        task, resolved_goal, actions, config, mutexes=mutexes, hints=resolved, limits=limits,
        extra_expansions=extra_expansions,
    )  # fmt: skip
