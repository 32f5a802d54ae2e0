"""Training examples for a taught model, labelled by the planner, never from an evaluation set.

A hints example is a sampled goal (:func:`hbtp.planning.generate.sample_goals`: always solvable,
labelled with a cost-optimal plan) as the short prompt a taught model is asked
(:func:`hbtp.llm.prompt.taught_prompt`) and the reply it must give: the plan, its action predicates
and objects (:func:`hbtp.llm.prompt.taught_reply`). Goals come from several difficulty levels.

No goal of an evaluation set is trained on: the paper's Table I and Table II sets and the shipped
instruction dataset of the world's scenario. They are left out while sampling, and
:func:`check_disjoint` refuses a set that holds one (:class:`LeakError`). A share of the examples
is held back (never trained on) to measure the taught model.
"""

from __future__ import annotations

import contextlib
import enum
import random
from collections.abc import Iterable, Sequence
from dataclasses import dataclass, replace
from typing import TypeVar

from hbtp.datasets import dataset_names, load_dataset
from hbtp.datasets.instructions import instruction_scenarios, load_instructions
from hbtp.datasets.records import Record
from hbtp.datasets.shipped import DATASET_SCENARIO
from hbtp.domains import Scenario
from hbtp.errors import InputError
from hbtp.llm.backends.adapters import PROMPT_FORMAT, SPELLINGS
from hbtp.llm.prompt import taught_prompt, taught_reply
from hbtp.logic.goals import parse_goal
from hbtp.logic.task import GroundTask
from hbtp.planning.generate import LEVELS, Draw, Sampling, generate_records
from hbtp.train.abridge import abridged

_T = TypeVar("_T")

#: A goal as a set of disjuncts, each a set of literals in the datasets' spelling: two spellings of
#: one goal (other order, other spaces) have the same key.
GoalKey = frozenset[frozenset[str]]

#: The difficulty levels examples are drawn from, where their literals come from, and their shares:
#: half near s0 (random walks: the paper's easy, medium and hard tasks and the demonstration pools'
#: wider mix) and half from every reachable atom (goals whose plans fetch a tool or prepare an
#: appliance first: a model taught only walk goals stops short on those).
LEVEL_SHARES: tuple[tuple[str, Draw, float], ...] = (
    ("any", Draw.WALK, 0.2),
    ("easy", Draw.WALK, 0.1),
    ("medium", Draw.WALK, 0.1),
    ("hard", Draw.WALK, 0.1),
    ("any", Draw.REACHABLE, 0.35),
    ("hard", Draw.REACHABLE, 0.15),
)


class LeakError(InputError):
    """Training examples that hold a goal of an evaluation set."""


class ExampleKind(enum.Enum):
    """What an example teaches: the hints of a goal, or the goal of an instruction."""

    HINTS = "hints"
    GOAL = "goal"


@dataclass(frozen=True)
class Example:
    """One prompt and the reply the model learns for it."""

    kind: ExampleKind
    goal: str
    prompt: str
    reply: str

    def to_dict(self) -> dict[str, str]:
        return {"kind": self.kind.value, "goal": self.goal, "prompt": self.prompt, "reply": self.reply}

    @classmethod
    def from_dict(cls, data: dict[str, str]) -> Example:
        return cls(ExampleKind(data["kind"]), data["goal"], data["prompt"], data["reply"])


def goal_key(goal: str) -> GoalKey:
    """The key of a goal text (see :data:`GoalKey`)."""
    return frozenset(frozenset(atom.underscored for atom in term) for term in parse_goal(goal))


def evaluation_goals(scenario: str) -> frozenset[GoalKey]:
    """The goals of every evaluation set of ``scenario``: its Table I and Table II test sets (every
    shipped dataset of the scenario but the few-shot pools) and its instruction dataset."""
    keys: set[GoalKey] = set()
    for name in dataset_names():
        if DATASET_SCENARIO.get(name) == scenario and not name.startswith("fewshot_"):
            keys.update(goal_key(record.goal) for record in load_dataset(name))
    if scenario in instruction_scenarios():
        keys.update(goal_key(record.goal) for record in load_instructions(scenario))
    return frozenset(keys)


def check_disjoint(examples: Iterable[Example], held: frozenset[GoalKey], name: str) -> None:
    """Refuse examples that hold one of the ``held`` goals (:class:`LeakError`)."""
    leaked = sorted({example.goal for example in examples if goal_key(example.goal) in held})
    if leaked:
        shown = ", ".join(leaked[:3]) + (f" and {len(leaked) - 3} more" if len(leaked) > 3 else "")
        raise LeakError(f"{len(leaked)} training goal(s) belong to an evaluation set of {name!r}: {shown}")


def hints_example(record: Record, task: GroundTask, *, abridge: bool = False) -> tuple[Example, frozenset[str]]:
    """A labelled goal of ``task`` as the prompt a taught model is asked and the reply it learns
    (the plan in the spelling of the prompt format taught now; with ``abridge``, without the actions
    the check puts back: :func:`hbtp.train.abridge.abridged`), and the action predicates of the
    actions left out."""
    plan = [task.action(name) for name in record.optimal_actions]
    said = abridged(task, task.resolve_goal(record.goal), plan) if abridge else tuple(plan)
    kept = {action.index for action in said}
    left_out = frozenset(action.predicate for action in plan if action.index not in kept)
    reply = taught_reply((action.signature for action in said), SPELLINGS[PROMPT_FORMAT])
    return Example(ExampleKind.HINTS, record.goal, taught_prompt(record.goal), reply), left_out


def held_goals(scenario: Scenario) -> frozenset[GoalKey]:
    """The goals no example may have: the evaluation sets' (:func:`evaluation_goals`) and the
    problem's own ``:goal`` (an IPC instance's task is an evaluation task too)."""
    held = set(evaluation_goals(scenario.name))
    with contextlib.suppress(InputError):  # no :goal (the shipped scenarios' problems)
        held.add(goal_key(scenario.problem_goal()))
    return frozenset(held)


def sample_records(scenario: Scenario, count: int, seed: int, max_expansions: int) -> tuple[list[Record], int]:
    """About ``count`` labelled goals, distinct, over the levels of :data:`LEVEL_SHARES`, none of an
    evaluation set; and how many sampled goals were left out for being one."""
    held = held_goals(scenario)
    seen: set[GoalKey] = set()
    records: list[Record] = []
    dropped = 0
    for offset, (level, draw, share) in enumerate(LEVEL_SHARES):
        sampling = Sampling(seed=seed * 1_000 + offset, max_expansions=max_expansions, draw=draw)
        wanted = max(1, round(count * share))
        for record in generate_records(scenario.task, LEVELS[level], wanted, sampling, scenario.mutexes):
            record = replace(record, id=f"{draw.value}-{level}-{record.id}")
            key = goal_key(record.goal)
            if key in held:
                dropped += 1
            elif key not in seen:
                seen.add(key)
                records.append(record)
    return records, dropped


def everyday(records: Iterable[Record]) -> list[Record]:
    """The records of :func:`sample_records` whose goals are the ends of random walks
    (:data:`Draw.WALK <hbtp.planning.generate.Draw>`: their ids start with ``walk-``)."""
    return [record for record in records if record.id.startswith(f"{Draw.WALK.value}-")]


def split(records: Sequence[_T], held_out: float, seed: int) -> tuple[list[_T], list[_T]]:
    """Shuffle ``records`` (seeded) and hold back the share ``held_out`` of them."""
    if not 0 <= held_out < 1:
        raise InputError(f"the held-out share must be at least 0 and below 1, not {held_out}")
    order = list(records)
    random.Random(seed).shuffle(order)
    kept = round(len(order) * held_out)
    return order[kept:], order[:kept]


__all__ = [
    "LEVEL_SHARES",
    "Example",
    "ExampleKind",
    "GoalKey",
    "LeakError",
    "check_disjoint",
    "evaluation_goals",
    "everyday",
    "goal_key",
    "held_goals",
    "hints_example",
    "sample_records",
    "split",
]
