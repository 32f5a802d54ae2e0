"""Step costs are values (one per planner), α's integer/fraction rule lives in them, and every
LLM-free heuristic gives the search its precondition bound through one method."""

from __future__ import annotations

import importlib
import math
from fractions import Fraction
from types import SimpleNamespace

import pytest

from hbtp.datasets import load_dataset
from hbtp.domains import Scenario
from hbtp.errors import InputError
from hbtp.llm.parse import hints_from_record
from hbtp.logic import Atom, GroundAction
from hbtp.planning import PLANNERS, Status, plan, planner_config, search
from hbtp.planning.costs import (
    MAX_ALPHA,
    ActionCosts,
    DiscountedCosts,
    FreeOwedCosts,
    Number,
    StepCosts,
    UnitCosts,
    check_alpha,
)
from hbtp.planning.heuristics import analyse_space, build_heuristic
from hbtp.planning.result import PlanResult
from helpers import random_case

ACTION = GroundAction(0, Atom("A", ()), frozenset(), frozenset({1}), frozenset(), 7)


def test_each_planner_is_a_cost_value() -> None:
    assert PLANNERS["bte"].costs == UnitCosts()
    assert PLANNERS["obtea"].costs == ActionCosts()
    assert PLANNERS["hbtp-o"].costs == DiscountedCosts(10_000)
    assert PLANNERS["hbtp-s"].costs == FreeOwedCosts()
    assert planner_config("hbtp-o", alpha=20).costs == DiscountedCosts(20)
    assert planner_config("obtea", alpha=20).costs == ActionCosts()  # α only matters to HBTP-O


@pytest.mark.parametrize(
    ("costs", "full", "owed", "scale", "follows_hints", "orders"),
    [
        (UnitCosts(), 1, 1, 1, False, False),
        (ActionCosts(), 7, 7, 1, False, True),
        (DiscountedCosts(100), 700, 7, 100, True, True),
        (DiscountedCosts(2.5), 7, Fraction(14, 5), 1, True, True),
        (FreeOwedCosts(), 7, 0, 1, True, True),
    ],
)
def test_step_costs_of_each_planner(
    costs: StepCosts, full: Number, owed: Number, scale: int, follows_hints: bool, orders: bool
) -> None:
    assert costs.full_cost(ACTION) == full
    assert costs.owed_cost(ACTION) == owed
    assert costs.scale == scale
    assert costs.follows_hints is follows_hints
    assert costs.orders_by_heuristic is orders


@pytest.mark.parametrize("alpha", [10_000, 10_000.0, Fraction(10_000)])
def test_a_whole_alpha_counts_in_units_of_one_over_alpha_whatever_its_type(alpha: object) -> None:
    costs = DiscountedCosts(alpha)  # type: ignore[arg-type]
    assert costs.alpha == 10_000
    assert type(costs.alpha) is int
    assert costs.scale == 10_000
    assert costs == DiscountedCosts(10_000)


@pytest.mark.parametrize("alpha", [0, 0.5, math.inf, math.nan, MAX_ALPHA + 1, True, "10"])
def test_invalid_alpha_is_an_input_error(alpha: object) -> None:
    with pytest.raises(InputError, match="alpha must be"):
        check_alpha(alpha)
    with pytest.raises(InputError, match="alpha must be"):
        planner_config("hbtp-o", alpha=alpha)  # type: ignore[arg-type]


def test_plan_with_a_float_alpha_is_the_same_as_with_the_int(robothow: Scenario) -> None:
    task = robothow.task
    for record in load_dataset("table1_robothow_100")[:5]:
        hints = hints_from_record(record)
        runs = [
            plan(task, record.goal, "hbtp-o", hints=hints, alpha=alpha, heuristic=heuristic, space=space)
            for heuristic in ("none", "lm")
            for space in ("full", "pruned")
            for alpha in (10_000, 10_000.0)
        ]
        for by_int, by_float in zip(runs[::2], runs[1::2], strict=True):
            assert by_int.solved
            assert (by_int.expansions, by_int.solution, by_int.cost) == (
                by_float.expansions,
                by_float.solution,
                by_float.cost,
            )


def test_a_fractional_alpha_is_exact_and_still_sound(robowaiter: Scenario) -> None:
    task = robowaiter.task
    record = load_dataset("table2_robowaiter_50")[0]
    result = plan(task, record.goal, "hbtp-o", hints=hints_from_record(record), alpha=2.5, heuristic="lm")
    reference = plan(task, record.goal, "obtea", heuristic="lm")
    assert result.solved
    assert reference.solved
    assert result.cost == reference.cost  # the hints are an optimal plan: HBTP-O stays optimal


# ---------------------------------------------------------------- heuristics
@pytest.mark.parametrize("name", ["hmax", "lm"])
@pytest.mark.parametrize("seed", range(40))
def test_precondition_bound_is_a_lower_bound_of_every_condition_holding_the_precondition(name: str, seed: int) -> None:
    case = random_case(seed)
    task = case.task
    heuristic = build_heuristic(name, task, task.actions, case.goal.ids)
    assert heuristic is not None
    # The search's conditions hold goal literals and preconditions only.
    relevant = sorted(case.goal.ids.union(*(a.pre for a in task.actions)))
    for action in task.actions:
        bound = heuristic.precondition_bound(action)
        estimate = heuristic(action.pre)
        assert bound <= estimate or (math.isinf(bound) and math.isinf(estimate)), (seed, action.name)
        for extra in relevant:
            assert bound <= heuristic(action.pre | {extra}) or math.isinf(bound), (seed, action.name, extra)


def test_the_full_space_analysis_lives_with_the_task_and_pruned_ones_are_bounded(robowaiter: Scenario) -> None:
    task = robowaiter.task
    assert analyse_space(task, task.actions) is analyse_space(task, task.actions)
    spaces = [task.actions[i : i + 3] for i in range(0, 60, 3)]
    first = analyse_space(task, spaces[0])
    assert analyse_space(task, spaces[0]) is first
    for space in spaces[1:]:
        analyse_space(task, space)
    assert analyse_space(task, spaces[0]) is not first  # only the most recent pruned spaces are kept


# ------------------------------------------------------------------- status
def test_an_internal_error_of_the_search_is_not_reported_as_unsolvable(
    robowaiter: Scenario, monkeypatch: pytest.MonkeyPatch
) -> None:
    search_module = importlib.import_module("hbtp.planning.search_state")  # where the result is checked

    def broken(*args: object, **kwargs: object) -> SimpleNamespace:
        return SimpleNamespace(succeeded=False, executed=(), cost=0)  # a tree that misses the goal

    monkeypatch.setattr(search_module, "execute_expansions", broken)
    task = robowaiter.task
    goal = task.resolve_goal(load_dataset("table2_robowaiter_50")[0].goal)
    result: PlanResult = search(task, goal, task.actions, planner_config("obtea"))
    assert result.status is Status.ERROR
    assert not result.solved
    assert result.message.startswith("internal error")
    assert result.to_dict(task)["status"] == "error"
