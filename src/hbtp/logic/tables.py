"""Per-task tables: what the layers above compute from a task once and keep with it.

A :class:`TaskTable` is the typed home of one such table (the prompt vocabulary, the heuristics'
analyses, the disturbance model...): declared once where it is built, with its type, and asked of
a task with :meth:`TaskTable.of`. The values live in the task's :class:`Tables` and die with the
task, unlike a module-level cache. A ``state_free`` table (one that does not depend on s0) is
shared with the tasks :meth:`hbtp.logic.task.GroundTask.from_state` makes.
"""

from __future__ import annotations

from collections.abc import Callable, Hashable
from dataclasses import dataclass
from typing import Any, Generic, Protocol, TypeVar, cast

from hbtp.collector import collector_paused

T = TypeVar("T")


class HasTables(Protocol):
    """What keeps per-task tables: a :class:`~hbtp.logic.task.GroundTask`, or the
    :class:`~hbtp.logic.names.ActionNames` of a world not grounded yet."""

    def tables(self, state_free: bool = False) -> Tables: ...


class Tables:
    """The tables one task (or a family of tasks that share them) keeps."""

    def __init__(self) -> None:
        self._values: dict[tuple[TaskTable[Any], Hashable], Any] = {}

    def get(self, table: TaskTable[T], key: Hashable, build: Callable[[], T]) -> T:
        """The value of ``table`` for ``key``, built once (not thread-safe against two first builds
        of one key: both compute the same value; one is kept). It is built with the collector paused:
        a table is many small objects without cycles, and in a world of 400k actions the collector's
        passes over them took twice as long as building the action names' grammar."""
        try:
            return cast(T, self._values[(table, key)])
        except KeyError:
            with collector_paused():
                value = self._values[(table, key)] = build()
            return value

    def clear(self) -> None:
        self._values.clear()

    def __len__(self) -> int:
        return len(self._values)


@dataclass(frozen=True, eq=False)
class TaskTable(Generic[T]):
    """One kind of per-task table: ``name`` says what it holds (for readers and messages)."""

    name: str
    state_free: bool = False

    def of(self, task: HasTables, build: Callable[[], T], key: Hashable = None) -> T:
        """The table of ``task`` (for ``key``, when one kind of table has several: the arguments it
        was built with), built by ``build()`` the first time."""
        return task.tables(self.state_free).get(self, key, build)


__all__ = ["HasTables", "Tables", "TaskTable"]
