"""Limits of a planning run: wall-clock time, expansions, memory.

The search asks :class:`LimitWatch` after every expansion and every 512 generated children, so a run
ends within a few milliseconds of its time limit; on a limit the result still carries the partial
tree and the statistics. ``time_s`` counts from the start of each search; a :class:`Deadline`
(``Limits.deadline``, started with the command) also bounds it, so the time spent loading, grounding
and in earlier searches of the same command (``--hints oracle``) is charged to the same limit.
"""

from __future__ import annotations

import dataclasses
import math
import time
from dataclasses import dataclass

from hbtp.deadline import Deadline
from hbtp.errors import InputError
from hbtp.memory import resident_mb
from hbtp.planning.result import Status


@dataclass(frozen=True)
class Limits:
    """``time_s``: wall-clock seconds per search; ``max_expansions``: conditions expanded; ``memory_mb``:
    resident size; ``deadline``: a wall-clock deadline shared with the rest of the command."""

    time_s: float | None = None
    max_expansions: int | None = None
    memory_mb: float | None = None
    deadline: Deadline | None = None

    def __post_init__(self) -> None:
        if self.time_s is not None and not self.time_s > 0:
            raise InputError(f"time limit must be a positive number of seconds, not {self.time_s}")
        if self.max_expansions is not None and self.max_expansions < 1:
            raise InputError(f"expansion limit must be at least 1, not {self.max_expansions}")
        if self.memory_mb is not None and not self.memory_mb > 0:
            raise InputError(f"memory limit must be a positive number of MB, not {self.memory_mb}")

    def starting_now(self) -> Limits:
        """These limits with a :class:`Deadline` of ``time_s`` seconds from now, to hand to every phase
        of a command (loading, heuristic set-up, every search) so that ``time_s`` bounds all of it."""
        if self.time_s is None:
            return self
        return dataclasses.replace(self, deadline=Deadline(self.time_s, memory_mb=self.memory_mb))


class LimitWatch:
    """Checks the limits of one run."""

    def __init__(self, limits: Limits, started: float) -> None:
        self.limits = limits
        self.started = started  # the run's start (time.perf_counter())
        own = None if limits.time_s is None else Deadline(limits.time_s, started, limits.memory_mb)
        shared = limits.deadline
        #: The earlier of the run's own time limit and the command's deadline.
        self.deadline = shared if own is None or (shared is not None and shared.at < own.at) else own
        self._at = math.inf if self.deadline is None else self.deadline.at  # checked at every expansion

    def as_deadline(self) -> Deadline | None:
        """The time limit of this run as a :class:`Deadline` (for the heuristic set-up)."""
        return self.deadline

    def timed_out(self) -> bool:
        return time.perf_counter() >= self._at

    def check(self, expansions: int, generated: int) -> Status | None:
        if self.timed_out():
            return Status.TIMEOUT
        if self.limits.max_expansions is not None and expansions >= self.limits.max_expansions:
            return Status.NODE_LIMIT
        if self.limits.memory_mb is not None and expansions % 256 == 0 and resident_mb() > self.limits.memory_mb:
            return Status.MEMORY_LIMIT
        return None

    def reason(self, status: Status) -> str:
        if status is Status.TIMEOUT:
            return f"time limit of {self.deadline.seconds if self.deadline else 0:g} s reached"
        if status is Status.NODE_LIMIT:
            return f"expansion limit of {self.limits.max_expansions} reached"
        if status is Status.MEMORY_LIMIT:
            return f"memory limit of {self.limits.memory_mb} MB reached"
        return ""
