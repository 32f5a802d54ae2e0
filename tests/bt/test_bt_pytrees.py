"""py_trees: a live tree ticked to the goal, and the standalone module that rebuilds it."""

from __future__ import annotations

import ast
from typing import Any

import pytest

from hbtp.bt import Fallback, tree_of
from hbtp.bt.pytrees_export import SymbolicWorld, build_pytrees, tick_to_goal, write_pytrees_module
from hbtp.domains import load_scenario
from hbtp.logic.task import GroundTask
from hbtp.planning import plan
from hbtp.planning.result import PlanResult
from helpers import plan_goals

GOALS = {
    "robowaiter": ("On_Water_Table1", "On_Dessert_Bar & Low_ACTemperature"),
    "virtualhome": ("IsIn_chicken_microwave", "IsIn_breadslice_fridge & IsIn_milk_fridge"),
    "robothow-small": ("IsIn_apple_fridge & IsClose_fridge", "IsOn_plate_bed & IsOn_wine_kitchencabinet"),
    "robothow": ("IsIn_milk_fridge", "IsClose_window & IsOpen_door"),
}
CASES = [(scenario, goal, kind) for scenario, goals in GOALS.items() for goal in goals for kind in ("full", "path")]


@pytest.fixture(scope="module")
def planned() -> dict[tuple[str, str], tuple[GroundTask, PlanResult]]:
    return plan_goals(GOALS)


@pytest.mark.parametrize(("scenario", "goal", "kind"), CASES)
def test_live_py_trees_tree_reaches_the_goal(planned: Any, scenario: str, goal: str, kind: str) -> None:
    py_trees = pytest.importorskip("py_trees")
    task, result = planned[scenario, goal]
    world = SymbolicWorld.initial(task)
    root = build_pytrees(tree_of(result, kind), task, world)
    status = tick_to_goal(root, max_ticks=200)
    assert status == py_trees.common.Status.SUCCESS
    assert tuple(world.executed) == result.executed
    assert result.goal.ids <= world.state


def test_live_tree_shape_and_reactivity(planned: Any) -> None:
    py_trees = pytest.importorskip("py_trees")
    task, result = planned["robothow-small", "IsIn_apple_fridge & IsClose_fridge"]
    tree = tree_of(result, "path")
    world = SymbolicWorld.initial(task)
    root = build_pytrees(tree, task, world)
    assert isinstance(root, py_trees.composites.Selector)
    assert root.memory is False
    assert root.children[0].name == "IsClose(fridge) & IsIn(apple,fridge)"
    assert isinstance(tree, Fallback)
    assert len(root.children) == len(tree.children)
    sequence = root.children[-1]
    assert isinstance(sequence, py_trees.composites.Sequence)
    assert sequence.memory is False
    assert sequence.children[1].name == "Walk(apple)"
    root.tick_once()  # one action per tick, RUNNING while busy
    assert root.status == py_trees.common.Status.RUNNING
    assert [task.actions[i].name for i in world.executed] == ["Walk(apple)"]
    # a disturbance: the goal made true by hand; the next tick re-checks it first and stops
    world.state = world.state | result.goal.ids
    root.tick_once()
    assert root.status == py_trees.common.Status.SUCCESS
    assert len(world.executed) == 1


def test_live_tree_fails_when_no_branch_applies(planned: Any) -> None:
    py_trees = pytest.importorskip("py_trees")
    task, result = planned["robothow-small", "IsIn_apple_fridge & IsClose_fridge"]
    world = SymbolicWorld(task, frozenset())  # nothing holds: the robot is not even standing
    root = build_pytrees(tree_of(result, "path"), task, world)
    assert tick_to_goal(root) == py_trees.common.Status.FAILURE
    assert world.executed == []


@pytest.mark.parametrize(("scenario", "goal", "kind"), CASES[::3])
def test_standalone_module_rebuilds_and_runs_the_tree(planned: Any, scenario: str, goal: str, kind: str) -> None:
    py_trees = pytest.importorskip("py_trees")
    task, result = planned[scenario, goal]
    source = write_pytrees_module(tree_of(result, kind), task, scenario=scenario, goal=goal)
    assert source == write_pytrees_module(tree_of(result, kind), task, scenario=scenario, goal=goal)
    imported = {
        alias.name.split(".")[0]
        for node in ast.walk(ast.parse(source))
        if isinstance(node, ast.Import)
        for alias in node.names
    } | {
        node.module.split(".")[0]
        for node in ast.walk(ast.parse(source))
        if isinstance(node, ast.ImportFrom) and node.module
    }
    assert imported == {"__future__", "logging", "py_trees"}
    namespace: dict[str, Any] = {"__name__": "generated_tree"}
    exec(compile(source, f"{scenario}_tree.py", "exec"), namespace)
    status, world = namespace["run"]()
    assert status == py_trees.common.Status.SUCCESS
    assert world.executed == [task.actions[i].name for i in result.executed]
    assert {str(task.atoms[i]) for i in result.goal.ids} <= world.state


def test_module_text_needs_no_py_trees_to_write() -> None:
    task = load_scenario("robowaiter").task
    result = plan(task, "Exists_Coffee", "obtea")
    source = write_pytrees_module(tree_of(result, "path"), task)
    assert "import py_trees" in source
    assert "from hbtp" not in source
    assert max(len(line) for line in source.splitlines()) <= 120
