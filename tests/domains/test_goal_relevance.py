"""A scenario for one goal (:meth:`Scenario.for_goal`): only the actions relevant to the goal, as Fast
Downward's translator keeps for a problem's goal; the search, its tree and its cost are unchanged."""

from __future__ import annotations

import json
from pathlib import Path

import pytest

from hbtp.bt.build import tree_of
from hbtp.bt.jsonio import tree_to_json
from hbtp.cli import EXIT_OK, main
from hbtp.domains import Scenario, infer_mutexes, load_pddl_scenario
from hbtp.logic.relevance import relevant_actions
from hbtp.planning import plan, planner_config
from helpers import brute_force, random_case, run_tree

SWITCH = """(define (domain switch) (:requirements :strips :typing) (:types lamp)
  (:predicates (on ?l - lamp) (off ?l - lamp) (lit))
  (:action turn-on :parameters (?l - lamp) :precondition (off ?l) :effect (and (on ?l) (not (off ?l))))
  (:action show :parameters (?l - lamp) :precondition (on ?l) :effect (lit)))
"""
PROBLEM = """(define (problem p) (:domain switch) (:objects l0 l1 l2 - lamp)
  (:init (off l0) (off l1) (off l2)) (:goal (on l1)))
"""


def _files(tmp_path: Path) -> tuple[str, str]:
    (tmp_path / "d.pddl").write_text(SWITCH, encoding="utf-8")
    (tmp_path / "p.pddl").write_text(PROBLEM, encoding="utf-8")
    return str(tmp_path / "d.pddl"), str(tmp_path / "p.pddl")


def _scenario(seed: int) -> tuple[Scenario, object]:
    case = random_case(seed)
    scenario = Scenario(
        name="r", title="r", description="", task=case.task, mutexes=infer_mutexes(case.task),
        domain_file=Path("d.pddl"), problem_file=Path("p.pddl"),
    )  # fmt: skip
    return scenario, case


@pytest.mark.parametrize("seed", range(150))
def test_the_goals_scenario_plans_the_same_tree_and_the_brute_force_optimum(seed: int) -> None:
    whole, case = _scenario(seed)
    goal = case.goal  # type: ignore[attr-defined]
    part = whole.for_goal(goal)
    kept = {a.name for a in part.task.actions}
    assert kept == {whole.task.actions[i].name for i in relevant_actions(whole.task, goal)}
    assert part.task.atoms == whole.task.atoms
    assert part.task.initial_state == whole.task.initial_state
    assert [a.index for a in part.task.actions] == list(range(len(part.task.actions)))
    optimum, best = brute_force(whole.task, goal.ids)
    assert brute_force(part.task, goal.ids)[0] == optimum
    # every action of an optimal plan is relevant to the goal
    assert {whole.task.actions[i].name for i in best} <= kept
    trees = []
    for scenario in (whole, part):
        config = planner_config("obtea", heuristic="seq", symmetry=True)
        result = plan(scenario.task, goal, config, mutexes=scenario.mutexes)
        assert result.cost == optimum
        if result.solved:
            tree = tree_of(result, "full")
            assert run_tree(tree, scenario.task, scenario.task.initial_state, 50).reached
            trees.append(json.dumps(tree_to_json(tree, scenario.task, scenario="r", goal=goal, complete=True)))
    assert len(set(trees)) <= 1  # the same tree, action for action


def test_a_goal_every_action_serves_keeps_the_scenario_itself(tmp_path: Path) -> None:
    whole = load_pddl_scenario(*_files(tmp_path))
    assert whole.task.keeping(range(len(whole.task.actions))) is whole.task
    scenario, goal = whole.resolve_goal("lit() & on(l0) & on(l2)")
    assert scenario.for_goal(goal) is scenario
    scenario, goal = whole.resolve_goal("on(l0) & on(l2)")
    assert [a.name for a in scenario.for_goal(goal).task.actions] == ["turn-on(l0)", "turn-on(l2)"]


def test_kept_actions_are_renumbered_with_their_effects_and_costs() -> None:
    whole, _ = _scenario(7)
    task = whole.task
    part = task.keeping([len(task.actions) - 1, 0])
    assert [a.name for a in part.actions] == [task.actions[0].name, task.actions[-1].name]
    assert [a.index for a in part.actions] == [0, 1]
    for new, old in zip(part.actions, (task.actions[0], task.actions[-1]), strict=True):
        assert (new.pre, new.add, new.delete, new.cost) == (old.pre, old.add, old.delete, old.cost)
    assert part.action_ids == {a.signature: a.index for a in part.actions}


def _run(capsys: pytest.CaptureFixture[str], *argv: str) -> tuple[int, str]:
    code = main(list(argv))
    return code, capsys.readouterr().out


def test_plan_searches_the_goals_actions_and_its_tree_reloads_whole(
    tmp_path: Path, capsys: pytest.CaptureFixture[str]
) -> None:
    domain, problem = _files(tmp_path)
    whole = load_pddl_scenario(domain, problem)
    assert len(whole.task.actions) == 6
    out = tmp_path / "tree.json"
    code, output = _run(capsys, "plan", "--pddl", domain, problem, "--json", "-o", str(out))
    assert code == EXIT_OK, output
    record = json.loads(output)
    assert (record["status"], record["cost"], record["action_space"]) == ("solved", 1, 1)
    assert record["executed"] == ["turn-on(l1)"]
    # the tree names its actions: run and verify read it in the whole grounding
    assert _run(capsys, "verify", str(out))[0] == EXIT_OK
    code, output = _run(capsys, "run", str(out))
    assert code == EXIT_OK, output
    assert "goal reached" in output


def test_plan_with_a_goal_given_uses_that_goals_actions(tmp_path: Path, capsys: pytest.CaptureFixture[str]) -> None:
    domain, problem = _files(tmp_path)
    code, output = _run(capsys, "plan", "--pddl", domain, problem, "-g", "lit()", "--json")
    assert code == EXIT_OK, output
    record = json.loads(output)
    # lit() is shown by any lamp that is on: every turn-on and every show is relevant
    assert (record["status"], record["cost"], record["action_space"]) == ("solved", 2, 6)


def test_ground_counts_the_actions_of_the_problems_goal(tmp_path: Path, capsys: pytest.CaptureFixture[str]) -> None:
    domain, problem = _files(tmp_path)
    code, output = _run(capsys, "ground", "--pddl", domain, problem)
    assert code == EXIT_OK
    assert "actions            6" in output
    assert "goal_actions       1 (relevant to the problem's :goal)" in output
    code, output = _run(capsys, "ground", "-s", "robowaiter", "--json")
    assert json.loads(output)["goal_actions"] is None  # a shipped scenario's problem has no goal
