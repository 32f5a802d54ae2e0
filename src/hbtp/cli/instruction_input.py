"""``hbtp plan --instruction TEXT``: the goal an instruction means, asked of the LLM and checked.

The backend is ``--llm`` (``local`` when not given; ``oracle`` answers the instruction dataset's
recorded goals); the chosen goal replaces ``-g`` and planning proceeds as usual (with the LLM loop
only when ``--llm`` was given). No acceptable goal: exit 2, the attempts in ``--json``.
"""

from __future__ import annotations

import logging
from dataclasses import replace

import click

from hbtp.cli.goal_input import read_goal
from hbtp.cli.options import echo_json
from hbtp.domains import Scenario
from hbtp.errors import InputError
from hbtp.files import InputKind
from hbtp.llm.backends.registry import BackendOptions, make_goal_backend
from hbtp.pipeline.instruct import GoalChoice, InstructOptions, goal_from_instruction, instruction_pool

log = logging.getLogger(__name__)

INSTRUCTION_HELP = (
    'What to do, in words ("put the milk in the fridge and close it"); the LLM (--llm, default local) '
    "turns it into a checked goal. @FILE reads it from a file, @- from standard input."
)

#: The backend that reads instructions when ``--llm`` is not given.
DEFAULT_INSTRUCTION_BACKEND = "local"


def choose_goal(
    loaded: Scenario, text: str, spec: str | None, backend: BackendOptions, *, rounds: int, as_json: bool
) -> GoalChoice:
    """The goal of the instruction ``text`` (``@FILE`` read) in ``loaded``, or an :class:`InputError`
    (after printing the attempts with ``as_json``) when no proposal is acceptable."""
    instruction = read_goal(text, InputKind.INSTRUCTION)
    llm = make_goal_backend(spec or DEFAULT_INSTRUCTION_BACKEND, loaded, replace(backend, record=backend.record))
    try:
        choice = goal_from_instruction(
            loaded, instruction, llm, instruction_pool(loaded), InstructOptions(rounds=rounds, seed=backend.seed)
        )
    finally:
        llm.close()
    if choice.goal is None:
        if as_json:
            echo_json({"status": "no-goal", "scenario": loaded.name, "instruction": choice.to_dict()})
        raise InputError(choice.message)
    if not as_json:
        click.echo(
            f"goal: {choice.goal}  (from the instruction: {len(choice.attempts)} answer(s), {choice.llm_seconds:.2f} s)"
        )
    return choice


__all__ = ["DEFAULT_INSTRUCTION_BACKEND", "INSTRUCTION_HELP", "choose_goal"]
