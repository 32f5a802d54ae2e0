"""The instruction dataset: what a person says, paired with the goal it means (issue 11).

One JSON-lines file per shipped scenario (``data/instructions/<scenario>.jsonl``). Each line is
``{"id", "task", "goal", "instructions"}``: ``goal`` in the goal syntax of :mod:`hbtp.logic.goals`
(``&``, ``|``, ``~``), ``instructions`` two or more phrasings of it (imperative, indirect), and
``task`` the record number in the scenario's Table II test set when the goal is that record's, or
``null`` for goals written for this dataset (the disjunctive and negative ones among them).
"""

from __future__ import annotations

import functools
import json
from dataclasses import dataclass
from importlib import resources

from hbtp.errors import InputError

DATA = resources.files("hbtp.datasets") / "data" / "instructions"
KEYS = ("id", "task", "goal", "instructions")


@dataclass(frozen=True)
class InstructionRecord:
    """One goal and the instructions that ask for it."""

    id: str
    scenario: str
    goal: str
    instructions: tuple[str, ...]
    task: int | None = None  # the Table II test-set record with this goal, if any


def instruction_scenarios() -> tuple[str, ...]:
    """The scenarios with an instruction file, sorted."""
    return tuple(sorted(entry.name.removesuffix(".jsonl") for entry in DATA.iterdir() if entry.name.endswith(".jsonl")))


def load_instructions(scenario: str) -> tuple[InstructionRecord, ...]:
    """The instruction records of a shipped scenario; :class:`InputError` naming the choices."""
    if scenario not in instruction_scenarios():
        raise InputError(
            f"no instruction dataset for scenario {scenario!r}; choose one of: {', '.join(instruction_scenarios())}"
        )
    return _load(scenario)


@functools.cache
def _load(scenario: str) -> tuple[InstructionRecord, ...]:
    name = f"{scenario}.jsonl"
    records: list[InstructionRecord] = []
    for number, line in enumerate((DATA / name).read_text(encoding="utf-8").splitlines(), 1):
        if line.strip():
            records.append(_record(json.loads(line), scenario, f"{name}:{number}"))
    return tuple(records)


def _record(data: object, scenario: str, where: str) -> InstructionRecord:
    if not isinstance(data, dict) or tuple(data) != KEYS:
        raise InputError(f"{where}: expected an object with the keys {', '.join(KEYS)}")
    instructions = data["instructions"]
    if not isinstance(instructions, list) or not all(isinstance(i, str) and i.strip() for i in instructions):
        raise InputError(f"{where}: instructions must be a list of non-empty strings")
    task = data["task"]
    if task is not None and not isinstance(task, int):
        raise InputError(f"{where}: task must be a record number or null")
    return InstructionRecord(str(data["id"]), scenario, str(data["goal"]), tuple(instructions), task)


__all__ = ["InstructionRecord", "instruction_scenarios", "load_instructions"]
