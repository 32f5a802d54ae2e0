"""Deeds an instruction asks for that a taught model's goal leaves out (:mod:`hbtp.pipeline.deeds`),
and the goal continued with them. Sentences written for these tests, not taken from the
instruction dataset."""

from __future__ import annotations

import pytest
from scripted import Taught, verbalised

from hbtp.domains import load_scenario
from hbtp.logic.goals import parse_goal
from hbtp.pipeline.deeds import unanswered
from hbtp.pipeline.instruct import InstructOptions, goal_from_instruction


def _asked(text: str, goal: str) -> list[list[str]]:
    return [
        [a.underscored for a in offered] for offered in unanswered(load_scenario("robothow"), text, parse_goal(goal)[0])
    ]


@pytest.mark.parametrize(
    ("text", "goal", "asked"),
    [
        # a deed of a clause no literal answers: what it says, of the thing "it" may stand for
        ("Put the plate in the dishwasher and run it.", "IsIn_plate_dishwasher", [["IsSwitchedOn_dishwasher"]]),
        ("Put the milk in the microwave and close it.", "IsIn_milk_microwave", [["IsClose_microwave", "IsClose_milk"]]),
        # answered, negated, words inside a name, the robot itself, a part, a thing said short
        ("Put the plate in the dishwasher and run it.", "IsIn_plate_dishwasher & IsSwitchedOn_dishwasher", []),
        ("Put the plate in the dishwasher but don't run it.", "IsIn_plate_dishwasher", []),
        ("Put a slice of bread on the desk.", "IsOn_breadslice_desk", []),
        ("Put the apple on the desk and stand next to it.", "IsOn_apple_desk", []),
        ("Put the milk in the microwave and shut the door.", "IsIn_milk_microwave", []),
        ("Put the soap in the bathroom cabinet and close the cabinet.",
         "IsIn_barsoap_bathroomcabinet & IsClose_bathroomcabinet", []),
    ],
)  # fmt: skip
def test_a_clause_no_literal_answers_asks_for_what_it_says(text: str, goal: str, asked: list[list[str]]) -> None:
    assert [sorted(offered) for offered in _asked(text, goal)] == asked


def test_generated_instructions_ask_for_nothing_their_goals_leave_out() -> None:
    for name in ("robowaiter", "robothow-small"):
        world = load_scenario(name)
        said = [(text, goal) for text, goal in verbalised(world, 120, seed=13) if "|" not in goal]
        assert len(said) >= 50
        assert [(text, goal) for text, goal in said if unanswered(world, text, parse_goal(goal)[0])] == []


def test_a_taught_models_goal_is_continued_with_the_deeds_it_leaves_out() -> None:
    world = load_scenario("robothow")
    text = "The plate is dirty - put it in the dishwasher and run it."
    one = Taught("IsIn_plate_dishwasher")
    assert goal_from_instruction(world, text, one).goal == "IsIn_plate_dishwasher & IsSwitchedOn_dishwasher"
    assert one.asked == 1  # one literal said: the model is not asked
    several = Taught("IsIn_milk_microwave", "IsClose_microwave")
    chosen = goal_from_instruction(world, "Put the milk in the microwave and close it.", several)
    assert chosen.goal == "IsIn_milk_microwave & IsClose_microwave"
    assert several.asked == 2  # the model chose
    kept = goal_from_instruction(world, text, Taught("IsIn_plate_dishwasher"), options=InstructOptions(cover=False))
    assert kept.goal == "IsIn_plate_dishwasher"
