"""``hbtp plan --instruction TEXT``: the goal an instruction means, asked of the LLM and checked.

The backend is ``--llm`` (``local`` when not given; ``oracle`` answers the instruction dataset's
recorded goals); the chosen goal replaces ``-g``. Planning then asks the same backend (the same
loaded model) for hints only where they can pay, as ``--llm auto`` decides: when ``--llm`` was
given and LLM-free planning finds no verdict in ``--auto-probe`` seconds. No acceptable goal:
exit 2, the attempts in ``--json``; no time left for it: exit 1.
"""

from __future__ import annotations

import logging

import click

from hbtp.cli.goal_input import read_goal
from hbtp.cli.options import echo_json
from hbtp.deadline import Deadline, TimeLimitReached
from hbtp.domains import Scenario
from hbtp.errors import BackendTimeLimit, InputError
from hbtp.files import InputKind
from hbtp.llm.backend import Backend
from hbtp.pipeline.instruct import GoalChoice, InstructOptions, goal_from_instruction, instruction_pool

log = logging.getLogger(__name__)

INSTRUCTION_HELP = (
    'What to do, in words ("put the milk in the fridge and close it"); the LLM (--llm, default local) '
    "turns it into a checked goal. @FILE reads it from a file, @- from standard input."
)

_ASKING = "asking for the goal of the instruction"

#: The backend that reads instructions when ``--llm`` is not given.
DEFAULT_INSTRUCTION_BACKEND = "local"


def choose_goal(
    loaded: Scenario, text: str, llm: Backend, options: InstructOptions, deadline: Deadline | None, *, as_json: bool
) -> GoalChoice:
    """The goal of the instruction ``text`` (``@FILE`` read) in ``loaded`` asked of ``llm`` (left
    open: it may serve the hints too) within ``deadline``, or an :class:`InputError` (after printing
    the attempts with ``as_json``) when no proposal is acceptable, :class:`TimeLimitReached` when
    the time ran out first."""
    instruction = read_goal(text, InputKind.INSTRUCTION)
    if deadline is not None:
        deadline.check(_ASKING)
    try:
        choice = goal_from_instruction(loaded, instruction, llm, instruction_pool(loaded), options, deadline)
    except BackendTimeLimit as error:
        if deadline is None:
            raise
        raise TimeLimitReached(f"{deadline.message(_ASKING)} ({error})") from None
    if choice.goal is None:
        if as_json:
            echo_json({"status": "no-goal", "scenario": loaded.name, "instruction": choice.to_dict()})
        if deadline is not None:
            deadline.check(_ASKING)
        raise InputError(choice.message)
    if not as_json:
        click.echo(
            f"goal: {choice.goal}  (from the instruction: {len(choice.attempts)} answer(s), {choice.llm_seconds:.2f} s)"
        )
    return choice


__all__ = ["DEFAULT_INSTRUCTION_BACKEND", "INSTRUCTION_HELP", "choose_goal"]
