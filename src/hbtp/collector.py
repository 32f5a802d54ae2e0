"""Python's cyclic garbage collector around work that builds many small acyclic objects.

Reading PDDL, grounding, decoding a cached scenario and the search all allocate objects without
reference cycles; the collector's repeated full passes over them would take about as long as the
work itself (and make a search overshoot its time limit). :func:`collector_paused` switches it off
for a block and restores its state after: the one way the library touches the collector.

A short-lived process (a command, a benchmark worker) may do more, explicitly, with
:func:`searches_frozen`: each search's objects are then frozen after it (moved out of the
collector's sight) and freed when the next search starts. Library code that embeds hbtp never
meets ``gc.freeze`` unless it asks for it.
"""

from __future__ import annotations

import contextlib
import contextvars
import gc
from collections.abc import Callable, Iterator


@contextlib.contextmanager
def collector_paused(on_resume: Callable[[], None] | None = None) -> Iterator[None]:
    """The collector off for the block, then back as it was; ``on_resume`` runs just before it is
    switched back on (a :class:`SearchMemory` freezes the search's objects there)."""
    collecting = gc.isenabled()
    gc.disable()
    try:
        yield
    finally:
        if collecting:
            if on_resume is not None:
                on_resume()
            gc.enable()


class SearchMemory:
    """What a finished search leaves for the next one to free, frozen out of the collector's sight.

    A search allocates many small objects and no reference cycles. Without this, the first
    collection after a large search, typically while its tree is built, walks every one of them (a
    second after a 10 s search); and freeing them (tens of thousands of nodes and suspended
    generators, up to 0.1 s) would be charged to the caller. With it, they are frozen (an O(1)
    step) and parked until the next search releases them, before that one's clock starts.
    """

    def __init__(self) -> None:
        self.parked: list[object] = []
        self.frozen = False

    def park(self, objects: object) -> None:
        """Keep ``objects`` alive until :meth:`release` (so dropping them costs nothing now)."""
        self.parked.append(objects)

    def release(self) -> None:
        """Free what is parked and give the frozen objects back to the collector."""
        self.parked.clear()
        if self.frozen:
            gc.unfreeze()
            self.frozen = False

    def paused(self) -> contextlib.AbstractContextManager[None]:
        """The collector paused for a search; its objects frozen when it is switched back on."""
        return collector_paused(on_resume=self.freeze)

    def freeze(self) -> None:
        gc.freeze()
        self.frozen = True


_SEARCH_MEMORY: contextvars.ContextVar[SearchMemory | None] = contextvars.ContextVar("hbtp_search_memory", default=None)


@contextlib.contextmanager
def searches_frozen() -> Iterator[SearchMemory]:
    """Within the block (and the threads it starts with a copy of its context), every search keeps
    its objects frozen until the next one; on leaving, they are freed and unfrozen. For a whole
    command or a benchmark worker, not for a library call (see the module docstring)."""
    memory = SearchMemory()
    token = _SEARCH_MEMORY.set(memory)
    try:
        yield memory
    finally:
        _SEARCH_MEMORY.reset(token)
        memory.release()


@contextlib.contextmanager
def searches_collected() -> Iterator[None]:
    """Within the block, searches leave their objects to the collector as usual, even inside
    :func:`searches_frozen`: for a loop of thousands of small searches (labelling training
    examples), whose frozen leftovers would otherwise pile up until the command ends."""
    memory = _SEARCH_MEMORY.get()
    if memory is not None:
        memory.release()
    token = _SEARCH_MEMORY.set(None)
    try:
        yield
    finally:
        _SEARCH_MEMORY.reset(token)


def search_memory() -> SearchMemory | None:
    """The :class:`SearchMemory` of the enclosing :func:`searches_frozen`, if any."""
    return _SEARCH_MEMORY.get()


__all__ = ["SearchMemory", "collector_paused", "search_memory", "searches_collected", "searches_frozen"]
