"""A memory limit for the whole process: ``hbtp plan --memory-mb``.

Two guards. Every phase of a command checks the resident size where it checks its deadline
(:meth:`hbtp.deadline.Deadline.check`: reading, grounding, mutex inference, heuristic set-up; the
search every 256 expansions) and stops cleanly with :class:`MemoryLimitReached` (exit code 1: not
solved) once it is past the limit. Behind them, :func:`memory_cap` has the kernel refuse any
allocation that would take the process's data (``RLIMIT_DATA``: the heap and every private
writable mapping) past :data:`HARD_MARGIN` times the limit, for a single allocation that jumps
past every check; the :class:`MemoryError` it raises becomes :class:`MemoryLimitReached` too.
"""

from __future__ import annotations

import contextlib
import logging
import math
import os
from collections.abc import Callable, Iterator

from hbtp.errors import InputError, PlanningError

log = logging.getLogger(__name__)

#: Bytes in the megabyte of ``--memory-mb`` (the unit :func:`resident_mb` reports).
MEGABYTE = 1_000_000
#: The kernel's limit, as a multiple of ``--memory-mb``: room for the checks to stop the command
#: cleanly (unwinding a full heap allocates too) before an allocation fails.
HARD_MARGIN = 1.25

_PAGE = os.sysconf("SC_PAGE_SIZE") if hasattr(os, "sysconf") else 4096


def resident_mb() -> float:
    """Current resident set size of this process in MB (Linux /proc; 0 where unavailable)."""
    try:
        with open("/proc/self/statm", encoding="ascii") as handle:
            return int(handle.read().split()[1]) * _PAGE / MEGABYTE
    except (OSError, ValueError, IndexError):
        return 0.0


def peak_resident_mb() -> float:
    """The most resident memory this process has had, in MB (0 where the platform does not say).

    The kernel's high-water mark (``ru_maxrss``) is brought up to date when memory is given back,
    so it can lag the current size by a few pages: the larger of the two is the peak."""
    try:
        import resource
    except ImportError:  # not a Unix
        return resident_mb()
    kilobytes = resource.getrusage(resource.RUSAGE_SELF).ru_maxrss  # Linux: kilobytes
    return max(kilobytes * 1024 / MEGABYTE, resident_mb())


class MemoryLimitReached(PlanningError):
    """An allocation failed under the memory limit."""


def check_memory_mb(mb: float | None) -> None:
    """Refuse a memory limit that is not a positive, finite number of megabytes."""
    if mb is not None and not (math.isfinite(mb) and mb > 0):
        raise InputError(f"memory limit must be a positive number of MB, not {mb}")


@contextlib.contextmanager
def memory_cap(mb: float | None) -> Iterator[None]:
    """Have the kernel limit the process's data to :data:`HARD_MARGIN` times ``mb`` megabytes
    while the block runs (nothing for ``None``), then restore the limit it had; a
    :class:`MemoryError` inside becomes :class:`MemoryLimitReached`.

    Where the platform has no such limit (not Linux, or a hard limit below ``mb`` that cannot be
    raised), the block runs with what there is and the search's resident-size watch still applies.
    """
    check_memory_mb(mb)
    if mb is None:
        yield
        return
    restore = _set_data_limit(int(mb * HARD_MARGIN * MEGABYTE))
    try:
        yield
    except MemoryError:
        raise MemoryLimitReached(f"memory limit of {mb:g} MB reached") from None
    finally:
        if restore is not None:
            restore()


def _set_data_limit(limit: int) -> Callable[[], None] | None:
    try:
        import resource
    except ImportError:  # not a Unix
        log.info("no process memory limit on this platform; the search's resident-size watch applies")
        return None
    soft, hard = resource.getrlimit(resource.RLIMIT_DATA)
    capped = limit if hard == resource.RLIM_INFINITY else min(limit, hard)
    try:
        resource.setrlimit(resource.RLIMIT_DATA, (capped, hard))
    except (ValueError, OSError) as error:
        log.warning("could not limit the process's memory to %d bytes: %s", capped, error)
        return None

    def restore() -> None:
        resource.setrlimit(resource.RLIMIT_DATA, (soft, hard))

    return restore


__all__ = [
    "HARD_MARGIN",
    "MEGABYTE",
    "MemoryLimitReached",
    "check_memory_mb",
    "memory_cap",
    "peak_resident_mb",
    "resident_mb",
]
