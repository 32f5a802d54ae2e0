"""A tick rate: ticks at most ``hz`` times a second, sleeping between them to hold the rate.

:class:`TickRate` is the value (checked: a positive, finite number of ticks per second, at most
:data:`MAX_TICK_HZ`); :meth:`TickRate.pacer` gives the :class:`Pacer` of one run. The pacer's
:meth:`~Pacer.wait` is called before every tick: the first returns at once, each later one sleeps
until one period after the tick before started. A tick that overruns its period is followed at once
by the next (the rate is not made up for by a burst of ticks).
"""

from __future__ import annotations

import math
import time
from collections.abc import Callable
from dataclasses import dataclass

from hbtp.errors import InputError

__all__ = ["MAX_TICK_HZ", "Pacer", "TickRate"]

#: The highest tick rate accepted: faster than this, sleeping cannot hold the rate, and the run
#: should rather tick as fast as possible (no rate).
MAX_TICK_HZ = 1000.0


@dataclass(frozen=True, slots=True)
class TickRate:
    """At most ``hz`` ticks per second."""

    hz: float

    def __post_init__(self) -> None:
        hz = self.hz
        if isinstance(hz, bool) or not isinstance(hz, (int, float)) or not (0 < hz <= MAX_TICK_HZ):
            raise InputError(f"the tick rate must be a number of ticks per second in (0, {MAX_TICK_HZ:g}], not {hz!r}")

    @property
    def period_s(self) -> float:
        return 1.0 / self.hz

    def pacer(self) -> Pacer:
        return Pacer(self.period_s)


class Pacer:
    """Sleeps before each tick but the first until one period after the tick before started."""

    def __init__(
        self,
        period_s: float,
        *,
        clock: Callable[[], float] = time.monotonic,
        sleep: Callable[[float], None] = time.sleep,
    ) -> None:
        if not (0 < period_s < math.inf):
            raise InputError(f"the tick period must be a positive, finite number of seconds, not {period_s!r}")
        self.period_s = period_s
        self.clock = clock
        self.sleep = sleep
        self.last: float | None = None

    def wait(self) -> None:
        """Wait for the next tick's turn (at once for the first tick)."""
        if self.last is not None:
            left = self.last + self.period_s - self.clock()
            if left > 0:
                self.sleep(left)
        self.last = self.clock()
