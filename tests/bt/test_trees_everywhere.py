"""Every planner's tree for every valid record of every shipped dataset passes the static verifier and
reaches the goal in our simulator, in a live py_trees tree, and in BehaviorTree.CPP (behaviortreepy),
with the same actions everywhere (slow: run with ``pytest -m slow``)."""

from __future__ import annotations

from typing import Any

import pytest

from hbtp.bt import tree_of
from hbtp.bt.btcpp_engine import BtcppEngine
from hbtp.bt.pytrees_export import SymbolicWorld, build_pytrees, tick_to_goal
from hbtp.bt.simulate import simulate
from hbtp.bt.verify import verify
from hbtp.datasets import DATASET_SCENARIO, dataset_names, load_dataset, validate_records
from hbtp.domains import load_scenario
from hbtp.llm.parse import hints_from_record
from hbtp.logic.execution import NodeStatus
from hbtp.planning import PLANNERS, Limits, plan


@pytest.mark.slow
@pytest.mark.parametrize("name", dataset_names())
def test_every_tree_verifies_and_reaches_the_goal_in_three_engines(name: str) -> None:
    bt = pytest.importorskip("behaviortreepy")
    py_trees = pytest.importorskip("py_trees")
    scenario = load_scenario(DATASET_SCENARIO[name])
    task = scenario.task
    records = load_dataset(name)
    invalid = set(validate_records(records, task).invalid_ids)
    checked = 0
    for record in records:
        if record.id in invalid or not record.optimal_actions:
            continue
        hints = hints_from_record(record)
        for planner in PLANNERS:
            result = plan(
                task, record.goal, planner, hints=hints, space="pruned", mutexes=scenario.mutexes,
                limits=Limits(time_s=10),
            )  # fmt: skip
            where = f"{name} record {record.id} {planner}"
            assert result.solved, where
            goal = result.goal.ids
            for kind in ("full", "path"):
                tree = tree_of(result, kind)
                check = verify(tree, task, goal)
                assert check.ok, f"{where} {kind}: {check.summary()}"
                assert check.proved_goal_reaching, f"{where} {kind}: {check.summary()}"
                run = simulate(tree, task)
                assert run.reached(goal), f"{where} {kind}: simulator"
                if kind == "full":
                    assert run.executed == result.executed, f"{where}: simulator and planner differ"
                _check_pytrees(py_trees, tree, task, goal, run.executed, where)
                _check_btcpp(bt, tree, task, goal, run.executed, where)
                checked += 1
    assert checked > 0


def _check_pytrees(py_trees: Any, tree: Any, task: Any, goal: frozenset[int], executed: Any, where: str) -> None:
    world = SymbolicWorld.initial(task)
    status = tick_to_goal(build_pytrees(tree, task, world))
    assert status == py_trees.common.Status.SUCCESS, f"{where}: py_trees"
    assert goal <= world.state, f"{where}: py_trees goal"
    assert tuple(world.executed) == tuple(executed), f"{where}: py_trees actions"


def _check_btcpp(bt: Any, tree: Any, task: Any, goal: frozenset[int], executed: Any, where: str) -> None:
    run = BtcppEngine(tree, task).run(max_ticks=200)  # the btcpp-named export, ticked by BT.CPP
    assert run.status is NodeStatus.SUCCESS, f"{where}: BT.CPP"
    assert goal <= run.final_state, f"{where}: BT.CPP goal"
    assert tuple(run.executed) == tuple(executed), f"{where}: BT.CPP actions"
