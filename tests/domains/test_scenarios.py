"""The four shipped scenarios reproduce the reference facts (domains.md) exactly.

These are the paper's scenarios: their self-placements (``LeftPut(chair,chair)``) are kept, as the
benchmarks keep them (plans leave them out: tests/domains/test_irreflexive.py).
"""

from __future__ import annotations

import json
from collections import Counter
from pathlib import Path
from typing import Any

import pytest

from hbtp.domains import Scenario, load_pddl_scenario, load_scenario, scenario_names
from hbtp.domains.scenarios import ScenarioOptions, read_mutex_file, read_pddl
from hbtp.errors import InputError
from hbtp.logic import GroundTask

DATA_DIR = Path(__file__).parent.parent / "data"


def _paper(name: str) -> Scenario:
    return load_scenario(name, keep_self_placements=True)


# The shared fixtures of the same names, with the paper's action space.
@pytest.fixture(scope="module", params=scenario_names())
def scenario(request: pytest.FixtureRequest) -> Scenario:
    return _paper(request.param)


@pytest.fixture(scope="module")
def robowaiter() -> Scenario:
    return _paper("robowaiter")


@pytest.fixture(scope="module")
def virtualhome() -> Scenario:
    return _paper("virtualhome")


@pytest.fixture(scope="module")
def robothow_small() -> Scenario:
    return _paper("robothow-small")


@pytest.fixture(scope="module")
def robothow() -> Scenario:
    return _paper("robothow")


# name: (|A|, |Q|, |O|, |s0|) from the paper's Table II and the reference notes.
FIGURES = {
    "robowaiter": (174, 6, 31, 13),
    "virtualhome": (480, 11, 36, 17),
    "robothow-small": (155, 16, 17, 15),
    "robothow": (7329, 16, 126, 70),
}


def _sets(task: GroundTask, name: str) -> dict[str, Any]:
    action = task.action(name)
    return {
        "pre": task.names(action.pre),
        "add": task.names(action.add),
        "del": task.names(action.delete),
        "cost": action.cost,
    }


def test_scenario_names_in_the_papers_order() -> None:
    assert scenario_names() == ("robowaiter", "virtualhome", "robothow-small", "robothow")


def test_unknown_scenario() -> None:
    with pytest.raises(InputError, match=r"unknown scenario 'kitchen'.*robowaiter"):
        load_scenario("kitchen")


def test_sizes(scenario: Scenario) -> None:
    actions, predicates, objects, s0 = FIGURES[scenario.name]
    task = scenario.task
    assert len(task.actions) == actions
    assert len(task.action_predicates) == predicates
    assert len(task.objects) == objects
    assert len(task.initial_state) == s0
    summary = scenario.summary()
    assert (summary["actions"], summary["action_predicates"], summary["objects"], summary["s0"]) == FIGURES[
        scenario.name
    ]


def test_loading_is_cached_and_metadata_is_set(scenario: Scenario) -> None:
    assert _paper(scenario.name) is scenario
    assert scenario.title
    assert scenario.description
    assert (scenario.fewshot or "").startswith("fewshot_")
    assert (scenario.test_set or "").startswith("table2_")
    assert scenario.domain_file.is_file()
    assert scenario.problem_file.is_file()


def test_objects_are_the_walk_targets(scenario: Scenario) -> None:
    # The paper's O is the argument set of the move action (MoveTo in RoboWaiter, Walk elsewhere).
    task = scenario.task
    move = "MoveTo" if scenario.name == "robowaiter" else "Walk"
    assert sorted(task.objects) == sorted(a.objects[0] for a in task.actions if a.predicate == move)
    assert not set(task.objects) & set(task.constants)


def test_initial_state_is_the_reference_s0(scenario: Scenario, domains_samples: dict[str, Any]) -> None:
    task = scenario.task
    assert task.names(task.initial_state) == domains_samples["initial_state"][scenario.name]


def test_robothow_action_names_match_the_reference_list(robothow: Scenario, data_dir: Path) -> None:
    expected = (data_dir / "robothow_action_names.txt").read_text(encoding="utf-8").split()
    assert len(expected) == 7329
    assert sorted(a.name for a in robothow.task.actions) == sorted(expected)


@pytest.mark.parametrize("name", ["robowaiter", "virtualhome", "robothow-small"])
def test_action_names_match_the_reference_lists(name: str, domains_samples: dict[str, Any]) -> None:
    task = _paper(name).task
    assert sorted(a.name for a in task.actions) == domains_samples["action_names"][name]


def test_grounded_count_per_action_predicate(scenario: Scenario, domains_samples: dict[str, Any]) -> None:
    counts = Counter(a.predicate for a in scenario.task.actions)
    expected = {s["predicate"]: s["grounded_count"] for s in domains_samples["scenarios"][scenario.name]}
    assert counts == expected


# (scenario, sample) pairs, read at collection time to parametrize the test below.
SAMPLES = [
    (name, sample)
    for name, samples in json.loads((DATA_DIR / "domains_samples.json").read_text(encoding="utf-8"))[
        "scenarios"
    ].items()
    for sample in samples
]


@pytest.mark.parametrize(("name", "sample"), SAMPLES, ids=[f"{n}:{s['action']}" for n, s in SAMPLES])
def test_grounded_example_matches_the_reference(name: str, sample: dict[str, Any]) -> None:
    got = _sets(_paper(name).task, sample["action"])
    assert got["cost"] == sample["cost"]
    for part in ("pre", "add", "del"):
        expected = sample[part]
        if expected["complete"]:
            assert got[part] == expected["literals"], part
        else:  # abbreviated in the reference notes: its size and a few members are known
            assert len(got[part]) == expected["count"], part
            assert set(expected["literals"]) <= set(got[part]), part
        assert len(got[part]) == expected["count"]


def test_samples_cover_every_action_predicate() -> None:
    assert len(SAMPLES) == 6 + 11 + 16 + 16
    abbreviated = [(n, s["action"], p) for n, s in SAMPLES for p in ("pre", "add", "del") if not s[p]["complete"]]
    assert len(abbreviated) == 9  # the listed del sets of MoveTo, PickUp, Walk and the Grabs


# ========================================================== hand-picked quirks
def test_robowaiter_put_down_anything_anywhere(robowaiter: Scenario) -> None:
    task = robowaiter.task
    items = task.categories["item"]
    assert len(items) == 14
    assert _sets(task, "PutDown(Anything,Anywhere)") == {
        "pre": [],
        "add": ["Holding(Nothing)"],
        "del": sorted(f"Holding({o})" for o in items),
        "cost": 8,
    }
    # An ordinary PutDown does not give the hand back.
    assert _sets(task, "PutDown(Coffee,Table1)") == {
        "pre": ["Holding(Coffee)", "RobotNear(Table1)"],
        "add": ["On(Coffee,Table1)"],
        "del": ["Holding(Coffee)"],
        "cost": 20,
    }


@pytest.mark.parametrize(
    ("action", "pre", "add", "delete"),
    [
        ("Turn(Curtain,On)", ["Closed(Curtain)"], [], ["Closed(Curtain)"]),
        ("Turn(Curtain,Off)", [], ["Closed(Curtain)"], []),
        ("Turn(ACTemperature,Down)", ["Active(AC)", "Holding(Nothing)"], ["Low(ACTemperature)"], []),
        ("Turn(ACTemperature,Up)", ["Active(AC)", "Holding(Nothing)"], [], ["Low(ACTemperature)"]),
        ("Turn(AC,On)", ["Holding(Nothing)"], ["Active(AC)"], []),
        ("Turn(TubeLight,Off)", ["Active(TubeLight)", "Holding(Nothing)"], [], ["Active(TubeLight)"]),
    ],
)
def test_robowaiter_turn(robowaiter: Scenario, action: str, pre: list[str], add: list[str], delete: list[str]) -> None:
    assert _sets(robowaiter.task, action) == {"pre": pre, "add": add, "del": delete, "cost": 3}


def test_robowaiter_move_to_and_pick_up(robowaiter: Scenario) -> None:
    task = robowaiter.task
    assert _sets(task, "MoveTo(Bar)")["pre"] == []
    assert _sets(task, "MoveTo(Coffee)")["pre"] == ["Exists(Coffee)"]
    assert "Exists(Milk)" in _sets(task, "PickUp(Milk)")["del"]
    assert _sets(task, "Make(Dessert)")["add"] == ["Exists(Dessert)", "On(Dessert,Bar)"]


def test_robothow_put_rag_deletes_only_the_cleaning_tool(robothow: Scenario) -> None:
    assert _sets(robothow.task, "RightPut(rag,kitchentable)") == {
        "pre": ["IsNear(self,kitchentable)", "IsRightHolding(self,rag)"],
        "add": ["IsOn(rag,kitchentable)", "IsRightHandEmpty(self)"],
        "del": ["IsHoldingCleaningTool(self)"],
        "cost": 6,
    }


def test_robothow_putting_the_knife_down_keeps_holding_knife(robothow: Scenario) -> None:
    task = robothow.task
    assert "IsHoldingKnife(self)" in _sets(task, "RightGrab(kitchenknife)")["add"]
    assert _sets(task, "RightPut(kitchenknife,kitchentable)")["del"] == ["IsRightHolding(self,kitchenknife)"]


def test_robothow_open_microwave_needs_it_switched_off(robothow: Scenario, robothow_small: Scenario) -> None:
    for scenario in (robothow, robothow_small):
        assert _sets(scenario.task, "Open(microwave)")["pre"] == [
            "IsClose(microwave)",
            "IsLeftHandEmpty(self)",
            "IsNear(self,microwave)",
            "IsSwitchedOff(microwave)",
        ]


def test_robothow_put_milk_in_fridge_needs_it_plugged_and_open(robothow: Scenario) -> None:
    assert _sets(robothow.task, "RightPutIn(milk,fridge)") == {
        "pre": ["IsNear(self,fridge)", "IsOpen(fridge)", "IsPlugged(fridge)", "IsRightHolding(self,milk)"],
        "add": ["IsIn(milk,fridge)", "IsRightHandEmpty(self)"],
        "del": ["IsRightHolding(self,milk)"],
        "cost": 10,
    }


def test_robothow_switch_on_needs_closed_and_plugged(robothow: Scenario) -> None:
    assert _sets(robothow.task, "SwitchOn(microwave)")["pre"] == [
        "IsClose(microwave)",
        "IsLeftHandEmpty(self)",
        "IsNear(self,microwave)",
        "IsPlugged(microwave)",
        "IsSwitchedOff(microwave)",
    ]


def test_robothow_has_eighteen_degenerate_self_pairs(robothow: Scenario) -> None:
    pairs = sorted(a.name for a in robothow.task.actions if len(a.objects) == 2 and a.objects[0] == a.objects[1])
    assert len(pairs) == 18
    assert {"RightPut(radio,radio)", "LeftPutIn(box,box)"} <= set(pairs)
    assert {a[: a.index("(")] for a in pairs} <= {"RightPut", "LeftPut", "RightPutIn", "LeftPutIn"}


def test_robothow_put_rules(robothow: Scenario) -> None:
    names = {a.name for a in robothow.task.actions}
    assert "RightPut(towel,towelrack)" in names
    assert "RightPut(apple,towelrack)" not in names
    assert "RightPut(apple,plate)" in names  # food goes on plates
    assert "RightPut(book,plate)" not in names  # non-food does not
    assert "RightPut(apple,bathroomcounter)" not in names
    assert "RightPutIn(plate,dishwasher)" in names
    assert "RightPutIn(book,dishwasher)" not in names
    assert "RightPutIn(paper,printer)" in names


def test_robothow_small_put_in_is_every_grabbable_container_pair(robothow_small: Scenario) -> None:
    task = robothow_small.task
    pairs = {(x, y) for x in task.categories["grabbable"] for y in task.categories["container"]}
    assert len(pairs) == 24
    for hand in ("Right", "Left"):
        assert {a.objects for a in task.actions if a.predicate == f"{hand}PutIn"} == pairs


def test_robothow_small_plug_out_is_dead_for_plug_only_objects(robothow_small: Scenario) -> None:
    task = robothow_small.task
    for obj in ("fridge", "mouse"):
        switched_off = task.atom_id(f"IsSwitchedOff({obj})")
        assert switched_off in task.action(f"PlugOut({obj})").pre
        assert switched_off not in task.initial_state
        assert task.achievers[switched_off] == ()
    assert task.achievers[task.atom_id("IsSwitchedOff(tv)")] != ()


def test_virtualhome_puts_a_plate_on_itself(virtualhome: Scenario) -> None:
    task = virtualhome.task
    assert _sets(task, "RightPut(plate,plate)") == {
        "pre": ["IsNear(self,plate)", "IsRightHolding(self,plate)"],
        "add": ["IsOn(plate,plate)", "IsRightHandEmpty(self)"],
        "del": ["IsRightHolding(self,plate)"],
        "cost": 6,
    }
    assert task.action("LeftPut(plate,plate)").cost == 6


def test_virtualhome_open_needs_the_left_hand(virtualhome: Scenario) -> None:
    assert _sets(virtualhome.task, "Open(fridge)")["pre"] == [
        "IsClose(fridge)",
        "IsLeftHandEmpty(self)",
        "IsNear(self,fridge)",
    ]


# ================================================================ user PDDL
def test_load_pddl_scenario_from_the_shipped_files(robothow_small: Scenario) -> None:
    scenario = load_pddl_scenario(
        robothow_small.domain_file,
        robothow_small.problem_file,
        # The shipped lists include two actions that are unreachable from s0 (PlugOut(fridge), PlugOut(mouse)).
        ScenarioOptions(keep_fluent=["IsStanding"], objects=["all_objects"], reachable_only=False),
    )
    assert scenario.name == "robothow-small"  # the problem's name
    assert scenario.title == "robothow-small"
    assert [a.name for a in scenario.task.actions] == [a.name for a in robothow_small.task.actions]
    assert scenario.mutexes.nogoods == ()
    assert scenario.load_seconds > 0


def test_load_pddl_scenario_without_options_uses_the_problem_objects(robothow_small: Scenario) -> None:
    scenario = load_pddl_scenario(robothow_small.domain_file, robothow_small.problem_file, ScenarioOptions(name="rhs"))
    assert scenario.name == "rhs"
    assert len(scenario.task.objects) == 16  # the problem's :objects; faucet is a domain constant
    assert "IsStanding" not in scenario.task.predicates


def test_a_scenario_keeps_the_pddl_it_was_grounded_from(robothow_small: Scenario) -> None:
    scenario = load_pddl_scenario(robothow_small.domain_file, robothow_small.problem_file, ScenarioOptions(name="rhs"))
    assert scenario.parsed is not None
    assert scenario.pddl is scenario.parsed
    assert scenario.pddl == read_pddl(robothow_small.domain_file, robothow_small.problem_file)


def test_a_shipped_scenario_reads_its_pddl_when_asked(robothow_small: Scenario) -> None:
    # loaded from the disk cache or from its files: the same lifted domain and problem either way
    assert robothow_small.pddl == read_pddl(robothow_small.domain_file, robothow_small.problem_file)
    assert robothow_small.pddl is robothow_small.pddl  # read once


def test_read_mutex_file(tmp_path: Path) -> None:
    path = tmp_path / "mutex.toml"
    path.write_text('groups = [["IsOpen(?x)", "IsClose(?x)"]]\n', encoding="utf-8")
    assert read_mutex_file(path) == {"groups": [["IsOpen(?x)", "IsClose(?x)"]], "nogoods": []}
    path.write_text("groups = [\n", encoding="utf-8")
    with pytest.raises(InputError, match="not valid TOML"):
        read_mutex_file(path)
    path.write_text("group = []\n", encoding="utf-8")
    with pytest.raises(InputError, match="unknown key"):
        read_mutex_file(path)
    with pytest.raises(InputError, match="cannot read"):
        read_mutex_file(tmp_path / "missing.toml")
