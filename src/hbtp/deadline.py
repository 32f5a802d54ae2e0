"""A wall-clock deadline shared by every phase of one command.

``hbtp plan -t 60`` starts one :class:`Deadline` when the command starts and hands it to loading
(parsing, grounding, mutex inference), to the heuristic set-up and to the search, so the whole
command ends within about a second of its time limit. A phase that cannot finish in time raises
:class:`TimeLimitReached` (exit code 1: not solved); the search instead returns a TIMEOUT result.
"""

from __future__ import annotations

import math
import time
from dataclasses import dataclass, field

from hbtp.errors import InputError, PlanningError
from hbtp.memory import MemoryLimitReached, resident_mb

#: Seconds a command may take when ``-t`` is not given (``hbtp plan``, ``hbtp ground``).
DEFAULT_TIME_LIMIT = 60.0


class TimeLimitReached(PlanningError):
    """The time limit passed before a phase (grounding, mutex inference, heuristic set-up) was done."""


@dataclass(frozen=True)
class Deadline:
    """``seconds`` after ``started`` (a :func:`time.perf_counter` value; default: now).

    ``memory_mb``, the command's memory limit, is checked with the time (:meth:`check`)."""

    seconds: float
    started: float = field(default_factory=time.perf_counter)
    memory_mb: float | None = None

    def __post_init__(self) -> None:
        if not self.seconds > 0:
            raise InputError(f"time limit must be a positive number of seconds, not {self.seconds}")

    @property
    def at(self) -> float:
        """The :func:`time.perf_counter` value at which the deadline passes."""
        return self.started + self.seconds

    def remaining(self) -> float:
        """Seconds left (negative once passed)."""
        return self.at - time.perf_counter()

    def expired(self) -> bool:
        return time.perf_counter() >= self.at

    def message(self, phase: str) -> str:
        return f"time limit of {self.seconds:g} s reached while {phase}"

    def check(self, phase: str) -> None:
        """Raise :class:`TimeLimitReached` naming ``phase`` (e.g. ``"grounding"``) once the deadline
        passed, or :class:`~hbtp.memory.MemoryLimitReached` once the process is past ``memory_mb``."""
        if self.expired():
            raise TimeLimitReached(self.message(phase))
        if self.memory_mb is not None and resident_mb() > self.memory_mb:
            raise MemoryLimitReached(f"memory limit of {self.memory_mb:g} MB reached while {phase}")


def check_deadline(deadline: Deadline | None, phase: str) -> None:
    """:meth:`Deadline.check` when there is a deadline."""
    if deadline is not None:
        deadline.check(phase)


def seconds_left(deadline: Deadline | None) -> float:
    """Seconds left before ``deadline`` (``math.inf`` without one; negative once passed)."""
    return math.inf if deadline is None else deadline.remaining()


def expired(deadline: Deadline | None) -> bool:
    """Whether ``deadline`` passed (never without one)."""
    return deadline is not None and deadline.expired()


def within(deadline: Deadline | None, seconds: float | None) -> Deadline | None:
    """The earlier of ``deadline`` and ``seconds`` from now: the cap of one sub-step (a round's
    search, an LLM call, the fallback) inside a command's deadline. ``None`` when neither bounds."""
    if seconds is None or not math.isfinite(seconds):
        return deadline
    if deadline is not None and deadline.remaining() <= seconds:
        return deadline
    memory_mb = None if deadline is None else deadline.memory_mb
    return Deadline(max(seconds, 1e-9), memory_mb=memory_mb)
