"""A taught model's literals whose kind of fact the instruction never speaks of
(:mod:`hbtp.pipeline.unspoken`): left out when they name nothing new. Sentences written for these
tests, not taken from the instruction dataset."""

from __future__ import annotations

import random
from pathlib import Path

import pytest
from scripted import Taught, changed_by, verbalised

from hbtp.domains import Scenario, load_scenario
from hbtp.domains.scenarios import ScenarioOptions, load_pddl_scenario
from hbtp.domains.words import parse_words, words_for
from hbtp.errors import InputError
from hbtp.pipeline.clauses import phrasing_runs, tokens
from hbtp.pipeline.instruct import InstructOptions, goal_from_instruction
from hbtp.pipeline.unspoken import kind_as_said, unspoken_dropped, unspoken_listed
from hbtp.train.verbalise import verbalise


@pytest.mark.parametrize(
    ("name", "text", "goal", "read"),
    [
        # a state of an object the goal already names, never spoken of: cleanliness, power, an open door
        ("robowaiter", "Bring a glass of water over to table 1.", "On_Water_Table1 & IsClean_Table1",
         "On_Water_Table1"),
        ("robothow-small", "Go and stand by the window.", "IsNear_self_window & IsOpen_window", "IsNear_self_window"),
        ("robothow-small", "Keep the apple in the fridge.", "IsIn_apple_fridge & ~IsOpen_fridge", "IsIn_apple_fridge"),
        # each alternative on its own
        ("robowaiter", "Bring chips to table 1 or to table 2.", "On_Chips_Table1 & IsClean_Table1 | On_Chips_Table2",
         "On_Chips_Table1 | On_Chips_Table2"),
        # spoken of: its words, a synonym from the words file, a state, an unwanted deed, a deed undone
        ("robowaiter", "Bring water to table 1 and wipe it down.", "On_Water_Table1 & IsClean_Table1",
         "On_Water_Table1 & IsClean_Table1"),
        ("robothow-small", "Put the wine in the microwave and start it.",
         "IsIn_wine_microwave & IsSwitchedOn_microwave", "IsIn_wine_microwave & IsSwitchedOn_microwave"),
        ("robothow-small", "Wash the cutlets, then set them on the kitchen table.",
         "IsClean_cutlets & IsOn_cutlets_kitchentable", "IsClean_cutlets & IsOn_cutlets_kitchentable"),
        ("robothow-small", "The apple goes in the fridge; don't leave the fridge open.",
         "IsIn_apple_fridge & ~IsOpen_fridge", "IsIn_apple_fridge & ~IsOpen_fridge"),
        ("robowaiter", "Bring a coffee to table 1, then leave the bar.", "On_Coffee_Table1 & ~RobotNear_Bar",
         "On_Coffee_Table1 & ~RobotNear_Bar"),
        # it names something new, or it is all the goal asks for
        ("robothow-small", "Put the plate in the garbage can.", "IsIn_plate_garbagecan & IsSwitchedOn_tv",
         "IsIn_plate_garbagecan & IsSwitchedOn_tv"),
        ("robothow-small", "Go and stand by the window.", "IsOpen_window", "IsOpen_window"),
    ],
)  # fmt: skip
def test_a_literal_whose_kind_of_fact_is_never_spoken_of_is_left_out(
    name: str, text: str, goal: str, read: str
) -> None:
    assert unspoken_dropped(load_scenario(name), text, goal) == read


@pytest.mark.parametrize(
    ("text", "goal", "read"),
    [
        # listed with an object of a literal whose kind is spoken of: that kind
        ("Put the apple and the cutlets in the fridge.", "IsIn_apple_fridge & IsCut_cutlets",
         "IsIn_apple_fridge & IsIn_cutlets_fridge"),
        ("Wipe the plate and the kitchen table clean.", "IsClean_plate & IsSwitchedOn_kitchentable",
         "IsClean_plate & IsClean_kitchentable"),
        # its kind is spoken of, or its object is listed with none of the others'
        ("Put the apple in the fridge and cut the cutlets.", "IsIn_apple_fridge & IsCut_cutlets",
         "IsIn_apple_fridge & IsCut_cutlets"),
        ("Put the apple in the fridge, then the cutlets go on the plate.", "IsIn_apple_fridge & IsCut_cutlets",
         "IsIn_apple_fridge & IsCut_cutlets"),
    ],
)  # fmt: skip
def test_a_literal_of_a_kind_never_spoken_of_takes_the_kind_of_a_thing_listed_with_it(
    text: str, goal: str, read: str
) -> None:
    assert unspoken_listed(load_scenario("robothow-small"), text, goal) == read


@pytest.mark.parametrize(
    ("text", "goal", "read"),
    [
        # the clause about just the two things says another relation, never the literal's own
        ("Put the apple on the kitchen table and the cutlets in the fridge.",
         "IsOn_apple_kitchentable & IsOn_cutlets_fridge", "IsOn_apple_kitchentable & IsIn_cutlets_fridge"),
        ("Set the wine down inside the microwave.", "IsOn_wine_microwave", "IsIn_wine_microwave"),
        # a clause speaks of them by a pronoun with the literal's words; no clause names just the two
        ("Put the apple in the fridge or on top of it.", "IsIn_apple_fridge | IsOn_apple_fridge",
         "IsIn_apple_fridge | IsOn_apple_fridge"),
        ("Put the apple in the fridge next to the plate.", "IsOn_apple_fridge", "IsOn_apple_fridge"),
        # a state of one thing: the span (lists kept whole) about just that thing
        ("Turn off the TV, then put the apple in the fridge.", "IsSwitchedOn_tv & IsIn_apple_fridge",
         "IsSwitchedOff_tv & IsIn_apple_fridge"),
        # negated there, an item of a list, or its own kind said where it is named beside others
        ("Make sure the TV isn't off.", "IsSwitchedOn_tv", "IsSwitchedOn_tv"),
        ("The TV, the mouse and the microwave need to be plugged in. The TV has to be on.",
         "IsPlugged_tv & IsSwitchedOn_tv", "IsPlugged_tv & IsSwitchedOn_tv"),
        ("Pull the fridge open. The fridge and the TV should end up plugged in.",
         "IsOpen_fridge & IsPlugged_fridge & IsPlugged_tv", "IsOpen_fridge & IsPlugged_fridge & IsPlugged_tv"),
        ("Get the microwave, the fridge and the window open, then switch the microwave on.",
         "IsOpen_microwave & IsSwitchedOn_microwave", "IsOpen_microwave & IsSwitchedOn_microwave"),  # a list going on
    ],
)  # fmt: skip
def test_a_kind_its_own_clause_never_says_takes_the_one_it_says(text: str, goal: str, read: str) -> None:
    assert kind_as_said(load_scenario("robothow-small"), text, goal) == read


def test_a_world_without_words_is_not_judged(tmp_path: Path) -> None:
    (tmp_path / "d.pddl").write_text(
        "(define (domain d) (:predicates (at ?x ?y) (lit ?x))"
        " (:action go :parameters (?x ?y) :precondition (at ?x ?x) :effect (and (at ?x ?y) (lit ?y))))",
        encoding="utf-8",
    )
    (tmp_path / "p.pddl").write_text(
        "(define (problem p) (:domain d) (:objects a b) (:init (at a a)) (:goal (at a b)))", encoding="utf-8"
    )
    world = load_pddl_scenario(tmp_path / "d.pddl", tmp_path / "p.pddl", ScenarioOptions(name="d"))
    assert unspoken_dropped(world, "Take a to b.", "at_a_b & lit_b") == "at_a_b & lit_b"
    assert kind_as_said(world, "Take a to b.", "at_b_a") == "at_b_a"


def test_generated_instructions_keep_their_literals() -> None:
    """The verbaliser speaks of each literal it asks for: none is left out (RobotHow-Small and
    RoboWaiter, their own goals)."""
    for name in ("robothow-small", "robowaiter"):
        world = load_scenario(name)
        said = verbalised(world, 120, seed=13)
        assert len([goal for _, goal in said if "&" in goal]) >= 20
        assert changed_by(unspoken_dropped, world, said) == []
        assert changed_by(unspoken_listed, world, said) == []
        assert changed_by(kind_as_said, world, said) == []


def test_a_taught_models_goal_is_read_without_a_literal_never_spoken_of() -> None:
    world: Scenario = load_scenario("robowaiter")
    text = "Table 1 would like a glass of water, please."
    reply = "IsClean_Table1 & On_Water_Table1"
    assert goal_from_instruction(world, text, Taught(reply)).goal == "On_Water_Table1"
    kept = goal_from_instruction(world, text, Taught(reply), options=InstructOptions(drop_unsaid=False))
    assert kept.goal == reply


def test_a_taught_models_goal_is_read_with_the_kind_of_a_thing_listed() -> None:
    world: Scenario = load_scenario("robothow-small")
    text, reply = "Wipe the plate and the kitchen table clean.", "IsClean_plate & IsSwitchedOn_kitchentable"
    assert goal_from_instruction(world, text, Taught(reply)).goal == "IsClean_plate & IsClean_kitchentable"


def test_words_heard_of_some_objects_only_are_read_never_written() -> None:
    """``heard`` phrasings ("run {0}", "wash {0}") count as speaking of the literal but the verbaliser
    never writes them ("run the candle"); one that holds a negation is refused."""
    world = load_scenario("robothow-small")
    words = words_for(world)
    heard = {"start", "run", "running", "wash", "scrub"}
    assert {w for p in ("IsSwitchedOn", "IsClean") for run in phrasing_runs(words.predicates[p]) for w in run} >= heard
    goals = ["IsSwitchedOn_tv & IsClean_kitchentable", "IsSwitchedOn_candle", "IsClean_apple & IsSwitchedOn_microwave"]
    said = {w for goal in goals for text in verbalise(goal, words, random.Random(3), 40) for w in tokens(text)}
    assert said & {"switch", "turn", "clean"}
    assert not said & heard
    raw = {"predicates": {"Lit": {"say": ["light {0}"], "state": ["{0} is lit"], "heard": ["don't blow out {0}"]}}}
    with pytest.raises(InputError, match="heard"):
        parse_words(raw)
