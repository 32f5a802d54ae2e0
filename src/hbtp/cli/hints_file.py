"""``hbtp plan --hints SOURCE``: hints from ``none``, ``oracle`` or a file.

A file is a dataset (text or JSONL records) or one raw LLM reply. The hints must be for the goal
asked: a file of records gives the record whose goal is that goal, and a file without one is
rejected. A file the strict dataset reader refuses (one malformed record among many) is still read
block by block, so the right record is found, with a warning naming the problem; its goal-less
blocks are never taken for another goal's hints. A raw reply without a ``Goals:`` line is taken as
the hints for the goal asked.
"""

from __future__ import annotations

import logging
import re
from dataclasses import dataclass
from pathlib import Path

from hbtp.datasets import read_dataset_file
from hbtp.datasets.records import Record
from hbtp.domains import Scenario
from hbtp.errors import DatasetError, InputError
from hbtp.files import InputKind, read_text
from hbtp.llm.parse import hints_from_record, parse_reply
from hbtp.logic.task import Goal
from hbtp.planning import Hints, Limits
from hbtp.planning.oracle import oracle_hints

log = logging.getLogger(__name__)

_GOALS_LINE = re.compile(r"^\s*Goals?\s*:(.*)$", re.IGNORECASE | re.MULTILINE)
_NO_HINTS = (
    "no hints found (expected 'Optimal Actions:' / 'Vital Action Predicates:' / "
    "'Vital Objects:' lines, or 'Heuristic Path:' / 'Relevant ...')"
)


@dataclass(frozen=True)
class HintsSource:
    """Where ``--hints`` takes the hints from: nowhere, the oracle (an optimal plan), or a file."""

    oracle: bool = False
    file: Path | None = None

    @classmethod
    def parse(cls, text: str) -> HintsSource:
        """``none``, ``oracle`` or a file name (a file named ``oracle`` or ``none``: ``./oracle``)."""
        if text == "none":
            return cls()
        if text == "oracle":
            return cls(oracle=True)
        if not text:
            raise InputError("--hints needs none, oracle or a file name")
        return cls(file=Path(text))

    @property
    def label(self) -> str:
        """``none``, ``oracle`` or ``file``, as the JSON output names it."""
        return "oracle" if self.oracle else "file" if self.file is not None else "none"

    @property
    def given(self) -> bool:
        return self.oracle or self.file is not None


def load_hints(source: HintsSource, loaded: Scenario, goal: Goal, limits: Limits) -> Hints | None:
    """No hints, the oracle's (an optimal plan) or a file's: the dataset record for ``goal`` or a raw
    LLM reply.

    Raises :class:`InputError` for a file that cannot be read, is not UTF-8, has no record for
    ``goal`` or has no hints at all.
    """
    if source.oracle:
        return oracle_hints(loaded.task, goal, loaded.mutexes, limits)
    if source.file is None:
        return None
    path = source.file
    text = read_text(path, InputKind.HINTS)
    try:
        records: list[Record] | None = read_dataset_file(path)
        problem: DatasetError | None = None
    except DatasetError as error:
        records, problem = None, error
    if records:
        matching = [r for r in records if _goal_key(loaded, r.goal) == frozenset(goal.disjuncts)]
        if not matching:
            raise InputError(f"{path}: {_none_has(len(records), goal)}")
        return hints_from_record(matching[0])
    blocks = [block for block in re.split(r"\n[ \t\r]*\n", text.removeprefix("\ufeff")) if block.strip()]
    with_goal = [(block, _GOALS_LINE.search(block)) for block in blocks]
    goal_blocks = [(block, match.group(1)) for block, match in with_goal if match is not None]
    if not goal_blocks:  # a raw reply: hints for whatever goal is asked
        parsed = parse_reply(text)
        if not parsed.found:
            raise InputError(f"{path}: {_NO_HINTS}")
        return parsed.hints
    for block, goal_text in goal_blocks:
        if _goal_key(loaded, goal_text) == frozenset(goal.disjuncts):
            parsed = parse_reply(block)
            if not parsed.found:
                raise InputError(f"{path}: the record for the goal {goal} has {_NO_HINTS}")
            if problem is not None:
                log.warning(
                    "%s is not a valid dataset file (%s); using its record for the goal %s", path, problem, goal
                )
            return parsed.hints
    reason = f" (and it is not a valid dataset file: {problem})" if problem is not None else ""
    raise InputError(f"{path}: {_none_has(len(goal_blocks), goal)}{reason}")


def _none_has(count: int, goal: Goal) -> str:
    if count == 1:
        return f"its only record is not for the goal {goal}"
    return f"none of its {count} records has the goal {goal}"


def _goal_key(loaded: Scenario, goal: str) -> frozenset[frozenset[int]] | None:
    """The goal's disjuncts as a set (what two spellings of one goal share), ``None`` if unreadable."""
    try:
        return frozenset(loaded.task.resolve_goal(goal.strip()).disjuncts)
    except InputError:
        return None
