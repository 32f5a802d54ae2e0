"""Declared (unproved) mutexes only speed the search up: they never make hbtp answer "unsolvable".

Issue 14, defect B: RobotHow's declared hand groups and tool nogoods are false in odd corners of the
state space (tests/domains/test_mutex.py), so a goal they call contradictory may well be reachable. Only a
search pruned with *proved* mutexes may decide that a goal is unsolvable.
"""

from __future__ import annotations

import itertools
from pathlib import Path

import pytest

from hbtp.bt import tree_of
from hbtp.bt.jsonio import tree_from_json
from hbtp.cli import EXIT_OK, main
from hbtp.domains import DomainBuilder, Scenario, infer_mutexes
from hbtp.llm.backends.oracle import OracleBackend
from hbtp.logic.task import Goal, GroundTask
from hbtp.pipeline import LoopOptions, run_hbtp
from hbtp.planning import PLANNERS, Limits, PlanResult, SearchStats, Status, plan, search
from hbtp.planning.oracle import optimal_plan, oracle_hints
from hbtp.planning.planners import _remaining, confirmed_search, planner_config
from helpers import run_tree

ISSUE_GOAL = (
    "IsIn(kitchenknife,garbagecan) & IsRightHolding(self,plate) & IsRightHolding(self,rag) & IsSwitchedOn(microwave)"
)
ISSUE_COST = 126  # the optimum: OBTEA with proved mutexes only (and what the LLM loop found)


def assert_reaches(result: PlanResult, task: GroundTask, goal: Goal) -> None:
    """The result is solved, and its tree is verified and reaches the goal when ticked from s0."""
    assert result.status is Status.SOLVED, result.message
    run = run_tree(tree_of(result), task, task.initial_state, max_ticks=200)
    assert run.reached
    assert goal.ids <= run.state
    assert run.cost == result.cost


# ------------------------------------------------------------------------- the goal of the issue
def test_the_declared_hand_group_is_what_rejected_the_issue_goal(robothow_small: Scenario) -> None:
    task, mutexes = robothow_small.task, robothow_small.mutexes
    goal = task.resolve_goal(ISSUE_GOAL)
    assert mutexes.declared
    assert mutexes.conflict(goal.ids) is not None
    assert mutexes.proved_only().conflict(goal.ids) is None


@pytest.mark.parametrize("planner", PLANNERS)
def test_every_planner_solves_the_issue_goal_with_the_scenario_mutexes(robothow_small: Scenario, planner: str) -> None:
    task = robothow_small.task
    goal = task.resolve_goal(ISSUE_GOAL)
    result = plan(task, goal, planner, mutexes=robothow_small.mutexes, heuristic="lm")
    assert_reaches(result, task, goal)
    if planner == "obtea":
        assert result.cost == ISSUE_COST


def test_oracle_hints_for_the_issue_goal_solve_it_in_the_pruned_space(robothow_small: Scenario) -> None:
    task = robothow_small.task
    goal = task.resolve_goal(ISSUE_GOAL)
    plan_ids = optimal_plan(task, goal, robothow_small.mutexes)
    assert sum(task.actions[i].cost for i in plan_ids) == ISSUE_COST
    hints = oracle_hints(task, goal, robothow_small.mutexes)
    for planner in PLANNERS:
        result = plan(task, goal, planner, hints=hints, space="pruned", mutexes=robothow_small.mutexes)
        assert_reaches(result, task, goal)


@pytest.mark.parametrize("planner", PLANNERS)
def test_the_cli_solves_the_issue_goal(
    capsys: pytest.CaptureFixture[str], tmp_path: Path, robothow_small: Scenario, planner: str
) -> None:
    out = tmp_path / "tree.json"
    code = main(["plan", "-s", "robothow-small", "-p", planner, "-g", ISSUE_GOAL, "-o", str(out)])
    captured = capsys.readouterr()
    assert code == EXIT_OK, captured.out + captured.err
    assert captured.out.startswith("solved: ")
    if planner == "obtea":
        assert captured.out.startswith(f"solved: cost {ISSUE_COST},")
    root, _ = tree_from_json(out.read_text(encoding="utf-8"), robothow_small.task, str(out))
    run = run_tree(root, robothow_small.task, robothow_small.task.initial_state, max_ticks=200)
    assert run.reached
    assert robothow_small.task.resolve_goal(ISSUE_GOAL).ids <= run.state


def test_the_cli_solves_the_issue_goal_with_oracle_hints(capsys: pytest.CaptureFixture[str]) -> None:
    code = main(["plan", "-s", "robothow-small", "-p", "obtea", "-g", ISSUE_GOAL, "--hints", "oracle"])
    captured = capsys.readouterr()
    assert code == EXIT_OK, captured.out + captured.err
    assert captured.out.startswith(f"solved: cost {ISSUE_COST},")


def test_the_llm_loop_without_fallback_does_not_call_the_issue_goal_unsolvable(robothow_small: Scenario) -> None:
    task = robothow_small.task
    goal = task.resolve_goal(ISSUE_GOAL)
    options = LoopOptions(planner="obtea", feedback_rounds=1, fallback=False)
    loop = run_hbtp(robothow_small, goal, OracleBackend(robothow_small), (), options)
    assert loop.outcome.label == "NF"
    assert_reaches(loop.result, task, goal)


# ------------------------------------------------ systematic: what the declared mutexes call impossible
def _declared_conflicts(scenario: Scenario) -> list[tuple[int, ...]]:
    """Every pair of a declared group, and every declared nogood."""
    goals: list[tuple[int, ...]] = []
    for group in scenario.mutexes.groups:
        if not group.proved:
            goals.extend(itertools.combinations(sorted(group.atoms), 2))
    goals.extend(tuple(sorted(nogood)) for nogood in scenario.mutexes.nogoods)
    return goals


def test_robothow_small_declares_conflicts(robothow_small: Scenario) -> None:
    conflicts = _declared_conflicts(robothow_small)
    assert len(conflicts) == 44  # two hand groups of 7 atoms (21 pairs each) and two tool nogoods
    assert all(robothow_small.mutexes.proved_only().conflict(c) is None for c in conflicts)


@pytest.mark.parametrize("planner", PLANNERS)
def test_hbtp_agrees_with_proved_mutexes_on_every_declared_conflict(robothow_small: Scenario, planner: str) -> None:
    """Whatever hbtp answers for a goal the declared mutexes call contradictory, a search pruned
    with the proved mutexes only answers the same (status and, for OBTEA, cost)."""
    task = robothow_small.task
    proved = robothow_small.mutexes.proved_only()
    for ids in _declared_conflicts(robothow_small):
        goal = task.resolve_goal([task.atoms[i] for i in ids])
        answer = plan(task, goal, planner, mutexes=robothow_small.mutexes, heuristic="lm", limits=Limits(time_s=30))
        reference = plan(task, goal, planner, mutexes=proved, heuristic="lm", limits=Limits(time_s=30))
        assert answer.status is reference.status, (str(goal), answer.message, reference.message)
        if planner == "obtea":
            assert answer.cost == reference.cost, str(goal)
        if answer.solved:
            assert_reaches(answer, task, goal)


# -------------------------------------------------------------- the rule, on a tiny hand-built task
def _quirky_task() -> tuple[GroundTask, Goal]:
    """``Empty`` and ``Holding(x)`` look exclusive but ``Quirk`` makes both hold: the goal needs it."""
    builder = DomainBuilder("quirk")
    builder.action("Grab(x)", pre=["Empty()"], add=["Holding(x)"], delete=["Empty()"], cost=2)
    builder.action("Drop(x)", pre=["Holding(x)"], add=["Empty()"], delete=["Holding(x)"], cost=2)
    builder.action("Quirk(x)", pre=["Holding(x)", "Ready()"], add=["Empty()"], delete=[], cost=5)
    builder.action("Prepare(x)", pre=[], add=["Ready()"], delete=[], cost=1)
    builder.action("Bell(x)", pre=["Empty()", "Holding(x)"], add=["Rung()"], delete=[], cost=1)
    builder.initial(["Empty()"])
    task = builder.build()
    return task, task.resolve_goal("Rung()")


def test_a_search_the_declared_mutexes_emptied_is_decided_without_them() -> None:
    task, goal = _quirky_task()
    mutexes = infer_mutexes(task, [["Empty()", "Holding(*)"]])
    assert mutexes.declared
    config = planner_config("obtea")
    pruned = confirmed_search(task, goal, task.actions, config, mutexes=mutexes.proved_only())
    assert pruned.solved  # the proved mutexes alone allow the only solution
    assert search(task, goal, task.actions, config, mutexes=mutexes).status is Status.UNSOLVABLE
    for planner in PLANNERS:
        result = plan(task, goal, planner, mutexes=mutexes)
        assert_reaches(result, task, goal)
        assert result.cost == pruned.cost


def test_a_goal_only_the_declared_mutexes_reject_is_planned() -> None:
    task, _ = _quirky_task()
    goal = task.resolve_goal("Empty() & Holding(x)")
    mutexes = infer_mutexes(task, [["Empty()", "Holding(*)"]])
    assert mutexes.conflict(goal.ids) is not None
    result = plan(task, goal, "obtea", mutexes=mutexes)
    assert_reaches(result, task, goal)


def test_no_time_or_expansions_left_is_a_limit_not_a_proof() -> None:
    task, goal = _quirky_task()
    mutexes = infer_mutexes(task, [["Empty()", "Holding(*)"]])
    declared_only = search(task, goal, task.actions, planner_config("obtea"), mutexes=mutexes)
    assert declared_only.status is Status.UNSOLVABLE
    assert declared_only.stats.explored == 1
    # One expansion for the search with the declared mutexes, one for the search without them.
    result = plan(task, goal, "obtea", mutexes=mutexes, limits=Limits(max_expansions=2))
    assert result.status is Status.NODE_LIMIT
    assert _remaining(Limits(max_expansions=1), SearchStats(explored=1)) is Status.NODE_LIMIT
    assert _remaining(Limits(time_s=1.0), SearchStats(time_s=1.5)) is Status.TIMEOUT
    assert _remaining(Limits(time_s=2.0, max_expansions=5), SearchStats(time_s=0.5, explored=2)) == Limits(1.5, 3)


def test_a_really_unsolvable_goal_is_still_unsolvable() -> None:
    builder = DomainBuilder("stuck")
    builder.action("Grab(x)", pre=["Empty()"], add=["Holding(x)"], delete=["Empty()"], cost=2)
    builder.action("Drop(x)", pre=["Holding(x)"], add=["Empty()"], delete=["Holding(x)"], cost=2)
    builder.action("Paint(x)", pre=["Empty()", "Holding(x)"], add=["Painted(x)"], delete=[], cost=1)
    builder.initial(["Empty()"])
    task = builder.build()
    mutexes = infer_mutexes(task, [["Empty()", "Holding(*)"]], [["Painted(x)", "Empty()"]])
    for text in ("Painted(x)", "Empty() & Holding(x)"):
        result = plan(task, text, "obtea", mutexes=mutexes)
        assert result.status is Status.UNSOLVABLE
        assert plan(task, text, "obtea").status is Status.UNSOLVABLE  # no mutexes at all: the same


def test_proved_only_is_computed_once_and_is_itself_when_nothing_is_declared(robothow_small: Scenario) -> None:
    mutexes = robothow_small.mutexes
    proved = mutexes.proved_only()
    assert proved is mutexes.proved_only()
    assert not proved.declared
    assert proved.proved_only() is proved
    assert all(group.proved for group in proved.groups)
    assert proved.nogoods == ()
