"""Perturbed execution: seeded and deterministic, consistent states, and full trees recover better."""

from __future__ import annotations

import dataclasses
import random

import pytest

from hbtp.bt import tree_of
from hbtp.bt.disturb import (
    KINDS,
    RandomDisturbance,
    disturbed_runs,
    event_model,
    exactly_one_groups,
    perturbation_stats,
    run_seed,
)
from hbtp.bt.simulate import Event, simulate
from hbtp.datasets import load_dataset
from hbtp.domains import Scenario
from hbtp.errors import InputError
from hbtp.llm.parse import hints_from_record
from hbtp.logic.task import State
from hbtp.planning import PlanResult, plan
from hbtp.planning.heuristic_names import HeuristicName


def _plans(
    scenario: Scenario, count: int, planner: str = "obtea", heuristic: HeuristicName = "lm"
) -> list[tuple[PlanResult, frozenset[int]]]:
    assert scenario.test_set is not None
    found = []
    for record in load_dataset(scenario.test_set)[:count]:
        hints = hints_from_record(record)
        result = plan(
            scenario.task,
            record.goal,
            planner,
            hints=hints,
            space="pruned",
            mutexes=scenario.mutexes,
            heuristic=heuristic,
        )
        assert result.solved
        found.append((result, scenario.task.resolve_goal(record.goal).ids))
    return found


def test_runs_are_deterministic_for_a_seed(robothow_small: Scenario) -> None:
    (result, goal), *_ = _plans(robothow_small, 1)
    tree = tree_of(result)
    task, mutexes = robothow_small.task, robothow_small.mutexes
    first = disturbed_runs(tree, task, mutexes, 0.3, 10, seed=5, trace=True)
    again = disturbed_runs(tree, task, mutexes, 0.3, 10, seed=5, trace=True)
    assert first == again
    assert sum(run.events for run in first) > 0
    other = disturbed_runs(tree, task, mutexes, 0.3, 10, seed=6, trace=True)
    assert other != first
    stats = perturbation_stats(tree, task, goal, mutexes, 0.3, 10, seed=5)
    assert stats == perturbation_stats(tree, task, goal, mutexes, 0.3, 10, seed=5)
    assert stats["successes"] == sum(run.reached(goal) for run in first)
    assert run_seed(5, 2) == "hbtp-disturb/5/2"


class _Checked:
    """Wraps a disturbance and checks every state it leaves behind."""

    def __init__(self, inner: RandomDisturbance, scenario: Scenario) -> None:
        self.inner = inner
        self.scenario = scenario
        self.groups = exactly_one_groups(scenario.task, scenario.mutexes)
        self.kinds: dict[str, int] = {}

    def __call__(self, tick: int, state: State, last_action: int | None, before_last: State | None) -> Event | None:
        event = self.inner(tick, state, last_action, before_last)
        if event is None:
            return None
        self.kinds[event.kind] = self.kinds.get(event.kind, 0) + 1
        after = event.apply(state)
        assert after != state
        assert event.added.isdisjoint(state)
        assert event.removed <= state
        assert self.scenario.mutexes.conflict(after) is None, event.describe(self.scenario.task)
        for group in self.groups:
            assert len(group & after) == 1, event.describe(self.scenario.task)
        if event.kind == "undo":
            assert last_action is not None
            action = self.scenario.task.actions[last_action]
            assert (event.added & action.delete) or (event.removed & action.add)
        return event


@pytest.mark.parametrize("name", ["robothow-small", "virtualhome", "robowaiter"])
def test_disturbed_states_stay_consistent(
    name: str, robothow_small: Scenario, virtualhome: Scenario, robowaiter: Scenario
) -> None:
    scenario = {"robothow-small": robothow_small, "virtualhome": virtualhome, "robowaiter": robowaiter}[name]
    task = scenario.task
    assert scenario.mutexes.conflict(task.initial_state) is None
    model = event_model(task, scenario.mutexes)
    assert event_model(task, scenario.mutexes) is model  # kept with the task, per mutexes
    other = dataclasses.replace(scenario.mutexes, nogoods=(*scenario.mutexes.nogoods, frozenset({0, 1})))
    assert event_model(task, other) is not model
    assert event_model(task, other).mutexes is other
    kinds: dict[str, int] = {}
    for result, _ in _plans(scenario, 4):
        for index in range(10):
            checked = _Checked(RandomDisturbance(model, 0.6, random.Random(index)), scenario)
            simulate(tree_of(result), task, max_ticks=60, disturbance=checked)
            for kind, count in checked.kinds.items():
                kinds[kind] = kinds.get(kind, 0) + count
    assert set(kinds) == set(KINDS)


def test_exactly_one_groups_are_proved_groups_filled_in_s0(robothow_small: Scenario) -> None:
    task = robothow_small.task
    groups = exactly_one_groups(task, robothow_small.mutexes)
    assert groups
    for group in groups:
        assert len(group & task.initial_state) == 1
        for action in task.actions:
            if action.delete & group:
                assert action.add & group


def test_the_full_tree_recovers_at_least_as_often_as_the_path_tree(robothow_small: Scenario) -> None:
    task, mutexes = robothow_small.task, robothow_small.mutexes
    totals = {"full": 0.0, "path": 0.0}
    # OBTEA without a heuristic (the paper's) expands conditions off the solution path; with the
    # landmark heuristic, or with HBTP-S, the full tree is often little more than the path.
    for result, goal in _plans(robothow_small, 12, heuristic="none"):
        for kind in totals:
            stats = perturbation_stats(tree_of(result, kind), task, goal, mutexes, 0.2, 15, seed=1, max_ticks=200)
            assert stats["base_reached"]
            totals[kind] += stats["success_rate"]
    assert totals["full"] >= totals["path"]
    assert totals["full"] > totals["path"]


def test_without_perturbation_every_run_is_the_undisturbed_one(robowaiter: Scenario) -> None:
    (result, goal), *_ = _plans(robowaiter, 1, planner="hbtp-s")
    stats = perturbation_stats(tree_of(result), robowaiter.task, goal, robowaiter.mutexes, 0.0, 3, seed=0)
    assert stats["success_rate"] == 1.0
    assert stats["mean_extra_ticks"] == 0.0
    assert stats["mean_extra_cost"] == 0.0
    assert stats["mean_events"] == 0.0
    assert stats["base_cost"] == result.cost
    assert set(stats) >= {"success_rate", "mean_ticks", "mean_extra_ticks", "mean_cost", "mean_extra_cost"}


def test_bad_arguments_are_input_errors(robowaiter: Scenario) -> None:
    (result, goal), *_ = _plans(robowaiter, 1, planner="hbtp-s")
    tree = tree_of(result)
    task, mutexes = robowaiter.task, robowaiter.mutexes
    for p in (-0.1, 1.5):
        with pytest.raises(InputError, match=r"\[0, 1\]"):
            perturbation_stats(tree, task, goal, mutexes, p, 2, 0)
    with pytest.raises(InputError):
        disturbed_runs(tree, task, mutexes, 0.1, -1)
    with pytest.raises(InputError, match="event kind"):
        RandomDisturbance(event_model(task, mutexes), 0.1, random.Random(0), kinds=("earthquake",))


def test_only_the_chosen_kinds_happen(robothow_small: Scenario) -> None:
    (result, _), *_ = _plans(robothow_small, 1)
    model = event_model(robothow_small.task, robothow_small.mutexes)
    checked = _Checked(RandomDisturbance(model, 1.0, random.Random(0), kinds=("make-false",)), robothow_small)
    run = simulate(tree_of(result), robothow_small.task, max_ticks=20, disturbance=checked, trace=True)
    assert set(checked.kinds) == {"make-false"}
    assert all(step.disturbance is None or step.disturbance.startswith("make-false") for step in run.trace)
