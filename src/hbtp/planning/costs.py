"""Step costs: how each planner prices an action of the backward search.

The four planners run the same search and differ only in the step cost ``h(a)`` of an action:

* BT Expansion (:class:`UnitCosts`): 1, so the search is breadth-first and ignores costs;
* OBTEA (:class:`ActionCosts`): ``D(a)``;
* HBTP-O (:class:`DiscountedCosts`): ``D(a)/α`` while the heuristic path p̂ still owes ``a`` on the
  search path, else ``D(a)``;
* HBTP-S (:class:`FreeOwedCosts`): 0 while owed, else ``D(a)``.

Costs stay exact. HBTP-O with a whole α counts in units of ``1/α``: every cost is multiplied by α
(:attr:`StepCosts.scale`) and an owed action costs ``D(a)``; any other α gives fractions.
"""

from __future__ import annotations

import math
from dataclasses import dataclass, field
from fractions import Fraction

from hbtp.errors import InputError
from hbtp.logic.task import GroundAction

Number = int | float | Fraction
#: The default α of HBTP-O.
DEFAULT_ALPHA = 10_000
#: The largest α: the heuristics compute in floats, exact while D·α stays below 2^53 (with plan costs up
#: to 10^6); far larger α overflow them.
MAX_ALPHA = 10**9


def check_alpha(alpha: object) -> Number:
    """``alpha`` if it is a valid HBTP-O discount divisor: a finite number from 1 to :data:`MAX_ALPHA`.

    An owed action costs D(a)/α, so α < 1 would make the heuristic path dearer than any other
    path, and a non-finite α has no step cost at all. A whole α becomes an int (exact arithmetic in
    units of 1/α), whatever its type: ``10000.0`` and ``10000`` are the same α.
    """
    if isinstance(alpha, bool) or not isinstance(alpha, int | float | Fraction):
        raise InputError(f"alpha must be a number, not {alpha!r}")
    if isinstance(alpha, float) and not math.isfinite(alpha):
        raise InputError(f"alpha must be a finite number, not {alpha}")
    if not 1 <= alpha <= MAX_ALPHA:
        raise InputError(f"alpha must be between 1 and {MAX_ALPHA:,}, not {alpha}")
    if isinstance(alpha, float) and alpha.is_integer():
        return int(alpha)
    if isinstance(alpha, Fraction) and alpha.denominator == 1:
        return int(alpha)
    return alpha


class StepCosts:
    """The step costs of one planner (see the module docstring).

    ``scale`` is the unit of the costs (every full cost is ``D(a)·scale``); ``follows_hints`` says
    whether actions owed by p̂ cost less; ``orders_by_heuristic`` whether an LLM-free heuristic orders
    the search (A*, ``g + h``) or only drops dead ends.
    """

    __slots__ = ()
    scale: Number = 1
    follows_hints = False
    orders_by_heuristic = True

    def full_cost(self, action: GroundAction) -> Number:
        """The step cost of an action that p̂ does not (or no longer) owe."""
        return action.cost

    def owed_cost(self, action: GroundAction) -> Number:
        """The step cost of an action that p̂ still owes on the search path."""
        return self.full_cost(action)

    def with_alpha(self, alpha: Number) -> StepCosts:
        """These costs with HBTP-O's divisor ``alpha`` (unchanged for the planners without one)."""
        return self


@dataclass(frozen=True, slots=True)
class UnitCosts(StepCosts):
    """BT Expansion: every action costs 1 (breadth-first; a heuristic only drops dead ends)."""

    orders_by_heuristic = False

    def full_cost(self, action: GroundAction) -> Number:
        return 1


@dataclass(frozen=True, slots=True)
class ActionCosts(StepCosts):
    """OBTEA: every action costs ``D(a)``."""


@dataclass(frozen=True, slots=True)
class DiscountedCosts(StepCosts):
    """HBTP-O: an owed action costs ``D(a)/α``, in units of ``1/α`` when α is whole."""

    alpha: Number = DEFAULT_ALPHA
    scale: Number = field(init=False, repr=False, compare=False)
    follows_hints = True

    def __post_init__(self) -> None:
        alpha = check_alpha(self.alpha)
        object.__setattr__(self, "alpha", alpha)
        object.__setattr__(self, "scale", alpha if isinstance(alpha, int) else 1)

    def full_cost(self, action: GroundAction) -> Number:
        return action.cost * self.scale

    def owed_cost(self, action: GroundAction) -> Number:
        if isinstance(self.alpha, int):
            return action.cost
        return Fraction(action.cost) / Fraction(self.alpha)

    def with_alpha(self, alpha: Number) -> StepCosts:
        return DiscountedCosts(alpha)


@dataclass(frozen=True, slots=True)
class FreeOwedCosts(StepCosts):
    """HBTP-S: an owed action costs nothing."""

    follows_hints = True

    def owed_cost(self, action: GroundAction) -> Number:
        return 0


__all__ = [
    "DEFAULT_ALPHA",
    "MAX_ALPHA",
    "ActionCosts",
    "DiscountedCosts",
    "FreeOwedCosts",
    "Number",
    "StepCosts",
    "UnitCosts",
    "check_alpha",
]
