"""The planners as configurations of the one search, and :func:`plan`, the entry point."""

from __future__ import annotations

import dataclasses
import enum
import logging
from collections.abc import Sequence

from hbtp.domains.mutex import Mutexes
from hbtp.errors import InputError
from hbtp.logic.task import Goal, GroundAction, GroundTask
from hbtp.planning.costs import (
    DEFAULT_ALPHA,
    MAX_ALPHA,
    ActionCosts,
    DiscountedCosts,
    FreeOwedCosts,
    Number,
    UnitCosts,
    check_alpha,
)
from hbtp.planning.flow import require_solver
from hbtp.planning.heuristic_names import DEFAULT_HEURISTIC, HeuristicName, heuristic_named
from hbtp.planning.hints import Hints, ResolvedHints, pruned_action_space, resolve_hints
from hbtp.planning.limits import Limits
from hbtp.planning.result import PlanResult, SearchStats, Status
from hbtp.planning.search import SearchConfig, search

PLANNERS: dict[str, SearchConfig] = {
    "bte": SearchConfig("bte", UnitCosts()),
    "obtea": SearchConfig("obtea", ActionCosts()),
    "hbtp-o": SearchConfig("hbtp-o", DiscountedCosts(DEFAULT_ALPHA)),
    "hbtp-s": SearchConfig("hbtp-s", FreeOwedCosts()),
}
PLANNER_DESCRIPTIONS = {
    "bte": "BT Expansion: breadth-first, costs ignored (sound and complete, not optimal)",
    "obtea": "OBTEA: cost-optimal BT expansion",
    "hbtp-o": "HBTP-O: heuristic path discounted by 1/alpha (optimal when p-hat has no wrong actions)",
    "hbtp-s": "HBTP-S: heuristic path actions cost 0 while owed (fastest, satisficing)",
}


class Space(enum.StrEnum):
    """The action space a search explores: every action, or A⁻ built from the hints."""

    FULL = "full"
    PRUNED = "pruned"


log = logging.getLogger(__name__)

__all__ = [
    "MAX_ALPHA",
    "PLANNERS",
    "PLANNER_DESCRIPTIONS",
    "Space",
    "check_alpha",
    "confirmed_search",
    "plan",
    "planner_config",
]


def planner_config(
    name: str,
    *,
    heuristic: HeuristicName | str = DEFAULT_HEURISTIC,
    alpha: Number = DEFAULT_ALPHA,
    symmetry: bool = False,
) -> SearchConfig:
    """The :class:`SearchConfig` of a registered planner, with the given options.

    ``heuristic`` is a :class:`HeuristicName` or its name (``"lm"``; another is an :class:`InputError`).
    ``alpha`` (HBTP-O's divisor, any finite number from 1 to :data:`MAX_ALPHA`) is checked for every
    planner, used by HBTP-O only. ``symmetry``: see :attr:`SearchConfig.symmetry`.
    """
    try:
        base = PLANNERS[name]
    except KeyError:
        raise InputError(f"unknown planner {name!r}; choose one of: {', '.join(PLANNERS)}") from None
    heuristic = heuristic_named(heuristic)  # a name given as text ("lm") is checked and becomes the value
    if heuristic is HeuristicName.SEQ:
        require_solver()
    costs = base.costs.with_alpha(check_alpha(alpha))
    return dataclasses.replace(base, heuristic=heuristic, costs=costs, symmetry=symmetry)


def plan(
    task: GroundTask,
    goal: Goal | str,
    planner: str | SearchConfig = "hbtp-s",
    *,
    hints: Hints | ResolvedHints | None = None,
    space: Space = Space.FULL,
    mutexes: Mutexes | None = None,
    heuristic: HeuristicName | str | None = None,
    alpha: Number = DEFAULT_ALPHA,
    limits: Limits | None = None,
    extra_expansions: int = 0,
) -> PlanResult:
    """Plan a behavior tree for ``goal``.

    ``planner`` is a planner's name, with ``heuristic`` (default :data:`DEFAULT_HEURISTIC`, as
    ``hbtp plan``) and ``alpha``, or a :class:`SearchConfig` from :func:`planner_config`, which
    holds them and the rarer options (``symmetry``).
    ``space=Space.PRUNED`` searches A⁻ = (Q⁻ × O⁻) ∩ A built from the hints; ``Space.FULL`` every action.
    Hints naming unknown actions, predicates or objects are reported in the log and ignored.
    ``extra_expansions`` explores that many more conditions after the solution (a more reactive tree).
    """
    if isinstance(planner, SearchConfig):
        if heuristic is not None or alpha != DEFAULT_ALPHA:
            raise InputError("give the heuristic and alpha in the SearchConfig, not beside it")
        config = planner
    else:
        config = planner_config(planner, heuristic=DEFAULT_HEURISTIC if heuristic is None else heuristic, alpha=alpha)
    resolved_goal = task.resolve_goal(goal) if isinstance(goal, str) else goal
    resolved: ResolvedHints | None
    if hints is None:
        resolved = None
    elif isinstance(hints, ResolvedHints):
        resolved = hints
    else:
        resolved = resolve_hints(task, hints)
    if space == Space.PRUNED:
        if resolved is None:
            raise InputError("a pruned action space needs hints (heuristic path, predicates, objects)")
        actions = task.restricted(pruned_action_space(task, resolved))
    elif space == Space.FULL:
        actions = task.actions
    else:
        raise InputError(f"unknown action space {space!r}; choose full or pruned")
    if extra_expansions < 0:
        raise InputError(f"extra expansions must not be negative, not {extra_expansions}")
    return confirmed_search(
        task, resolved_goal, actions, config, mutexes=mutexes, hints=resolved, limits=limits,
        extra_expansions=extra_expansions,
    )  # fmt: skip


def confirmed_search(
    task: GroundTask,
    goal: Goal,
    actions: Sequence[GroundAction],
    config: SearchConfig,
    *,
    mutexes: Mutexes | None = None,
    hints: ResolvedHints | None = None,
    limits: Limits | None = None,
    extra_expansions: int = 0,
) -> PlanResult:
    """:func:`search`, whose UNSOLVABLE verdicts are proofs even when ``mutexes`` has declared ones.

    Declared mutexes may be false, so a failure they took part in (a goal they reject, or an open
    list they helped to empty) proves nothing: the verdict then comes from the same search with the
    proved mutexes alone, within what is left of ``limits`` (a timeout if nothing is left).
    """
    result = search(
        task, goal, actions, config, mutexes=mutexes, hints=hints, limits=limits, extra_expansions=extra_expansions
    )
    if mutexes is None or not _declared_pruned(result, mutexes):
        return result
    log.info("%s: no solution with the declared mutexes; searching again with the proved ones only", goal)
    rest = _remaining(limits or Limits(), result.stats)
    if isinstance(rest, Status):
        message = f"{rest.value} before the search without the declared mutexes could decide"
        return dataclasses.replace(result, status=rest, message=message)
    again = search(
        task, goal, actions, config, mutexes=mutexes.proved_only(), hints=hints, limits=rest,
        extra_expansions=extra_expansions,
    )  # fmt: skip
    stats = dataclasses.replace(again.stats, time_s=result.stats.time_s + again.stats.time_s)
    return dataclasses.replace(again, stats=stats)


def _declared_pruned(result: PlanResult, mutexes: Mutexes) -> bool:
    """Whether ``result`` is an UNSOLVABLE verdict that declared mutexes took part in."""
    if result.status is not Status.UNSOLVABLE or not mutexes.declared:
        return False
    disjuncts = result.goal.disjuncts
    proved = mutexes.proved_only()
    if disjuncts and all(proved.conflict(d) is not None for d in disjuncts):
        return False  # a proved clash in every disjunct of the goal is a proof
    return result.stats.pruned_mutex > 0 or any(mutexes.conflict(d) is not None for d in disjuncts)


def _remaining(limits: Limits, used: SearchStats) -> Limits | Status:
    """What ``limits`` leave after a search that used ``used``, or the limit that is exhausted."""
    time_s, max_expansions = limits.time_s, limits.max_expansions
    if time_s is not None:
        time_s -= used.time_s
        if time_s <= 0:
            return Status.TIMEOUT
    if max_expansions is not None:
        max_expansions -= used.explored
        if max_expansions < 1:
            return Status.NODE_LIMIT
    return dataclasses.replace(limits, time_s=time_s, max_expansions=max_expansions)  # any deadline stays
