"""The symbolic simulator: runs, tick limits, disturbances, traces, and the compiled ticker."""

from __future__ import annotations

import json
import random

import pytest

from hbtp.bt import Action, Condition, Fallback, Node, NodeStatus, Sequence, tick, tree_of
from hbtp.bt.simulate import ConditionChecks, Event, compile_tree, condition_checks, simulate, trace_to_jsonl
from hbtp.bt.verify import flatten
from hbtp.datasets import load_dataset
from hbtp.domains import Scenario
from hbtp.errors import InputError
from hbtp.logic.execution import Tick
from hbtp.logic.task import GroundTask, State
from hbtp.planning import plan
from hbtp.planning.execution import execute_expansions
from helpers import kitchen_builder, random_task, run_tree


@pytest.fixture(scope="module")
def kitchen() -> GroundTask:
    """Walk to the fridge, open it, put the milk in; a switch that flips forever."""
    return (
        kitchen_builder()
        .action("On(lamp)", pre=["IsOff(lamp)"], add=["IsOn(lamp)"], delete=["IsOff(lamp)"])
        .action("Off(lamp)", pre=["IsOn(lamp)"], add=["IsOff(lamp)"], delete=["IsOn(lamp)"])
        .initial(["IsOff(lamp)"])
        .build()
    )


def _ids(task: GroundTask, *names: str) -> frozenset[int]:
    return frozenset(task.atom_id(n) for n in names)


def _branch(task: GroundTask, action: str, *condition: str) -> Sequence:
    return Sequence((Condition(_ids(task, *condition)), Action(task.action(action).index)))


def test_a_planned_tree_runs_its_solution_from_s0(kitchen: GroundTask) -> None:
    result = plan(kitchen, "IsIn_milk_fridge", "obtea")
    goal = kitchen.resolve_goal("IsIn_milk_fridge").ids
    for kind in ("full", "path"):
        run = simulate(tree_of(result, kind), kitchen)
        assert run.status is NodeStatus.SUCCESS
        assert run.reached(goal)
        assert run.executed == result.executed
        assert run.cost == result.cost == 28
        assert run.ticks == len(run.executed) + 1  # the last tick finds the goal
        assert goal <= run.final_state
        assert run.events == 0
        assert run.trace == ()


def test_simulate_agrees_with_the_test_runner_on_the_scenarios(scenario: Scenario) -> None:
    assert scenario.test_set is not None
    for record in load_dataset(scenario.test_set)[:3]:
        result = plan(scenario.task, record.goal, "hbtp-s", mutexes=scenario.mutexes, heuristic="lm")
        assert result.solved
        for kind in ("full", "path"):
            tree = tree_of(result, kind)
            run = simulate(tree, scenario.task)
            expected = run_tree(tree, scenario.task, scenario.task.initial_state, 100)
            assert run.succeeded
            assert expected.reached
            assert run.executed == expected.actions == result.executed
            assert run.cost == expected.cost == result.cost
            assert run.final_state == expected.state
        # the search's own execution check is the same executor on the same branches: the same run
        assert execute_expansions(scenario.task, result.expansions) == simulate(tree_of(result, "full"), scenario.task)


def test_a_failing_tree_fails_at_once(kitchen: GroundTask) -> None:
    tree = Fallback(
        (Condition(_ids(kitchen, "IsIn(milk,fridge)")), _branch(kitchen, "Open(fridge)", "IsClose(fridge)"))
    )
    run = simulate(tree, kitchen)
    assert run.status is NodeStatus.FAILURE  # Open needs IsNear, which does not hold
    assert run.ticks == 1
    assert run.executed == ()
    assert not run.reached(_ids(kitchen, "IsIn(milk,fridge)"))


def test_a_tree_that_loops_stops_at_the_tick_limit(kitchen: GroundTask) -> None:
    tree = Fallback(
        (
            Condition(_ids(kitchen, "IsIn(milk,fridge)")),
            _branch(kitchen, "On(lamp)", "IsOff(lamp)"),
            _branch(kitchen, "Off(lamp)", "IsOn(lamp)"),
        )
    )
    run = simulate(tree, kitchen, max_ticks=7)
    assert run.status is NodeStatus.RUNNING
    assert run.hit_limit
    assert run.ticks == 7
    assert len(run.executed) == 7
    assert run.cost == 7
    with pytest.raises(InputError):
        simulate(tree, kitchen, max_ticks=0)


def test_simulate_starts_from_a_given_state(kitchen: GroundTask) -> None:
    result = plan(kitchen, "IsIn_milk_fridge", "obtea")
    start = _ids(kitchen, "IsStanding(self)", "IsOpen(fridge)", "IsHolding(self,milk)", "IsNear(self,fridge)")
    run = simulate(tree_of(result), kitchen, start)
    assert [kitchen.actions[i].name for i in run.executed] == ["PutIn(milk,fridge)"]
    assert run.cost == 10


class _Scripted:
    """A disturbance that closes the fridge at tick 3, and records what it was shown."""

    def __init__(self, task: GroundTask) -> None:
        self.task = task
        self.seen: list[tuple[int, int | None, bool]] = []

    def __call__(self, tick: int, state: State, last_action: int | None, before_last: State | None) -> Event | None:
        self.seen.append((tick, last_action, before_last is not None))
        if tick != 3:
            return None
        return Event("scripted", _ids(self.task, "IsClose(fridge)"), _ids(self.task, "IsOpen(fridge)"))


def test_a_disturbance_is_applied_before_the_tick_and_traced(kitchen: GroundTask) -> None:
    result = plan(kitchen, "IsIn_milk_fridge", "obtea")
    disturbance = _Scripted(kitchen)
    run = simulate(tree_of(result), kitchen, disturbance=disturbance, trace=True)
    names = [kitchen.actions[i].name for i in run.executed]
    assert names == ["Walk(fridge)", "Open(fridge)", "Open(fridge)", "PutIn(milk,fridge)"]
    assert run.events == 1
    assert run.cost == 28 + 3
    assert disturbance.seen[0] == (1, None, False)
    assert disturbance.seen[2] == (3, kitchen.action("Open(fridge)").index, True)
    assert [step.tick for step in run.trace] == list(range(1, run.ticks + 1))
    third = run.trace[2]
    assert third.disturbance == "scripted: +IsClose(fridge) -IsOpen(fridge)"
    assert "IsClose(fridge)" in third.state
    assert "IsOpen(fridge)" not in third.state
    assert list(third.state) == sorted(third.state)
    assert third.action == "Open(fridge)"
    assert run.trace[-1].status is NodeStatus.SUCCESS
    assert run.trace[-1].action is None


def test_trace_to_jsonl(kitchen: GroundTask) -> None:
    result = plan(kitchen, "IsIn_milk_fridge", "obtea")
    run = simulate(tree_of(result), kitchen, trace=True)
    lines = [json.loads(line) for line in trace_to_jsonl(run, kitchen, run_index=4).splitlines()]
    assert len(lines) == run.ticks + 1
    assert lines[0] == {
        "run": 4,
        "tick": 1,
        "state": ["IsClose(fridge)", "IsHolding(self,milk)", "IsOff(lamp)", "IsStanding(self)"],
        "status": "running",
        "action": "Walk(fridge)",
        "disturbance": None,
    }
    assert lines[-1]["end"] == "success"
    assert lines[-1]["executed"] == ["Walk(fridge)", "Open(fridge)", "PutIn(milk,fridge)"]
    assert lines[-1]["cost"] == 28
    assert "run" not in json.loads(trace_to_jsonl(run, kitchen).splitlines()[0])


def test_ticking_is_a_pure_function_of_the_state(kitchen: GroundTask) -> None:
    tree = tree_of(plan(kitchen, "IsIn_milk_fridge", "obtea"))
    state = kitchen.initial_state
    assert {tick(tree, state, kitchen) for _ in range(5)} == {tick(tree, state, kitchen)}
    first = simulate(tree, kitchen, trace=True)
    assert simulate(tree, kitchen, trace=True) == first


# ------------------------------------------------------------ compiled ticker
def random_tree(task: GroundTask, rng: random.Random, depth: int = 4) -> Node:
    """A random tree over ``task``: any nesting of the four node types."""
    atoms = range(len(task.atoms))
    roll = rng.random()
    if depth == 0 or roll < 0.35:
        if rng.random() < 0.5:
            return Condition(frozenset(rng.sample(atoms, rng.randint(0, min(3, len(task.atoms))))))
        return Action(rng.randrange(len(task.actions)))
    kind = Sequence if roll < 0.65 else Fallback
    return kind(tuple(random_tree(task, rng, depth - 1) for _ in range(rng.randint(0, 4))))


def random_state(task: GroundTask, rng: random.Random) -> frozenset[int]:
    return frozenset(i for i in range(len(task.atoms)) if rng.random() < 0.5)


def test_the_compiled_ticker_equals_tick_on_random_trees() -> None:
    flat_trees = 0
    for seed in range(150):
        task, _ = random_task(seed)
        rng = random.Random(seed)
        tree = random_tree(task, rng)
        flat_trees += flatten(tree) is not None
        ticker = compile_tree(tree, task)
        for _ in range(25):
            state = random_state(task, rng)
            assert ticker(state) == tick(tree, state, task), (seed, tree, state)
    assert flat_trees > 100  # most random trees have a first-match form: the fast path is exercised


def test_simulate_on_random_trees_matches_the_reference_runner() -> None:
    for seed in range(80):
        task, _ = random_task(seed)
        rng = random.Random(seed + 1000)
        tree = random_tree(task, rng)
        state = random_state(task, rng)
        run = simulate(tree, task, state, max_ticks=30)
        expected = run_tree(tree, task, state, 30, planned=False)
        assert run.executed == expected.actions
        assert run.final_state == expected.state
        assert run.succeeded == expected.reached


# ------------------------------------------------------------------ observers and visitors
def test_observers_see_every_tick_before_its_action(kitchen: GroundTask) -> None:
    result = plan(kitchen, "IsIn_milk_fridge", "obtea")
    seen: list[Tick] = []
    run = simulate(tree_of(result), kitchen, disturbance=_Scripted(kitchen), observers=[seen.append], trace=True)
    assert [tick.number for tick in seen] == list(range(1, run.ticks + 1))
    assert [tick.action for tick in seen[:-1]] == list(run.executed)
    assert seen[-1].status is NodeStatus.SUCCESS
    assert seen[-1].action is None
    assert [tick.event is not None for tick in seen] == [tick == 3 for tick in range(1, run.ticks + 1)]
    assert seen[0].state == kitchen.initial_state
    assert [(step.tick, step.status) for step in run.trace] == [(tick.number, tick.status) for tick in seen]


def test_the_tick_visitor_sees_every_node_ticked(kitchen: GroundTask) -> None:
    goal = Condition(_ids(kitchen, "IsIn(milk,fridge)"))
    walk = _branch(kitchen, "Walk(fridge)", "IsStanding(self)")
    opened = Sequence((Condition(_ids(kitchen, "IsOpen(fridge)")), Action(0)))
    tree = Fallback((goal, opened, walk))
    visited: list[tuple[Node, NodeStatus]] = []
    status, running = tick(tree, kitchen.initial_state, kitchen, lambda node, got: visited.append((node, got)))
    assert (status, running) == (NodeStatus.RUNNING, kitchen.action("Walk(fridge)").index)
    # children before their parent; the Action of the failed Sequence is never ticked
    assert visited == [
        (goal, NodeStatus.FAILURE),
        (opened.children[0], NodeStatus.FAILURE),
        (opened, NodeStatus.FAILURE),
        (walk.children[0], NodeStatus.SUCCESS),
        (walk.children[1], NodeStatus.RUNNING),
        (walk, NodeStatus.RUNNING),
        (tree, NodeStatus.RUNNING),
    ]
    counter = ConditionChecks()
    tick(tree, kitchen.initial_state, kitchen, counter)
    assert counter.count == 3


def test_condition_checks_count_the_conditions_of_every_tick(kitchen: GroundTask) -> None:
    tree = tree_of(plan(kitchen, "IsIn_milk_fridge", "obtea"))
    assert isinstance(tree, Fallback)
    # Fallback(goal, Sequence(c1, a1), ...): a tick checks the goal and the conditions up to the
    # first that holds (its action's precondition holds too: c_i was regressed through a_i)
    firsts = [tree.children[0]] + [branch.children[0] for branch in tree.children[1:] if isinstance(branch, Sequence)]
    guards = [guard.literals for guard in firsts if isinstance(guard, Condition)]
    assert len(guards) == len(tree.children)
    expected = 0
    for step in simulate(tree, kitchen, trace=True).trace:
        state = _ids(kitchen, *step.state)
        expected += 1 + next(i for i, guard in enumerate(guards) if guard <= state)
    assert condition_checks(tree, kitchen) == expected
    assert expected > len(guards)
