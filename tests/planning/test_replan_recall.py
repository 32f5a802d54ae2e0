"""Re-plans from a state searched before (hbtp.replanning.KeptSearch.recall): the hints' space's answer
is recalled, not searched again, and is the answer a new search gives; a state whose hints' space
held no tree goes straight to the full space; nothing a time limit ended is kept; the record is
bounded and belongs to one pruned space."""

from __future__ import annotations

import pytest

from hbtp import replanning
from hbtp.bt import tree_of
from hbtp.bt.disturb import seeded_disturbances
from hbtp.bt.jsonio import node_to_dict
from hbtp.domains import Scenario
from hbtp.logic.task import Goal
from hbtp.planning import PlanResult, Status
from hbtp.planning import kept as kept_module
from hbtp.planning.hints import hints_from_names
from hbtp.planning.planners import Space, planner_config
from hbtp.planning.search import search
from hbtp.replanning import KeptSearch, Replanner, ReplanOptions
from helpers import run_tree

GOAL = "IsIn_apple_fridge & IsClose_fridge"
HINTS = hints_from_names(predicates=["Walk", "RightGrab", "Open", "RightPutIn", "Close"], objects=["apple", "fridge"])


def disturbed(scenario: Scenario, goal: Goal, count: int) -> list[frozenset[int]]:
    """Distinct states three ticks of seeded disturbances make, where the goal does not hold."""
    task, states = scenario.task, []
    for disturbance in seeded_disturbances(task, scenario.mutexes, 0.5, 60, seed=5):
        state = task.initial_state
        for tick in range(1, 4):
            event = disturbance(tick, state, None, None)
            state = event.apply(state) if event is not None else state
        if not goal.holds(state) and state not in states:
            states.append(state)
    return states[:count]


def test_a_replan_from_a_state_searched_before_recalls_what_a_new_search_finds(robothow_small: Scenario) -> None:
    task = robothow_small.task
    goal = task.resolve_goal(GOAL)
    states = disturbed(robothow_small, goal, 20)
    assert len(states) >= 10
    kept = KeptSearch()
    first = Replanner(robothow_small, goal, None, ReplanOptions(max_replans=100, hints=HINTS, kept=kept))
    again = Replanner(robothow_small, goal, None, ReplanOptions(max_replans=100, hints=HINTS, kept=kept))
    fresh = Replanner(robothow_small, goal, None, ReplanOptions(max_replans=100, hints=HINTS))
    recalled = 0
    for state in states:
        for policy in (first, again, fresh):
            assert policy.replan(state, "test")
        searched, answered, new = first.replans[-1], again.replans[-1], fresh.replans[-1]
        assert not searched.recalled
        assert not new.recalled
        assert answered.recalled == (searched.space is Space.PRUNED)
        recalled += answered.recalled
        assert (answered.space, answered.cost, answered.status) == (new.space, new.cost, new.status)
        assert answered.tree is not None
        assert new.tree is not None
        if answered.recalled:  # (the full space's trees come from searches continued differently)
            assert node_to_dict(answered.tree, task) == node_to_dict(new.tree, task)
        run = run_tree(answered.tree, task.from_state(state), state, 1000)
        assert run.reached
        assert run.cost == answered.cost
    assert recalled >= 3


def test_a_state_whose_hints_space_held_no_tree_goes_straight_to_the_full_space(
    robothow_small: Scenario, monkeypatch: pytest.MonkeyPatch
) -> None:
    """Hints without Close hold no tree for the goal: the second re-plan from the state searches the
    full space only (the hints' space is not searched again), at the full space's optimum."""
    task = robothow_small.task
    goal = task.resolve_goal(GOAL)
    hints = hints_from_names(predicates=["Walk", "RightGrab", "Open", "RightPutIn"], objects=["apple", "fridge"])
    kept = KeptSearch()
    pruned_searches: list[int] = []
    original = Replanner._pruned

    def counted(self: Replanner, *args: object) -> tuple[PlanResult | None, bool]:
        pruned_searches.append(1)
        return original(self, *args)  # type: ignore[arg-type]

    monkeypatch.setattr(Replanner, "_pruned", counted)
    state = disturbed(robothow_small, goal, 1)[0]
    for _ in range(2):
        policy = Replanner(robothow_small, goal, None, ReplanOptions(hints=hints, kept=kept))
        assert policy.replan(state, "test")
        replan = policy.replans[-1]
        assert (replan.space, replan.recalled) == (Space.FULL, False)
        assert replan.cost == replanning.full_space_cost(robothow_small, goal, state)
    assert len(pruned_searches) == 1


def test_a_replan_a_time_limit_ended_is_not_kept(robothow_small: Scenario) -> None:
    task = robothow_small.task
    goal = task.resolve_goal(GOAL)
    state = disturbed(robothow_small, goal, 1)[0]
    kept = KeptSearch()
    hurried = Replanner(robothow_small, goal, None, ReplanOptions(hints=HINTS, kept=kept, budget_s=1e-9))
    assert not hurried.replan(state, "test")
    assert hurried.replans[-1].status == Status.TIMEOUT.value
    policy = Replanner(robothow_small, goal, None, ReplanOptions(hints=HINTS, kept=kept))
    assert policy.replan(state, "test")
    assert not policy.replans[-1].recalled


def test_the_kept_answers_are_bounded_and_belong_to_one_pruned_space(
    robothow_small: Scenario, monkeypatch: pytest.MonkeyPatch
) -> None:
    task = robothow_small.task
    kept = KeptSearch()
    kept.pruned_space(task, HINTS)
    answer = PlanResult(Status.SOLVED, "obtea", task.resolve_goal(GOAL))
    monkeypatch.setattr(kept_module, "KEPT_ANSWERS", 2)
    for key in ("a", "b", "c"):
        kept.remember(key, answer)
    assert kept.recall("a") == (False, None)  # the oldest, dropped
    assert kept.recall("c") == (True, answer)
    kept.remember("none", None)
    assert kept.recall("none") == (True, None)
    kept.pruned_space(task, hints_from_names(predicates=["Walk"], objects=["apple"]))  # another space
    assert kept.recall("c") == (False, None)


@pytest.mark.parametrize("heuristic", ["hmax", "lm"])
def test_the_hints_space_is_searched_with_its_own_heuristic(robothow_small: Scenario, heuristic: str) -> None:
    """ReplanOptions.pruned_heuristic (h_max by default) orders the hints' space's search: each re-plan
    answered there is the tree a plain OBTEA search of the widened space with it gives, at the same
    optimal cost in that space whichever the heuristic."""
    task = robothow_small.task
    goal = task.resolve_goal(GOAL)
    options = ReplanOptions(max_replans=100, hints=HINTS, pruned_heuristic=heuristic)  # type: ignore[arg-type]
    policy = Replanner(robothow_small, goal, None, options)
    other = "lm" if heuristic == "hmax" else "hmax"
    answered = 0
    for state in disturbed(robothow_small, goal, 20):
        assert policy.replan(state, "test")
        replan = policy.replans[-1]
        if replan.space is not Space.PRUNED:
            continue
        world = task.from_state(state)
        space = policy.kept.pruned_space(task, HINTS)
        here = world.resolve_goal(goal)
        proved = robothow_small.mutexes.proved_only()
        mutexes = proved if proved.conflict(state) is None else None
        config, other_config = (planner_config("obtea", heuristic=h) for h in (heuristic, other))  # type: ignore[arg-type]
        for widened in (space.around, space.beyond):
            actions = [world.actions[i] for i in widened(state)]
            mine = search(world, here, actions, config, mutexes=mutexes)
            if mine.solved:
                break
        theirs = search(world, here, actions, other_config, mutexes=mutexes)
        assert replan.tree is not None
        assert node_to_dict(replan.tree, task) == node_to_dict(tree_of(mine, "full"), task)
        assert replan.cost == mine.cost == theirs.cost
        answered += 1
    assert answered >= 3
