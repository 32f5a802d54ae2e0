"""BT.CPP's Groot2 publisher, made safe to drop at once.

BT.CPP's ``Groot2Publisher`` starts a server thread that sets its own "active" flag when it begins;
its destructor clears the flag and joins the thread. Dropped before that thread has begun (a run
that ends within milliseconds, a re-plan that swaps trees at once; on a loaded machine a new thread
may wait tens of milliseconds for a core), the thread then sets the flag the destructor cleared, and
the join never returns: the process hangs. :func:`groot2_publisher` hands a publisher over only once
the threads its constructor started have begun: on Linux, once each has waited at least once (its
first wait comes after the flag is set: ``voluntary_ctxt_switches`` in ``/proc``); elsewhere, after
:data:`FALLBACK_S`.
"""

from __future__ import annotations

import os
import time
from pathlib import Path
from typing import Any

#: The longest wait for a publisher's threads to begin (then it is handed over as it is).
START_WAIT_S = 2.0
#: The wait where threads cannot be seen (no ``/proc``).
FALLBACK_S = 0.25
_TASKS = Path("/proc/self/task")


def groot2_publisher(bt: Any, tree: Any, port: int) -> Any:
    """A ``bt.Groot2Publisher`` of ``tree`` on ``port`` (``bt``: the ``behaviortreepy`` module),
    returned once its threads have begun (see the module docstring); the binding's errors (a port
    taken) as it raises them."""
    before = _threads()
    publisher = bt.Groot2Publisher(tree, port)
    _await_begun(before)
    return publisher


def _threads() -> frozenset[int] | None:
    """The ids of this process's threads, or ``None`` where they cannot be listed."""
    try:
        return frozenset(int(name) for name in os.listdir(_TASKS))
    except (OSError, ValueError):
        return None


def _await_begun(before: frozenset[int] | None) -> None:
    """Wait until every thread started since ``before`` has waited once, for at most
    :data:`START_WAIT_S`."""
    if before is None:
        time.sleep(FALLBACK_S)
        return
    deadline = time.monotonic() + START_WAIT_S
    while time.monotonic() < deadline:
        now = _threads()
        started = (now or frozenset()) - before
        if now is None or (started and all(_has_waited(tid) for tid in started)):
            return
        time.sleep(0.001)


def _has_waited(tid: int) -> bool:
    """Whether thread ``tid`` has waited at least once (or is gone)."""
    try:
        status = (_TASKS / str(tid) / "status").read_text(encoding="ascii")
    except OSError:
        return True
    for line in status.splitlines():
        if line.startswith("voluntary_ctxt_switches:"):
            return int(line.split()[1]) > 0
    return True
