"""The heuristics' names: the one value a search, a planner and a command use to say which one.

Kept apart from :mod:`hbtp.planning.heuristics` (the estimates themselves) so that configuration
(:class:`~hbtp.planning.search_state.SearchConfig`, the command line) names a heuristic without
importing the tables behind it.
"""

from __future__ import annotations

import enum

from hbtp.errors import InputError

__all__ = ["DEFAULT_HEURISTIC", "HEURISTICS", "HeuristicName", "heuristic_named"]


class HeuristicName(enum.StrEnum):
    """The heuristics a search can order its conditions by (``--heuristic``): a value, equal to its
    name as text (``HeuristicName.LM == "lm"``), so rows and files keep the name."""

    NONE = "none"
    HMAX = "hmax"
    LM = "lm"
    LMCUT = "lmcut"
    SEQ = "seq"

    @property
    def consistent(self) -> bool:
        """Whether its estimates are consistent (a search with it never re-opens a condition)."""
        return self in (HeuristicName.NONE, HeuristicName.HMAX, HeuristicName.LM)


HEURISTICS: tuple[str, ...] = tuple(h.value for h in HeuristicName)
#: The heuristic hbtp plans with unless told otherwise (``hbtp plan``, :func:`hbtp.planning.plan`,
#: re-planning): landmarks, admissible, so OBTEA stays optimal. The paper's planners had none; its
#: benchmarks say ``none`` where they reproduce them.
DEFAULT_HEURISTIC = HeuristicName.LM


def heuristic_named(text: str) -> HeuristicName:
    """``text`` as a heuristic's name (:class:`~hbtp.errors.InputError` for another)."""
    try:
        return HeuristicName(text)
    except ValueError:
        raise InputError(f"unknown heuristic {text!r}; choose one of: {', '.join(HEURISTICS)}") from None
