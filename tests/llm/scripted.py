"""Helpers of the instruction-reading tests: a taught model with scripted answers, and instructions
the verbaliser wrote (never the instruction dataset) with their goals."""

from __future__ import annotations

from collections.abc import Callable, Sequence

from hbtp.domains import Scenario
from hbtp.llm.backend import PromptStyle, Reply, Request
from hbtp.train.example_set import make_examples
from hbtp.train.examples import ExampleKind


class Taught:
    """A taught model that answers with the given goals in turn (the last one again and again)."""

    name = "scripted"
    prompt_style = PromptStyle.COMPLETION
    taught = True

    def __init__(self, *replies: str) -> None:
        self.replies = list(replies)
        self.asked = 0

    def complete(self, request: Request) -> Reply:
        self.asked += 1
        return Reply(self.replies[min(self.asked, len(self.replies)) - 1], seconds=0.1)

    def close(self) -> None:
        return None


def verbalised(world: Scenario, goals: int, seed: int) -> list[tuple[str, str]]:
    """The instructions the verbaliser writes for ``goals`` goals sampled with ``seed`` (refusals
    aside), each with its goal."""
    examples = make_examples(world, goals, seed=seed)
    return [
        (example.prompt.split("Instruction:", 1)[1].rsplit("\nGoals:", 1)[0].strip(), example.goal)
        for example in (*examples.train, *examples.held_out)
        if example.kind is ExampleKind.GOAL and not example.reply.strip().startswith("Unknown")
    ]


def changed_by(
    check: Callable[[Scenario, str, str], str], world: Scenario, said: Sequence[tuple[str, str]]
) -> list[tuple[str, str]]:
    """The instructions of ``said`` (with their goals) whose goal ``check`` reads otherwise."""
    return [(text, goal) for text, goal in said if check(world, text, goal) != goal]
