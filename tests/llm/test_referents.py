"""A taught model's literals about things said short or by a part (:mod:`hbtp.pipeline.referents`),
and about two things the instruction never names together (:mod:`hbtp.pipeline.apart`). Sentences
written for these tests, not taken from the instruction dataset."""

from __future__ import annotations

import random

import pytest
from scripted import Taught, changed_by, verbalised

from hbtp.domains import load_scenario
from hbtp.domains.words import words_for
from hbtp.pipeline.apart import apart_mended
from hbtp.pipeline.instruct import InstructOptions, goal_from_instruction
from hbtp.pipeline.referents import referents_read
from hbtp.train.verbalise import verbalise


@pytest.mark.parametrize(
    ("text", "goal", "read"),
    [
        # a short name for a thing named before, a literal the goal holds about that thing: one literal
        ("Put the soap in the bathroom cabinet and close the cabinet.",
         "IsIn_barsoap_bathroomcabinet & IsClose_bathroomcabinet & IsClose_cabinet",
         "IsIn_barsoap_bathroomcabinet & IsClose_bathroomcabinet"),
        # a part said right after its thing: the thing
        ("Open the fridge door and put the milk inside.", "IsOpen_door & IsIn_milk_fridge",
         "IsOpen_fridge & IsIn_milk_fridge"),
        ("Put the juice in the kitchen cabinet and close the cabinet door.",
         "IsIn_juice_kitchencabinet & IsClose_cabinet & IsClose_door",
         "IsIn_juice_kitchencabinet & IsClose_kitchencabinet"),
        # a short name may mean the other thing when the goal does not say it twice; two things
        # listed, the short name first, a part on its own: as they are
        ("Put the juice in the kitchen cabinet, then shut the cabinet.",
         "IsIn_juice_kitchencabinet & IsClose_cabinet", "IsIn_juice_kitchencabinet & IsClose_cabinet"),
        ("Close the kitchen cabinet and the cabinet.", "IsClose_kitchencabinet & IsClose_cabinet",
         "IsClose_kitchencabinet & IsClose_cabinet"),
        ("Close the cabinet, then open the kitchen cabinet.", "IsClose_cabinet & IsOpen_kitchencabinet",
         "IsClose_cabinet & IsOpen_kitchencabinet"),
        ("Open the door.", "IsOpen_door", "IsOpen_door"),
        ("Put the apple in the bookshelf. The door has to be clean.", "IsIn_apple_bookshelf & IsClean_door",
         "IsIn_apple_bookshelf & IsClean_door"),
    ],
)  # fmt: skip
def test_a_thing_said_short_or_by_a_part_is_the_thing_meant(text: str, goal: str, read: str) -> None:
    assert referents_read(load_scenario("robothow"), text, goal) == read


@pytest.mark.parametrize(
    ("text", "goal"),
    [
        # "there" speaks of the place named before
        ("I'll be at table 2 in a minute; could you have a coffee waiting there?", "On_Coffee_Table2 & Holding_Coffee"),
        # the span about just one of its things says where the robot should be: not a state of the thing
        ("I'll be at the bar soon. A coffee, please!", "On_Coffee_Bar & Holding_Coffee"),
    ],
)  # fmt: skip
def test_a_place_said_there_or_a_fact_about_the_robot_keeps_the_literal(text: str, goal: str) -> None:
    assert apart_mended(load_scenario("robowaiter"), text, goal) == goal


@pytest.mark.parametrize(
    ("text", "goal", "read"),
    [
        # the clause that says the kind names one of its things and one more: that one
        ("Put the cutlets in the frying pan, then put the pan on the stove.",
         "IsIn_cutlets_fryingpan & IsOn_cutlets_stove", "IsIn_cutlets_fryingpan & IsOn_fryingpan_stove"),
        # the span about just one of its things says a state of it: that state
        ("Put the apple on the desk, close the fridge, and make sure the TV is off.",
         "IsOn_apple_desk & IsClose_fridge & IsOn_tv_desk", "IsOn_apple_desk & IsClose_fridge & IsSwitchedOff_tv"),
        # named together: in a list cut by commas, by a pronoun
        ("Put the apple, the book and the plate on the desk.",
         "IsOn_apple_desk & IsOn_book_desk & IsOn_plate_desk", "IsOn_apple_desk & IsOn_book_desk & IsOn_plate_desk"),
        ("Walk over to the desk; then put the apple on it.", "IsNear_self_desk & IsOn_apple_desk",
         "IsNear_self_desk & IsOn_apple_desk"),
        # the kind said in plain words only ("on the table" may be another table), a negated span,
        # a thing that would be lost: as they are
        ("Put the plate on the kitchen table, with the apple near the plate on the table.",
         "IsOn_plate_kitchentable & IsOn_apple_kitchentable", "IsOn_plate_kitchentable & IsOn_apple_kitchentable"),
        ("Put the apple on the desk; the TV should not be off.", "IsOn_apple_desk & IsOn_tv_desk",
         "IsOn_apple_desk & IsOn_tv_desk"),
        ("Put the cutlets in the frying pan, then put the pan on the stove.", "IsOn_cutlets_stove",
         "IsOn_cutlets_stove"),
    ],
)  # fmt: skip
def test_a_literal_about_two_things_never_named_together_takes_what_is_said(text: str, goal: str, read: str) -> None:
    assert apart_mended(load_scenario("robothow"), text, goal) == read


def test_generated_instructions_keep_their_literals() -> None:
    """The verbaliser's own goals are read as they are: sampled ones (RoboWaiter, with its spring
    water and water; RobotHow-Small), and RobotHow goals about its cabinets and its door."""
    for name in ("robowaiter", "robothow-small"):
        world = load_scenario(name)
        said = verbalised(world, 120, seed=13)
        assert len([goal for _, goal in said if "&" in goal]) >= 20
        assert changed_by(referents_read, world, said) == []
        assert changed_by(apart_mended, world, said) == []
    world = load_scenario("robothow")
    words, rng = words_for(world), random.Random(13)
    goals = ["IsIn_juice_bathroomcabinet & IsClose_cabinet", "IsOpen_door & IsIn_milk_fridge & IsClose_fridge",
             "IsClose_kitchencabinet & IsClean_door & IsOn_apple_cabinet",
             "IsIn_barsoap_cabinet & IsOpen_bathroomcabinet",
             "IsOn_candle_bookshelf & IsSwitchedOff_tv & IsOn_apple_desk"]  # fmt: skip
    said = [(text, goal) for goal in goals for text in verbalise(goal, words, rng, 40)]
    assert changed_by(referents_read, world, said) == []
    assert changed_by(apart_mended, world, said) == []


def test_a_taught_models_goal_is_read_about_the_things_meant() -> None:
    world = load_scenario("robothow")
    text = "Put the juice in the kitchen cabinet and close the cabinet door; make sure the candle is off."
    reply = "IsIn_juice_kitchencabinet & IsClose_door & IsOn_candle_kitchencabinet"
    chosen = goal_from_instruction(world, text, Taught(reply))
    assert chosen.goal == "IsIn_juice_kitchencabinet & IsClose_kitchencabinet & IsSwitchedOff_candle"
    kept = goal_from_instruction(
        world, text, Taught(reply), options=InstructOptions(place_named=False, drop_unsaid=False)
    )
    assert kept.goal == reply
