"""The examples a model is taught with, and the ones held back to measure it.

Labelled goals (:func:`hbtp.train.examples.sample_records`) are split first and held back whole: a
held-back goal is in no training example of either kind (hints, :mod:`hbtp.train.examples`;
instructions, :mod:`hbtp.train.goal_examples`).
"""

from __future__ import annotations

import random
from dataclasses import dataclass

from hbtp.collector import searches_collected
from hbtp.domains import Scenario
from hbtp.errors import InputError
from hbtp.train.examples import Example, check_disjoint, everyday, held_goals, hints_example, sample_records, split
from hbtp.train.goal_examples import PER_GOAL, goal_examples

#: Changes whenever the same request makes other examples (a resumed run never mixes the two).
EXAMPLES_FORMAT = 2


@dataclass(frozen=True)
class ExampleSet:
    """The examples trained on, and the ones held back to measure the model."""

    train: tuple[Example, ...]
    held_out: tuple[Example, ...]
    #: Sampled goals left out because an evaluation set holds them.
    dropped: int = 0
    #: The action predicates of actions the training replies leave to the check (abridged labels).
    filled: tuple[str, ...] = ()


def make_examples(
    scenario: Scenario,
    count: int,
    *,
    seed: int = 0,
    held_out: float = 0.1,
    max_expansions: int = 20_000,
    instructions: bool = True,
    abridge: bool = False,
    hints: bool = True,
) -> ExampleSet:
    """The examples of ``scenario`` (see the module docstring), checked disjoint from its evaluation
    sets; :class:`InputError` when the world is too small to sample from.

    Labelled goals are held back whole: a held-back goal is in no training example of either kind.
    With ``instructions``, each goal of everyday activity (:func:`~hbtp.train.examples.everyday`) also
    gives :data:`~hbtp.train.goal_examples.PER_GOAL` instruction examples (:mod:`hbtp.train.goal_examples`).
    With ``abridge``, a reply leaves out the actions the check puts back (:mod:`hbtp.train.abridge`).
    Without ``hints``, the goals -> plans examples are left out (an adapter that only reads
    instructions, beside one that gives the hints); both sets are made of the same split.

    Thousands of small searches label them: their objects go to the collector as they finish
    (:func:`hbtp.collector.searches_collected`), not frozen as a command's searches are."""
    with searches_collected():
        return _make_examples(scenario, count, seed, held_out, max_expansions, (hints, instructions), abridge)


def _make_examples(
    scenario: Scenario,
    count: int,
    seed: int,
    held_out: float,
    max_expansions: int,
    taught: tuple[bool, bool],
    abridge: bool,
) -> ExampleSet:
    hints, instructions = taught
    if not (hints or instructions):
        raise InputError("nothing to teach: goals -> hints and instructions -> goals are both left out")
    records, dropped = sample_records(scenario, count, seed, max_expansions)
    if len(records) < 2:
        raise InputError(
            f"{scenario.name}: only {len(records)} distinct goal(s) could be sampled; the world is too small to "
            "teach a model (it needs actions that change the state from s0)"
        )
    parts = []
    filled: set[str] = set()
    for index, part in enumerate(split(records, held_out, seed)):
        labelled = [hints_example(record, scenario.task, abridge=abridge) for record in part] if hints else []
        examples = [example for example, _ in labelled]
        if index == 0:
            filled.update(p for _, left_out in labelled for p in left_out)
        if instructions:
            examples += goal_examples(scenario, everyday(part), seed * 2 + index, PER_GOAL)
        random.Random(f"order|{seed}|{index}").shuffle(examples)
        parts.append(tuple(examples))
    check_disjoint((e for part in parts for e in part), held_goals(scenario), scenario.name)
    return ExampleSet(parts[0], parts[1], dropped, tuple(sorted(filled)))


__all__ = ["EXAMPLES_FORMAT", "ExampleSet", "make_examples"]
