"""Running trees with re-planning: in the symbolic world under disturbances, and on a (toy) robot."""

from __future__ import annotations

import json
import random
import statistics
import subprocess
import sys
import threading
from pathlib import Path

import pytest
from tests.helpers import ROAD_OR_RAIL_DOMAIN, kitchen_builder

from hbtp.bt import tree_of
from hbtp.bt.disturb import RandomDisturbance, event_model, run_seed
from hbtp.bt.engines import Engine
from hbtp.bt.jsonio import node_from_dict
from hbtp.bt.simulate import simulate
from hbtp.cli import EXIT_OK, main
from hbtp.datasets import load_dataset
from hbtp.domains.mutex import infer_mutexes
from hbtp.domains.scenarios import Scenario, ScenarioOptions, load_pddl_scenario
from hbtp.errors import InputError
from hbtp.logic.execution import Event, NodeStatus
from hbtp.logic.task import GroundTask, State
from hbtp.planning import plan
from hbtp.runtime import (
    UNSOLVABLE_FROM_STATE,
    ReplanningRun,
    ReplanOptions,
    Runtime,
    RuntimeFailure,
    replanning_trace_jsonl,
    run_replanning,
)


@pytest.fixture(params=list(Engine), ids=lambda engine: engine.value)
def engine(request: pytest.FixtureRequest) -> Engine:
    """Each engine in turn (skipped when its library is not installed)."""
    if request.param is Engine.PY_TREES:
        pytest.importorskip("py_trees.parsers.behaviour_tree_xml", reason="py_trees >= 2.6 (its XML reader)")
    elif request.param is Engine.BTCPP:
        pytest.importorskip("behaviortreepy")
    return Engine(request.param)


def _scenario(task: GroundTask) -> Scenario:
    return Scenario(task.name, task.name, "", task, infer_mutexes(task), Path("-"), Path("-"))


@pytest.mark.parametrize("name", ["robowaiter", "robothow-small"])
def test_replanning_reaches_the_goal_where_the_tree_alone_fails(request: pytest.FixtureRequest, name: str) -> None:
    scenario: Scenario = request.getfixturevalue(name.replace("-", "_"))
    task = scenario.task
    model = event_model(task, scenario.mutexes)
    failed_alone = unsolvable = 0
    for record in load_dataset(scenario.test_set or "")[:12]:
        goal = task.resolve_goal(record.goal)
        tree = tree_of(plan(task, goal, "obtea", mutexes=scenario.mutexes, heuristic="lm"), "path")
        for index in range(8):
            alone = simulate(tree, task, max_ticks=300, disturbance=RandomDisturbance(model, 0.5, random.Random(index)))
            disturbance = RandomDisturbance(model, 0.5, random.Random(index))
            run = run_replanning(scenario, goal, tree, max_ticks=300, disturbance=disturbance)
            failed_alone += not alone.reached(goal.ids)
            if run.reached(goal.ids):
                assert all(replan.status == "solved" for replan in run.replans)
                continue
            # only a disturbance that made the goal unreachable may stop it: no action sequence, even
            # ignoring deletes, makes the goal true from where the run stopped
            assert run.gave_up is not None, (record.goal, index)
            assert run.gave_up.startswith(UNSOLVABLE_FROM_STATE)
            assert not goal.ids <= _relaxed_closure(task, run.run.final_state)
            unsolvable += 1
    assert failed_alone > unsolvable, "the disturbances must defeat some path trees, or the test shows nothing"


def _relaxed_closure(task: GroundTask, state: State) -> frozenset[int]:
    """Every atom some action sequence can make true from ``state`` when deletes are ignored."""
    reached = set(state)
    grew = True
    while grew:
        grew = False
        for action in task.actions:
            if action.pre <= reached and not action.add <= reached:
                reached |= action.add
                grew = True
    return frozenset(reached)


def _milk_dropped_at_tick_2(*, trace: bool = False) -> tuple[GroundTask, ReplanningRun]:
    """The kitchen's milk task, run with re-planning while an event makes the robot drop the milk
    at tick 2 (which no action undoes: the goal becomes unreachable)."""
    task = kitchen_builder().build()
    goal = task.resolve_goal("IsIn(milk,fridge)")
    tree = tree_of(plan(task, goal, "obtea"), "full")
    holding = task.atom_id("IsHolding(self,milk)")

    def drop_the_milk(tick: int, state: State, last: int | None, before: State | None) -> Event | None:
        return Event("make-false", frozenset(), frozenset({holding})) if tick == 2 and holding in state else None

    return task, run_replanning(_scenario(task), goal, tree, max_ticks=100, disturbance=drop_the_milk, trace=trace)


def test_a_goal_made_unreachable_ends_with_a_reason_not_a_loop() -> None:
    _task, run = _milk_dropped_at_tick_2()
    assert run.run.status is NodeStatus.FAILURE
    assert run.run.ticks == 2
    assert run.gave_up is not None
    assert run.gave_up.startswith(UNSOLVABLE_FROM_STATE)
    assert [r.status for r in run.replans] == ["unsolvable"]


def test_replanning_is_bounded(robothow_small: Scenario) -> None:
    task = robothow_small.task
    record = load_dataset(robothow_small.test_set or "")[0]
    goal = task.resolve_goal(record.goal)
    tree = tree_of(plan(task, goal, "obtea", heuristic="lm"), "path")
    model = event_model(task, robothow_small.mutexes)
    for seed in range(20):
        disturbance = RandomDisturbance(model, 1.0, random.Random(run_seed(0, seed)))
        run = run_replanning(
            robothow_small, goal, tree, max_ticks=200, disturbance=disturbance, options=ReplanOptions(max_replans=0)
        )
        if run.gave_up is not None:
            assert "max_replans" in run.gave_up
            assert run.run.status is NodeStatus.FAILURE
            assert not run.replans
            return
    pytest.fail("no disturbance defeated the path tree in 20 runs")


def test_replan_options_check_their_values() -> None:
    with pytest.raises(InputError, match="max_replans"):
        ReplanOptions(max_replans=-1)
    with pytest.raises(InputError, match="budget"):
        ReplanOptions(budget_s=0)
    with pytest.raises(InputError, match="unknown planner"):
        ReplanOptions(planner="astar")
    with pytest.raises(InputError, match="heuristic"):
        ReplanOptions(pruned_heuristic="astar")  # type: ignore[arg-type]


# ------------------------------------------------------------------ a toy robot
class ToyRobot:
    """The symbolic world as a robot: actions change its state, the observer reads it."""

    def __init__(self, task: GroundTask, broken: frozenset[str] = frozenset()) -> None:
        self.task = task
        self.state = task.initial_state
        self.broken = broken
        self.calls: list[str] = []

    def observe(self) -> list[str]:
        return self.task.names(self.state)

    def act(self, name: str) -> str:
        self.calls.append(name)
        if name in self.broken:
            return "failure"
        action = self.task.actions[self.task.action(name).index]
        if not action.applicable(self.state):
            return "failure"
        self.state = action.progress(self.state)
        return "success"

    def callbacks(self) -> dict[str, object]:
        return {a.name: (lambda n=a.name: self.act(n)) for a in self.task.actions}


def _two_hands() -> GroundTask:
    """The kitchen, the milk to be grabbed first: with the right hand (cheap) or the left (dear)."""
    return (
        kitchen_builder(holding=False)
        .action("Grab(milk)", pre=["IsNear(self,fridge)"], add=["IsHolding(self,milk)"], cost=5)
        .action("LeftGrab(milk)", pre=["IsNear(self,fridge)"], add=["IsHolding(self,milk)"], cost=50)
        .build()
    )


def test_runtime_drives_a_robot_to_the_goal_and_routes_around_a_broken_action(engine: Engine) -> None:
    task = _two_hands()
    robot = ToyRobot(task, broken=frozenset({"Grab(milk)"}))
    runtime = Runtime(
        _scenario(task), "IsIn(milk,fridge)", robot.callbacks(), robot.observe, max_failures=2,
        options=ReplanOptions(engine=engine),
    )  # fmt: skip
    report = runtime.run(max_ticks=50)
    assert report.succeeded, report.reason
    assert task.atom_id("IsIn(milk,fridge)") in robot.state
    assert robot.calls.count("Grab(milk)") == 2  # tried twice, then left out of the next plan
    assert "LeftGrab(milk)" in robot.calls
    assert [r.reason for r in report.replans][-1] == "Grab(milk) failed 2 times in a row"
    assert json.loads(json.dumps(report.to_dict()))["status"] == "success"


def test_runtime_takes_implementations_per_predicate() -> None:
    task = kitchen_builder().build()
    robot = ToyRobot(task)
    by_predicate = {
        "Walk": lambda where: robot.act(f"Walk({where})"),
        "Open": lambda what: robot.act(f"Open({what})"),
        "PutIn": lambda what, where: robot.act(f"PutIn({what},{where})"),
    }
    report = Runtime(_scenario(task), "IsIn(milk,fridge)", by_predicate, robot.observe).run()
    assert report.succeeded
    assert report.called == ["Walk(fridge)", "Open(fridge)", "PutIn(milk,fridge)"]


def test_runtime_counts_a_raising_or_garbage_callback_as_a_failure(engine: Engine) -> None:
    task = kitchen_builder().build()
    robot = ToyRobot(task)
    callbacks = robot.callbacks()
    options = ReplanOptions(engine=engine)

    def explode() -> str:
        raise RuntimeError("motor stalled")

    callbacks["Open(fridge)"] = explode
    report = Runtime(_scenario(task), "IsIn(milk,fridge)", callbacks, robot.observe, max_failures=2, options=options)
    result = report.run(20)
    assert not result.succeeded
    assert result.failures == 2
    assert result.called == ["Walk(fridge)", "Open(fridge)", "Open(fridge)"]
    assert result.reason.startswith(UNSOLVABLE_FROM_STATE)  # no other way to open the fridge
    callbacks["Open(fridge)"] = lambda: 42
    garbage = Runtime(_scenario(task), "IsIn(milk,fridge)", callbacks, robot.observe, max_failures=1, options=options)
    result = garbage.run(20)
    assert not result.succeeded
    assert result.failures == 1


def test_runtime_stops_a_hanging_callback_and_a_lying_observer(engine: Engine) -> None:
    task = kitchen_builder().build()
    robot = ToyRobot(task)
    release = threading.Event()
    callbacks = robot.callbacks()
    callbacks["Walk(fridge)"] = lambda: release.wait(10) and "success"
    runtime = Runtime(
        _scenario(task), "IsIn(milk,fridge)", callbacks, robot.observe, tick_timeout_s=0.2,
        options=ReplanOptions(engine=engine),
    )  # fmt: skip
    with pytest.raises(RuntimeFailure, match=r"Walk\(fridge\) did not return within 0.2 s"):
        runtime.run()
    release.set()
    lying = Runtime(_scenario(task), "IsIn(milk,fridge)", robot.callbacks(), lambda: ["IsFlying(self)"])
    with pytest.raises(RuntimeFailure, match="IsFlying"):
        lying.run()
    with pytest.raises(InputError, match="Teleport"):
        Runtime(_scenario(task), "IsIn(milk,fridge)", {"Teleport(milk)": lambda: "success"}, robot.observe)


def test_a_replanning_trace_shows_each_new_tree_before_the_first_tick_that_uses_it(robothow_small: Scenario) -> None:
    task = robothow_small.task
    goal = task.resolve_goal("IsIn_apple_fridge & IsClose_fridge")
    tree = tree_of(plan(task, goal, "obtea", mutexes=robothow_small.mutexes, heuristic="lm"), "path")
    model = event_model(task, robothow_small.mutexes)
    for index in range(20):
        disturbance = RandomDisturbance(model, 0.5, random.Random(index))
        result = run_replanning(robothow_small, goal, tree, max_ticks=200, disturbance=disturbance, trace=True)
        if any(replan.tree is not None for replan in result.replans):
            break
    else:
        pytest.fail("no re-plan in 20 disturbed runs")
    lines = [json.loads(line) for line in replanning_trace_jsonl(result, task).splitlines()]
    assert all("run" not in line for line in lines)
    assert all(replan.tree is not None for replan in result.replans)
    found = [(i, line["replan"]) for i, line in enumerate(lines) if "replan" in line]
    assert len(found) == len(result.replans)
    for (position, record), replan in zip(found, result.replans, strict=True):
        assert set(record) == {"tick", "reason", "seconds", "status", "cost", "tree"}
        assert lines[position + 1]["tick"] == record["tick"] == replan.tick  # the first tick with the new tree
        assert (record["reason"], record["status"], record["cost"]) == (replan.reason, "solved", replan.cost)
        assert node_from_dict(record["tree"], task) == replan.tree
    assert [line["tick"] for line in lines if "tick" in line and "replan" not in line] == list(
        range(1, result.run.ticks + 1)
    )
    assert lines[-1]["end"] == result.run.status.value
    numbered = [json.loads(line) for line in replanning_trace_jsonl(result, task, run_index=4).splitlines()]
    assert all(line.pop("run") == 4 for line in numbered)
    assert numbered == lines
    assert "tree" not in result.replans[0].to_dict()  # the rows of --json carry no tree


def test_a_run_that_gives_up_says_why_at_the_end_of_its_trace() -> None:
    task, run = _milk_dropped_at_tick_2(trace=True)
    lines = [json.loads(line) for line in replanning_trace_jsonl(run, task, run_index=0).splitlines()]
    assert [line["tick"] for line in lines[:-1] if "replan" not in line] == [1, 2]
    assert lines[1]["replan"]["status"] == "unsolvable"  # before tick 2, where the tree failed
    assert "tree" not in lines[1]["replan"]  # no tree to swap in
    assert (lines[2]["tick"], lines[2]["status"]) == (2, "failure")
    assert lines[-1]["end"] == "failure"
    assert lines[-1]["gave_up"].startswith(UNSOLVABLE_FROM_STATE)


def test_robustness_benchmark_with_replanning(tmp_path: Path) -> None:
    out = tmp_path / "robustness"
    argv = ["bench", "robustness", "--replan", "--scenarios", "robowaiter", "--limit", "2", "--runs", "4"]
    argv += ["--p", "0.5", "--executor", "inline", "--no-progress", "-o", str(out)]
    assert main(argv) == EXIT_OK
    summary = json.loads((out / "summary.json").read_text(encoding="utf-8"))
    entry = summary["scenarios"]["robowaiter"]["p"]["0.5"]
    rows = [json.loads(line) for line in (out / "results.jsonl").read_text(encoding="utf-8").splitlines()]
    for tree in ("full+replan", "path+replan"):
        assert entry[tree]["reachable_runs_succeeded"] == entry[tree]["reachable_runs"] > 0
        # A re-plan is held against planning the same tasks from s0: those that re-planned.
        replanned = [1000 * r["plan_time_s"] for r in rows if r["tree"] == tree and r["median_replan_ms"] is not None]
        assert replanned
        assert entry[tree]["median_plan_ms_replanned"] == round(statistics.median(replanned), 6)
        assert 0 <= entry[tree]["recalled_replans"] <= entry[tree]["replans"]
        assert entry[tree]["median_searched_replan_ms"] is not None
    assert "With re-planning" in (out / "report.md").read_text(encoding="utf-8")


def test_robustness_re_plans_in_the_hints_space_are_checked_against_the_optimum(tmp_path: Path) -> None:
    """Re-plans search the record's hints' space first; --check-replans counts those that found the
    full space's optimum (never more than answered) and the cost they added; --replan-full-space
    answers every re-plan from the full space, optimal."""
    argv = ["bench", "robustness", "--replan", "--check-replans", "--scenarios", "robothow-small", "--limit", "6"]
    argv += ["--runs", "6", "--p", "0.5", "--executor", "inline", "--no-progress"]
    entries = {}
    for name, extra in (("hints", []), ("full", ["--replan-full-space"])):
        assert main([*argv, *extra, "-o", str(tmp_path / name)]) == EXIT_OK
        summary = json.loads((tmp_path / name / "summary.json").read_text(encoding="utf-8"))
        entries[name] = summary["scenarios"]["robothow-small"]["p"]["0.5"]["path+replan"]
    hints, full = entries["hints"], entries["full"]
    assert hints["reachable_runs_succeeded"] == hints["reachable_runs"] > 0
    assert hints["replans"] > 0
    assert 0 < hints["pruned_replans"] <= hints["replans"]
    assert 0 <= hints["optimal_replans"] <= hints["pruned_replans"]
    assert hints["replan_extra_cost"] >= 0
    assert (hints["optimal_replans"] == hints["pruned_replans"]) == (hints["replan_extra_cost"] == 0)
    assert full["pruned_replans"] == 0
    assert full["replans"] > 0


def test_hbtp_run_replans(tmp_path: Path, capsys: pytest.CaptureFixture[str]) -> None:
    tree = tmp_path / "tree.json"
    goal = "IsIn_apple_fridge & IsClose_fridge"
    assert main(["plan", "-s", "robothow-small", "-g", goal, "-p", "obtea", "--tree", "path", "-o", str(tree)]) == 0
    capsys.readouterr()
    argv = ["run", str(tree), "--perturb", "0.5", "--runs", "20"]
    assert main(argv) == 1  # the path tree alone loses some runs
    capsys.readouterr()
    assert main([*argv, "--replan", "10", "--json"]) == EXIT_OK
    record = json.loads(capsys.readouterr().out)
    assert record["successes"] == 20
    assert record["replans"] > 0
    assert all(r["reached"] and r["gave_up"] is None for r in record["results"])
    assert main(["run", str(tree), "--replan", "1", "-g", "IsFlying_apple"]) == 2


def test_the_documented_toy_robot_example_runs() -> None:
    example = Path(__file__).resolve().parents[2] / "examples" / "runtime_toy_robot.py"
    done = subprocess.run([sys.executable, str(example)], capture_output=True, text=True, timeout=120, check=True)
    assert done.stdout.startswith("success after")
    assert "LeftGrab(apple)" in done.stdout
    assert "RightGrab(apple) failed 2 times in a row" in done.stdout


def test_the_alternatives_of_a_disjunctive_precondition_share_their_actions_implementation(tmp_path: Path) -> None:
    (tmp_path / "d.pddl").write_text(ROAD_OR_RAIL_DOMAIN, encoding="utf-8")
    (tmp_path / "p.pddl").write_text(
        "(define (problem p) (:domain d) (:objects x y) (:init (at x) (rail x y)) (:goal (at y)))", encoding="utf-8"
    )
    scenario = load_pddl_scenario(tmp_path / "d.pddl", tmp_path / "p.pddl", ScenarioOptions(name="d"))
    world = {"at(x)", "rail(x,y)"}
    calls: list[tuple[str, ...]] = []

    def go(a: str, b: str) -> str:
        calls.append((a, b))
        world.discard(f"at({a})")
        world.add(f"at({b})")
        return "success"

    report = Runtime(scenario, "at(y)", {"go": go}, lambda: sorted(world)).run(max_ticks=10)
    assert report.succeeded
    assert calls == [("x", "y")]
    assert report.called == ["go-alt2(x,y)"]  # rail is the second alternative as written
