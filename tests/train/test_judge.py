"""Judging a taught model on held-back examples (hbtp.train.evaluate.judge) as the commands ask it:
a goal's plan with the short prompt, solved in the space it names; an instruction through the
pipeline, whose checks count (a literal about something the instruction never names is dropped
before the answer is judged); a refusal of what the world lacks counts only when it stands."""

from __future__ import annotations

from collections.abc import Sequence

import pytest

from hbtp.domains import Scenario, load_scenario
from hbtp.llm.backend import PromptStyle, Reply, Request
from hbtp.llm.goal_prompt import refusal_reply, taught_goal_prompt
from hbtp.llm.prompt import taught_prompt
from hbtp.planning import plan
from hbtp.train.evaluate import judge
from hbtp.train.examples import Example, ExampleKind


@pytest.fixture(scope="module")
def virtualhome() -> Scenario:
    return load_scenario("virtualhome")


class Taught:
    """A scripted taught model: for a prompt, the replies of the first key it starts with, in turn
    (the last one again once they run out)."""

    name = "scripted"
    prompt_style = PromptStyle.COMPLETION
    taught = True

    def __init__(self, replies: dict[str, list[str]]) -> None:
        self.replies = replies
        self.prompts: list[str] = []

    def complete(self, request: Request) -> Reply:
        prompt = request.completion_prompt
        self.prompts.append(prompt)
        replies = next(replies for start, replies in self.replies.items() if prompt.startswith(start))
        return Reply(replies.pop(0) if len(replies) > 1 else replies[0], seconds=0.25)

    def close(self) -> None:
        return None


def plan_reply(scenario: Scenario, goal: str) -> str:
    result = plan(scenario.task, goal, "obtea")
    assert result.solved
    return " " + ", ".join(scenario.task.actions[i].name for i in result.executed) + "\n\n"


def examples(scenario: Scenario) -> Sequence[Example]:
    milk = "IsIn_milk_fridge"
    return (
        Example(ExampleKind.HINTS, milk, taught_prompt(milk), plan_reply(scenario, milk)),
        Example(ExampleKind.GOAL, milk, taught_goal_prompt("store the milk in the fridge"), f" {milk}\n"),
        Example(
            ExampleKind.GOAL, "IsOn_chips_sofa", taught_goal_prompt("put the piano on the sofa"), refusal_reply("piano")
        ),
        Example(
            ExampleKind.GOAL,
            "IsOn_chips_desk",
            taught_goal_prompt("put the guitar on the desk"),
            refusal_reply("guitar"),
        ),
    )


def test_a_held_back_instruction_is_judged_after_the_pipelines_checks(virtualhome: Scenario) -> None:
    milk = "IsIn_milk_fridge"
    backend = Taught({
        "Goals: IsIn_milk_fridge": [plan_reply(virtualhome, milk)],
        "Instruction: store the milk": [f" {milk} & IsOn_tv_sofa\n"],  # the TV: never named, dropped
        "Instruction: put the piano": [" Unknown: piano\n"],  # stands: the world has no piano
        # overruled (the world has a desk), then asked again without refusals
        "Instruction: put the guitar": [" Unknown: desk\n", " IsOn_chips_desk\n"],
    })  # fmt: skip
    score = judge(virtualhome, backend, examples(virtualhome))
    assert (score.examples, score.exact, score.covered, score.nf) == (1, 1.0, 1.0, 1.0)
    assert (score.instructions, score.refusals) == (3, 2)
    # the piano refused by the model; the guitar's refusal overruled (it named the desk), but the
    # goal then put the chips, never named, in the guitar's place: refused all the same
    assert score.refused == 1.0
    assert score.instruction_exact == 1.0  # and the milk read (the TV dropped)
    assert score.median_seconds == 0.25
    assert sum(p.startswith("Instruction: put the guitar") for p in backend.prompts) == 2  # asked again
