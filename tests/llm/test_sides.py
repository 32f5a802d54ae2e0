"""A goal's alternatives taken from the sides of an instruction's "or" (:mod:`hbtp.pipeline.sides`).
Sentences written for these tests, not taken from the instruction dataset."""

from __future__ import annotations

import pytest
from scripted import Taught, changed_by, verbalised

from hbtp.domains import load_scenario
from hbtp.pipeline.instruct import InstructOptions, goal_from_instruction
from hbtp.pipeline.sides import sides_as_said


@pytest.mark.parametrize(
    ("name", "text", "goal", "read"),
    [
        # choices of several literals joined wrong: "either ..., or", "otherwise", "if that's ..."
        ("robothow-small", "Either put the apple in the fridge and shut it, or leave the apple on the kitchen table.",
         "IsIn_apple_fridge & IsOn_apple_kitchentable | IsClose_fridge",
         "IsIn_apple_fridge & IsClose_fridge | IsOn_apple_kitchentable"),
        ("robothow-small", "Chop the apple and put it on the kitchen table; otherwise the wine in the fridge will do.",
         "IsCut_apple & IsOn_apple_kitchentable & IsIn_wine_fridge",
         "IsCut_apple & IsOn_apple_kitchentable | IsIn_wine_fridge"),
        ("robowaiter", "Make a coffee and bring it to table 2; if that's a bother, chips on table 2 are fine.",
         "Exists_Coffee & On_Coffee_Table2 & On_Chips_Table2", "Exists_Coffee & On_Coffee_Table2 | On_Chips_Table2"),
        # a literal belongs to the side of the last object only that side names ("leave it on the kitchen table")
        ("robothow-small", "Put the apple in the fridge, or if there's no room leave it on the kitchen table.",
         "IsIn_apple_fridge & IsOn_apple_kitchentable", "IsIn_apple_fridge | IsOn_apple_kitchentable"),
        # the items of a list an "or" ends are sides too
        ("robothow-small", "Put the apple in the fridge, the cutlets on the table, or the wine in the microwave.",
         "IsIn_apple_fridge & IsOn_cutlets_kitchentable | IsIn_wine_microwave",
         "IsIn_apple_fridge | IsOn_cutlets_kitchentable | IsIn_wine_microwave"),
        # not the items of a list joined by "and": its last item is one side
        ("robowaiter", "Turn on the AC, chips on table 1 and a coffee on table 2; or, if not, a yogurt on table 3.",
         "Active_AC | On_Chips_Table1 | On_Coffee_Table2 | On_Yogurt_Table3",
         "Active_AC & On_Chips_Table1 & On_Coffee_Table2 | On_Yogurt_Table3"),
        # unchanged: grouped as said already, one side only, a list, a negation, no cut, "if" not pointing back
        ("robothow-small", "Either put the apple in the fridge and shut it, or leave the apple on the kitchen table.",
         "IsIn_apple_fridge & IsClose_fridge | IsOn_apple_kitchentable",
         "IsIn_apple_fridge & IsClose_fridge | IsOn_apple_kitchentable"),
        ("robowaiter", "A yogurt, or a milk drink for table 3.", "On_Yogurt_Table3 | On_MilkDrink_Table3",
         "On_Yogurt_Table3 | On_MilkDrink_Table3"),
        ("robothow-small", "Put the apple, the cutlets, or the wine on the kitchen table.",
         "IsOn_apple_kitchentable | IsOn_cutlets_kitchentable | IsOn_wine_kitchentable",
         "IsOn_apple_kitchentable | IsOn_cutlets_kitchentable | IsOn_wine_kitchentable"),
        ("robothow-small", "Put the apple on the kitchen table, or rather don't switch on the TV.",
         "IsOn_apple_kitchentable & ~IsSwitchedOn_tv", "IsOn_apple_kitchentable & ~IsSwitchedOn_tv"),
        ("robothow-small", "Put the apple in the fridge and the cutlets on the kitchen table.",
         "IsIn_apple_fridge | IsOn_cutlets_kitchentable", "IsIn_apple_fridge | IsOn_cutlets_kitchentable"),
        ("robothow-small", "Put the apple in the fridge and, if you can, the cutlets on the kitchen table.",
         "IsIn_apple_fridge & IsOn_cutlets_kitchentable", "IsIn_apple_fridge & IsOn_cutlets_kitchentable"),
    ],
)  # fmt: skip
def test_alternatives_are_taken_from_the_sides_of_an_or(name: str, text: str, goal: str, read: str) -> None:
    assert sides_as_said(load_scenario(name), text, goal) == read


def test_generated_instructions_keep_their_alternatives() -> None:
    """The verbaliser's goals are never regrouped (RobotHow-Small and RoboWaiter, their own goals),
    among them alternatives of several literals."""
    for name in ("robothow-small", "robowaiter"):
        world = load_scenario(name)
        said = verbalised(world, 120, seed=17)
        assert len([goal for _, goal in said if "|" in goal]) >= 5
        assert changed_by(sides_as_said, world, said) == []


def test_a_taught_models_choices_are_read_as_the_instruction_offers_them() -> None:
    world = load_scenario("robothow-small")
    text = "Either put the apple in the fridge and shut it, or leave the apple on the kitchen table."
    reply = "IsIn_apple_fridge & IsOn_apple_kitchentable | IsClose_fridge"
    read = goal_from_instruction(world, text, Taught(reply))
    assert read.goal == "IsIn_apple_fridge & IsClose_fridge | IsOn_apple_kitchentable"
    kept = goal_from_instruction(world, text, Taught(reply), options=InstructOptions(group_as_said=False))
    assert kept.goal is None  # as the model joined them, the fridge is closed at the start: nothing to do
    assert "already holds at the start" in kept.message
