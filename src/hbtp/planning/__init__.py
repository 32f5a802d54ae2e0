"""Planning: the backward search core, the four planners, hints and action-space pruning."""

from hbtp.planning.hints import (
    Hints,
    ResolvedHints,
    hints_from_names,
    pruned_action_space,
    resolve_hints,
)
from hbtp.planning.limits import Limits
from hbtp.planning.planners import PLANNER_DESCRIPTIONS, PLANNERS, plan, planner_config
from hbtp.planning.result import Expansion, PlanResult, SearchStats, Status
from hbtp.planning.search import SearchConfig, release_search_memory, search

__all__ = [
    "PLANNERS",
    "PLANNER_DESCRIPTIONS",
    "Expansion",
    "Hints",
    "Limits",
    "PlanResult",
    "ResolvedHints",
    "SearchConfig",
    "SearchStats",
    "Status",
    "hints_from_names",
    "plan",
    "planner_config",
    "pruned_action_space",
    "release_search_memory",
    "resolve_hints",
    "search",
]
