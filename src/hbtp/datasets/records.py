"""One dataset record: a goal with its solution path and the vital predicates and objects.

A record is what one block of a dataset file says, kept as text: the goal as written
(``IsIn_milk_fridge & IsClose_fridge``), the actions as written (``Walk_milk``). Resolving those
names against a domain is :mod:`hbtp.datasets.validate`'s job, so reading a file never needs a
scenario.

:meth:`Record.to_dict` and :meth:`Record.from_dict` are the JSON form used by the JSONL files.
"""

from __future__ import annotations

from collections.abc import Mapping
from dataclasses import dataclass, field
from typing import Any

from hbtp.datasets.reply import format_reply
from hbtp.errors import InputError

_LIST_FIELDS = ("optimal_actions", "vital_predicates", "vital_objects")
_TEXT_FIELDS = ("id", "goal", "instruction", "environment")
_KEYS = frozenset((*_TEXT_FIELDS, *_LIST_FIELDS, "cost"))
_REQUIRED = ("id", "goal", *_LIST_FIELDS)
#: Declared costs are below this (at most 18 digits), in both file formats.
MAX_COST = 10**18


@dataclass(frozen=True, slots=True)
class Record:
    """A dataset record.

    ``goal`` and ``instruction`` are kept verbatim (a shipped file's stray spaces included), so
    that writing a record back reproduces its source. ``optimal_actions`` is the record's solution
    path p̂ (empty when the goal already holds in s0); ``cost`` is its declared cost, when the file
    gives one. ``line`` is the 1-based line where the record starts in its source (0 when it was
    built in memory); it takes no part in equality.
    """

    id: str
    goal: str
    optimal_actions: tuple[str, ...]
    vital_predicates: tuple[str, ...]
    vital_objects: tuple[str, ...]
    instruction: str = ""
    environment: str = "1"
    cost: int | None = None
    line: int = field(default=0, compare=False)

    def reply_block(self) -> str:
        """The record's plan, vital predicates and vital objects as the three lines of a reply."""
        return format_reply(self.optimal_actions, self.vital_predicates, self.vital_objects)

    def to_dict(self) -> dict[str, Any]:
        """The JSON object of this record (``line`` is not part of it; ``cost`` only when known)."""
        data: dict[str, Any] = {
            "id": self.id,
            "environment": self.environment,
            "instruction": self.instruction,
            "goal": self.goal,
            "optimal_actions": list(self.optimal_actions),
            "vital_predicates": list(self.vital_predicates),
            "vital_objects": list(self.vital_objects),
        }
        if self.cost is not None:
            data["cost"] = self.cost
        return data

    @classmethod
    def from_dict(cls, data: Mapping[str, Any], line: int = 0) -> Record:
        """Build a record from its JSON object, checking keys and types.

        Raises :class:`~hbtp.errors.InputError` naming the offending key; the JSONL reader adds
        the file and line.
        """
        if not isinstance(data, Mapping):
            raise InputError(f"expected a JSON object, got {type(data).__name__}")
        unknown = sorted(set(data) - _KEYS)
        if unknown:
            raise InputError(f"unknown key(s) {', '.join(map(repr, unknown))} (expected: {', '.join(sorted(_KEYS))})")
        missing = [key for key in _REQUIRED if key not in data]
        if missing:
            raise InputError(f"missing key(s) {', '.join(map(repr, missing))}")
        for key in _TEXT_FIELDS:
            if key in data and not isinstance(data[key], str):
                raise InputError(f"{key!r} must be a string, got {type(data[key]).__name__}")
        if not data["id"]:
            raise InputError("'id' must not be empty")
        lists: dict[str, tuple[str, ...]] = {}
        for key in _LIST_FIELDS:
            value = data[key]
            if not isinstance(value, list) or not all(isinstance(item, str) for item in value):
                raise InputError(f"{key!r} must be a list of strings")
            lists[key] = tuple(value)
        cost = data.get("cost")
        if cost is not None and (isinstance(cost, bool) or not isinstance(cost, int)):
            raise InputError(f"'cost' must be an integer or null, got {cost!r}")
        if cost is not None and not 0 <= cost < MAX_COST:
            shown = str(cost) if len(str(cost)) <= 40 else f"{str(cost)[:40]}... ({len(str(cost))} digits)"
            raise InputError(f"'cost' must be a non-negative integer below 10**18, got {shown}")
        return cls(
            id=data["id"],
            goal=data["goal"],
            optimal_actions=lists["optimal_actions"],
            vital_predicates=lists["vital_predicates"],
            vital_objects=lists["vital_objects"],
            instruction=data.get("instruction", ""),
            environment=data.get("environment", "1"),
            cost=cost,
            line=line,
        )
