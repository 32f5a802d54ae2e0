"""Pausing Python's cyclic garbage collector around work that builds many small acyclic objects.

Reading PDDL, grounding, decoding a cached scenario and the search all allocate objects without
reference cycles; the collector's repeated full passes over them would take about as long as the
work itself (and make a search overshoot its time limit).
"""

from __future__ import annotations

import contextlib
import gc
from collections.abc import Callable, Iterator


@contextlib.contextmanager
def collector_paused(on_resume: Callable[[], None] | None = None) -> Iterator[None]:
    """The collector off for the block; ``on_resume`` runs just before it is switched back on (the
    search freezes its objects there, so the next collection does not walk them)."""
    collecting = gc.isenabled()
    gc.disable()
    try:
        yield
    finally:
        if collecting:
            if on_resume is not None:
                on_resume()
            gc.enable()
