"""check_reply: names outside the domain are repaired when unambiguous, otherwise reported; nothing
unknown ever reaches the hints."""

from __future__ import annotations

import contextlib
import random

import pytest

from hbtp.datasets import load_dataset
from hbtp.domains import Scenario
from hbtp.errors import InputError
from hbtp.llm.grammar import SECTION_TITLES, GrammarCheck, check_reply
from hbtp.llm.parse import parse_reply
from hbtp.logic.atoms import parse_atom
from hbtp.logic.names import names_of
from hbtp.logic.task import GroundTask
from hbtp.planning import Hints, resolve_hints

EXACT = (
    "Optimal Actions: Walk_cutlets, RightGrab_cutlets, Walk_fridge, Open_fridge, PlugIn_fridge, "
    "RightPutIn_cutlets_fridge, Close_fridge\n"
    "Vital Action Predicates: Walk, RightGrab, Open, PlugIn, RightPutIn, Close\n"
    "Vital Objects: cutlets, fridge"
)


def check(text: str, task: GroundTask) -> GrammarCheck:
    return check_reply(parse_reply(text), task)


def known_names(task: GroundTask) -> tuple[set[str], set[str], frozenset[str]]:
    """The task's action names (``Walk_apple``), action predicates and objects."""
    names = names_of(task)
    return {a.underscored for a in names.actions}, set(names.action_predicates), names.symbols


def assert_only_known(hints: Hints, task: GroundTask) -> None:
    """Every name of ``hints`` is in the task: resolving them reports nothing unknown."""
    actions, predicates, objects = known_names(task)
    assert resolve_hints(task, hints).unknown == ()
    assert all(parse_atom(name).underscored in actions for name in hints.path)
    assert set(hints.predicates) <= predicates
    assert set(hints.objects) <= objects


# ---------------------------------------------------------------------------------- exact names
def test_exact_names_pass_unchanged(robothow_small: Scenario) -> None:
    result = check(EXACT, robothow_small.task)
    assert result.clean
    assert result.problems == []
    assert (result.repairs, result.unknown, result.missing_sections) == ((), (), ())
    assert result.hints == parse_reply(EXACT).hints
    assert len(result.hints.path) == 7
    assert_only_known(result.hints, robothow_small.task)


def test_paren_form_is_accepted(robothow: Scenario) -> None:
    text = (
        "Optimal Actions: Walk(milk), RightGrab(milk), RightPutIn(milk, fridge)\n"
        "Vital Action Predicates: Walk\nVital Objects: milk"
    )
    result = check(text, robothow.task)
    assert result.clean
    assert result.hints.path == ("Walk(milk)", "RightGrab(milk)", "RightPutIn(milk,fridge)")


@pytest.mark.parametrize(
    ("scenario_name", "dataset"),
    [("robowaiter", "table2_robowaiter_50"), ("robothow-small", "table2_robothow_small_50")],
)
def test_every_test_record_is_clean(scenario_name: str, dataset: str, request: pytest.FixtureRequest) -> None:
    scenario: Scenario = request.getfixturevalue(scenario_name.replace("-", "_"))
    for record in load_dataset(dataset):
        text = (
            f"Optimal Actions: {', '.join(record.optimal_actions)}\n"
            f"Vital Action Predicates: {', '.join(record.vital_predicates)}\n"
            f"Vital Objects: {', '.join(record.vital_objects)}"
        )
        result = check(text, scenario.task)
        assert result.repairs == (), record.id
        assert result.clean or result.unknown, record.id  # records that do not fit report names, never crash
        assert_only_known(result.hints, scenario.task)


# ---------------------------------------------------------------------------------- repairs
def test_case_mistakes_are_repaired_and_recorded(robothow_small: Scenario) -> None:
    text = (
        "Optimal Actions: walk_cutlets, RIGHTGRAB_CUTLETS, Walk_Fridge\n"
        "Vital Action Predicates: walk, rightgrab\nVital Objects: Cutlets, FRIDGE"
    )
    result = check(text, robothow_small.task)
    assert result.clean
    assert result.hints.path == ("Walk(cutlets)", "RightGrab(cutlets)", "Walk(fridge)")
    assert result.hints.predicates == ("Walk", "RightGrab")
    assert result.hints.objects == ("cutlets", "fridge")
    assert result.repairs == (
        "walk_cutlets -> Walk_cutlets",
        "RIGHTGRAB_CUTLETS -> RightGrab_cutlets",
        "Walk_Fridge -> Walk_fridge",
        "walk -> Walk",
        "rightgrab -> RightGrab",
        "Cutlets -> cutlets",
        "FRIDGE -> fridge",
    )


def test_walk_apple_case_repair(robothow: Scenario) -> None:
    result = check("Optimal Actions: walk_apple\nVital Action Predicates: Walk\nVital Objects: apple", robothow.task)
    assert result.hints.path == ("Walk(apple)",)
    assert result.repairs == ("walk_apple -> Walk_apple",)
    assert result.clean


def test_near_misses_are_repaired(robothow: Scenario) -> None:
    text = (
        "Optimal Actions: Walk_apple, RightGrab_apple, Walk_fridge, Open_fridge, RightPutIn_apple_fridg, Close_fridg\n"
        "Vital Action Predicates: Walk, RigthGrab, Open, RightPutIn, Close\nVital Objects: aple, fridge"
    )
    result = check(text, robothow.task)
    assert result.clean, result.unknown
    assert "RightPutIn(apple,fridge)" in result.hints.path
    assert "Close(fridge)" in result.hints.path
    assert "RightGrab" in result.hints.predicates
    assert "apple" in result.hints.objects
    assert set(result.repairs) == {
        "RightPutIn_apple_fridg -> RightPutIn_apple_fridge",
        "Close_fridg -> Close_fridge",
        "RigthGrab -> RightGrab",
        "aple -> apple",
    }
    assert_only_known(result.hints, robothow.task)


# ---------------------------------------------------------------------------------- unknown names
def test_unknown_names_are_reported_and_left_out(robothow_small: Scenario) -> None:
    text = (
        "Optimal Actions: Walk_cutlets, Teleport_cutlets_fridge, Walk_unicorn, Walk_milk, Fly\n"
        "Vital Action Predicates: Walk, Teleport, Levitate\nVital Objects: cutlets, unicorn, moon, milk"
    )
    result = check(text, robothow_small.task)
    assert not result.clean
    assert result.hints.path == ("Walk(cutlets)",)  # milk is a RobotHow object, not a RobotHow-Small one
    assert result.hints.predicates == ("Walk",)
    assert result.hints.objects == ("cutlets",)
    assert set(result.unknown) == {
        "Teleport_cutlets_fridge",
        "Walk_unicorn",
        "Walk_milk",
        "Fly",
        "Teleport",
        "Levitate",
        "unicorn",
        "moon",
        "milk",
    }
    assert "Walk_unicorn is not in the domain" in result.problems
    assert result.repairs == ()
    assert_only_known(result.hints, robothow_small.task)


def test_ambiguous_names_are_not_guessed(robothow: Scenario) -> None:
    # pear / peach; cutleryfork / cutleryknife (/ cutlets); LeftGrab / RightGrab; wineglass / waterglass;
    # RightPutIn / RightPut
    text = (
        "Optimal Actions: RightGrab_pea, Walk_cutlery, Grab_apple, Walk_glass\n"
        "Vital Action Predicates: Grab, PutIn, RightPutln\nVital Objects: cutlery, glass"
    )
    result = check(text, robothow.task)
    assert result.hints == Hints((), (), ())
    assert set(result.unknown) == {
        "RightGrab_pea",
        "Walk_cutlery",
        "Grab_apple",
        "Walk_glass",
        "Grab",
        "PutIn",
        "RightPutln",
        "cutlery",
        "glass",
    }
    assert result.repairs == ()


def test_duplicates_are_reported_once(robothow_small: Scenario) -> None:
    text = (
        "Optimal Actions: Fly_fridge, Fly_fridge, Walk_fridge, Walk_fridge\n"
        "Vital Action Predicates: Walk\nVital Objects: fridge, fridge"
    )
    result = check(text, robothow_small.task)
    assert result.unknown == ("Fly_fridge",)
    assert result.hints.path == ("Walk(fridge)", "Walk(fridge)")  # p̂ is a multiset: repeats stay
    assert result.hints.objects == ("fridge",)


# ---------------------------------------------------------------------------------- missing sections
@pytest.mark.parametrize(
    ("text", "missing"),
    [
        ("Optimal Actions: Walk_fridge", ("Vital Action Predicates", "Vital Objects")),
        ("Vital Objects: fridge", ("Optimal Actions", "Vital Action Predicates")),
        ("nothing useful here", ("Optimal Actions", "Vital Action Predicates", "Vital Objects")),
        ("Optimal Actions: Walk_fridge\nVital Action Predicates: Walk\nVital Objects: fridge", ()),
    ],
)
def test_missing_sections(robothow_small: Scenario, text: str, missing: tuple[str, ...]) -> None:
    result = check(text, robothow_small.task)
    assert result.missing_sections == missing
    assert result.clean is (not missing)
    for title in missing:
        assert f"the '{title}' line is missing" in result.problems
    assert set(SECTION_TITLES.values()) >= set(missing)


def test_a_taught_reply_owes_the_plan_alone(robothow_small: Scenario) -> None:
    from hbtp.llm.grammar import check_reply
    from hbtp.llm.parse import parse_reply

    plan_only = check_reply(parse_reply("Optimal Actions: Walk_fridge"), robothow_small.task, path_only=True)
    assert plan_only.clean
    assert plan_only.hints.path == ("Walk(fridge)",)
    nothing = check_reply(parse_reply("Vital Objects: fridge"), robothow_small.task, path_only=True)
    assert nothing.missing_sections == ("Optimal Actions",)


# ---------------------------------------------------------------------------------- nothing unknown gets through
def _noisy_name(rng: random.Random, name: str) -> str:
    """A name with a random edit: case, a dropped, doubled or swapped letter, a suffix, or nonsense."""
    choice = rng.randrange(7)
    if choice == 0:
        return name.lower()
    if choice == 1 and len(name) > 2:
        i = rng.randrange(len(name))
        return name[:i] + name[i + 1 :]
    if choice == 2:
        i = rng.randrange(len(name))
        return name[:i] + name[i] + name[i:]
    if choice == 3 and len(name) > 3:
        i = rng.randrange(len(name) - 1)
        return name[:i] + name[i + 1] + name[i] + name[i + 2 :]
    if choice == 4:
        return name + rng.choice(["s", "_x", "2"])
    if choice == 5:
        return "".join(rng.choice("abcdefXYZ_") for _ in range(rng.randint(1, 12)))
    return name


def _underscored(name: str) -> str:
    try:
        return parse_atom(name).underscored
    except InputError:
        return name


def test_nothing_unknown_ever_reaches_the_hints(robothow: Scenario, robowaiter: Scenario) -> None:
    rng = random.Random(1)
    for scenario in (robothow, robowaiter):
        task = scenario.task
        known_actions, known_predicates, known_objects = known_names(task)
        actions = sorted(known_actions)
        predicates = sorted(task.action_predicates)
        objects = sorted(task.objects)
        for _ in range(30):
            path = [_noisy_name(rng, rng.choice(actions)) for _ in range(rng.randint(0, 6))]
            preds = [_noisy_name(rng, rng.choice(predicates)) for _ in range(rng.randint(0, 4))]
            objs = [_noisy_name(rng, rng.choice(objects)) for _ in range(rng.randint(0, 4))]
            text = (
                f"Optimal Actions: {', '.join(path)}\nVital Action Predicates: {', '.join(preds)}\n"
                f"Vital Objects: {', '.join(objs)}"
            )
            result = check(text, task)
            assert_only_known(result.hints, task)
            # every name given is accounted for: kept as is, repaired, or reported unknown
            repaired = dict(repair.split(" -> ") for repair in result.repairs)
            assert all(before != after for before, after in repaired.items())
            parsed = parse_reply(text).hints
            for name in parsed.path:
                with contextlib.suppress(InputError):
                    name = parse_atom(name).underscored
                assert name in known_actions or name in repaired or name in result.unknown, name
            for name in parsed.predicates:
                assert name in known_predicates or name in repaired or name in result.unknown, name
            for name in parsed.objects:
                assert name in known_objects or name in repaired or name in result.unknown, name
            assert len(result.hints.path) == len(parsed.path) - sum(
                1 for n in parsed.path if _underscored(n) in result.unknown
            )


def test_repairs_never_swap_the_verb_or_the_object(robothow: Scenario) -> None:
    text = "Optimal Actions: Put_apple, Walk_a, walk_Apple\nVital Action Predicates: Walk\nVital Objects: apple"
    result = check(text, robothow.task)
    assert result.hints.path == ("Walk(apple)",)
    assert set(result.unknown) == {"Put_apple", "Walk_a"}
    assert result.repairs == ("walk_Apple -> Walk_apple",)
