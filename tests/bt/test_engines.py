"""Every engine as a tick policy (hbtp's own, py_trees through its BT.CPP-XML reader, BehaviorTree.CPP):
the same actions as hbtp's simulator, re-planning on each, and what py_trees' XML reader needs."""

from __future__ import annotations

import random
import re
import sys
from pathlib import Path
from typing import Any

import pytest

from hbtp.bt import tick, tree_of
from hbtp.bt.btcpp import tree_from_btcpp, tree_to_btcpp
from hbtp.bt.disturb import RandomDisturbance, event_model
from hbtp.bt.engines import Engine
from hbtp.bt.export import export_tree
from hbtp.bt.simulate import simulate
from hbtp.domains import Scenario, load_scenario
from hbtp.errors import InputError
from hbtp.logic.execution import NodeStatus
from hbtp.logic.task import Goal
from hbtp.planning import plan
from hbtp.replanning import ReplanOptions, run_replanning
from helpers import edge_shape_trees

#: Small scenarios' goals: conjunctions, a disjunction ``A | B`` and a negated literal ``~p``
#: (an Inverter in BT.CPP XML).
GOALS = {
    "robowaiter": ("On_Water_Table1", "On(Water,Table1) | On(Coffee,Table1)"),
    "robothow-small": (
        "IsIn_apple_fridge & IsClose_fridge",
        "IsIn(apple,fridge) | IsOn(plate,bed)",
        "IsIn(apple,fridge) & ~IsOpen(fridge)",
    ),
    "virtualhome": ("IsIn_milk_fridge & ~IsOpen_fridge",),
}
CASES = [(scenario, goal) for scenario, goals in GOALS.items() for goal in goals]


def installed(engine: Engine) -> Engine:
    """``engine``, or skip the test when its library is not installed."""
    if engine is Engine.PY_TREES:
        pytest.importorskip("py_trees.parsers.behaviour_tree_xml", reason="py_trees >= 2.6 (its XML reader)")
    elif engine is Engine.BTCPP:
        pytest.importorskip("behaviortreepy")
    return engine


@pytest.fixture(params=list(Engine), ids=lambda engine: engine.value)
def engine(request: pytest.FixtureRequest) -> Engine:
    return installed(request.param)


@pytest.fixture(scope="module")
def planned() -> dict[tuple[str, str], tuple[Scenario, Goal, Any]]:
    """Each case planned with OBTEA (landmark heuristic), in the scenario its goal needs."""
    found = {}
    for name, goal_text in CASES:
        scenario, goal = load_scenario(name).resolve_goal(goal_text)
        result = plan(scenario.task, goal, "obtea", mutexes=scenario.mutexes, heuristic="lm")
        assert result.solved, (name, goal_text)
        found[name, goal_text] = (scenario, goal, result)
    return found


@pytest.mark.parametrize("kind", ["full", "path"])
@pytest.mark.parametrize(("scenario", "goal"), CASES)
def test_every_engine_ticks_the_actions_of_the_simulator(
    planned: Any, engine: Engine, scenario: str, goal: str, kind: str
) -> None:
    loaded, resolved, result = planned[scenario, goal]
    task = loaded.task
    tree = tree_of(result, kind)
    ours = simulate(tree, task, max_ticks=200)
    assert ours.reached(resolved)
    policy = engine.policy(tree, task)
    assert simulate(tree, task, max_ticks=200, policy=policy) == ours
    if "~" in goal and engine is not Engine.HBTP:
        assert '<Inverter name="~IsOpen(fridge)">' in getattr(policy, "xml", "")
    # off the planned path too: the same seeded disturbances give the same runs, failures included
    model = event_model(task, loaded.mutexes)
    for index in range(5):
        expected = simulate(tree, task, max_ticks=100, disturbance=RandomDisturbance(model, 0.4, random.Random(index)))
        disturbed = RandomDisturbance(model, 0.4, random.Random(index))
        assert simulate(tree, task, max_ticks=100, disturbance=disturbed, policy=policy) == expected, index


def test_every_engine_ticks_edge_shapes_like_hbtp(engine: Engine) -> None:
    """The trees of :func:`helpers.edge_shape_trees`, from every state of their task."""
    task, trees = edge_shape_trees()
    at, rested = task.atom_id("At(a)"), task.atom_id("Rested()")
    states = [frozenset(), frozenset({at}), frozenset({rested}), frozenset({at, rested})]
    for tree in trees:
        policy = engine.policy(tree, task)
        assert [policy(state) for state in states] == [tick(tree, state, task) for state in states], tree


def test_a_policy_applies_no_effects_and_fails_where_no_condition_holds(planned: Any, engine: Engine) -> None:
    loaded, _, result = planned["robothow-small", "IsIn_apple_fridge & IsClose_fridge"]
    task = loaded.task
    policy = engine.policy(tree_of(result, "path"), task)
    first = policy(task.initial_state)
    assert first == (NodeStatus.RUNNING, result.executed[0])
    assert policy(task.initial_state) == first  # the state is the caller's: ticking again changes nothing
    assert policy(frozenset()) == (NodeStatus.FAILURE, None)
    assert policy(task.initial_state) == first  # and the tree recovers from a failed tick


def test_replanning_under_disturbances_is_the_same_on_every_engine(planned: Any, engine: Engine) -> None:
    loaded, goal, result = planned["robothow-small", "IsIn_apple_fridge & IsClose_fridge"]
    tree = tree_of(result, "path")
    model = event_model(loaded.task, loaded.mutexes)
    replans = 0
    for index in range(8):
        ours = run_replanning(
            loaded, goal, tree, max_ticks=200, disturbance=RandomDisturbance(model, 0.5, random.Random(index))
        )
        theirs = run_replanning(
            loaded, goal, tree, max_ticks=200, disturbance=RandomDisturbance(model, 0.5, random.Random(index)),
            options=ReplanOptions(engine=engine),
        )  # fmt: skip
        assert theirs.run == ours.run, index
        assert [(r.tick, r.status, r.cost, r.tree) for r in theirs.replans] == [
            (r.tick, r.status, r.cost, r.tree) for r in ours.replans
        ]
        assert theirs.reached(goal) or theirs.unsolvable, (index, theirs.gave_up)
        replans += len(theirs.replans)
    assert replans > 0, "the disturbances must defeat the path tree, or the test shows nothing"


def test_engines_are_values_checked_where_options_are_made(monkeypatch: pytest.MonkeyPatch) -> None:
    assert [Engine(name) for name in ("hbtp", "pytrees", "btcpp")] == [Engine.HBTP, Engine.PY_TREES, Engine.BTCPP]
    assert Engine.BTCPP.label == "BehaviorTree.CPP"
    with pytest.raises(InputError, match="must be an Engine"):
        ReplanOptions(engine="btcpp")  # type: ignore[arg-type]
    monkeypatch.setitem(sys.modules, "py_trees.parsers.behaviour_tree_xml", None)
    with pytest.raises(InputError, match=r"py_trees 2\.6 or later"):
        ReplanOptions(engine=Engine.PY_TREES)
    monkeypatch.setitem(sys.modules, "behaviortreepy", None)
    with pytest.raises(InputError, match=r"pip install 'hbtp\[btcpp\]'"):
        Engine.BTCPP.require()


# ------------------------------------------------------------------ py_trees' BT.CPP-XML reader


@pytest.mark.parametrize("flavour", ["btcpp", "btcpp-named"])
def test_py_trees_reader_loads_the_exported_file_and_runs_it(planned: Any, tmp_path: Path, flavour: str) -> None:
    installed(Engine.PY_TREES)
    from py_trees.parsers.behaviour_tree_xml import parse_behaviour_tree_xml

    from hbtp.bt.pytrees_xml import TickState, node_registry

    loaded, goal, result = planned["robothow-small", "IsIn(apple,fridge) & ~IsOpen(fridge)"]
    task = loaded.task
    tree = tree_of(result, "full")
    path = tmp_path / "tree.xml"
    path.write_text(export_tree(tree, task, flavour), encoding="utf-8")
    tick = TickState(task)
    root = parse_behaviour_tree_xml(str(path), node_registry=node_registry(tick))  # the reader's own entry
    state, executed = task.initial_state, []
    for _ in range(50):
        tick.state, tick.action = state, None
        root.tick_once()
        if root.status.value != "RUNNING":
            break
        assert tick.action is not None
        executed.append(tick.action)
        state = task.actions[tick.action].progress(state)
        root.stop(root.status.INVALID)
    assert root.status.value == "SUCCESS"
    assert tuple(executed) == simulate(tree, task).executed == result.executed
    assert goal.holds(state)


def test_what_py_trees_reader_needs_from_our_xml(planned: Any, tmp_path: Path) -> None:
    """Two things: the reactive control nodes in the registry (the reader does not know them), and a
    unique path of names to every node (the reader rejects duplicate names): our writer names every
    group and control node but the root after its kind and position."""
    installed(Engine.PY_TREES)
    from py_trees.parsers.behaviour_tree_xml import parse_behaviour_tree_xml

    from hbtp.bt.pytrees_xml import PytreesPolicy, TickState, node_registry, pytrees_from_btcpp

    loaded, _, result = planned["robothow-small", "IsIn_apple_fridge & IsClose_fridge"]
    task = loaded.task
    tree = tree_of(result, "full")
    xml = tree_to_btcpp(tree, task)
    assert '<ReactiveSequence name="Sequence 2">' in xml
    assert '<Sequence name="Condition 1">' in xml
    # the XML hbtp wrote before: control nodes without names, every group named "Condition"
    unnamed = re.sub(r' name="(?:Sequence|Fallback) [0-9]+"', "", re.sub(r"Condition [0-9]+", "Condition", xml))
    assert tree_from_btcpp(unnamed, task) == tree_from_btcpp(xml, task) == tree
    with pytest.raises(InputError, match="Duplicate node name found"):
        pytrees_from_btcpp(unnamed, TickState(task))
    registry = {tag: node for tag, node in node_registry(TickState(task)).items() if not tag.startswith("Reactive")}
    file = tmp_path / "tree.xml"
    file.write_text(xml, encoding="utf-8")
    with pytest.raises(ValueError, match="Unsupported tag 'ReactiveFallback'"):
        parse_behaviour_tree_xml(str(file), node_registry=registry)
    named = PytreesPolicy(tree, task, ports=False)  # btcpp-named: the literal from the end of the node's name
    assert simulate(tree, task, policy=named) == simulate(tree, task)
