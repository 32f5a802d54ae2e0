"""Self-placements: derived from the irreflexive relations the data declares, left out of plans,
kept by the benchmarks (the paper's action space)."""

from __future__ import annotations

import json
import re
from pathlib import Path

import pytest

from hbtp.bench.paper import paper_options, paper_scaled, paper_scenario
from hbtp.bt import Action, Node, tree_of
from hbtp.bt.disturb import disturbed_runs
from hbtp.bt.nodes import walk
from hbtp.bt.simulate import simulate
from hbtp.bt.verify import verify
from hbtp.cli import EXIT_OK
from hbtp.domains import load_pddl_scenario, load_scenario, scenario_names
from hbtp.domains.irreflexive import self_placements
from hbtp.domains.pruned import PrunedWorld
from hbtp.domains.scale import scaled_scenario
from hbtp.domains.scenarios import Scenario, ScenarioOptions
from hbtp.errors import InputError
from hbtp.logic.names import names_of
from hbtp.logic.task import GroundTask
from hbtp.planning import plan
from helpers import cli, one_error_line

ROBOTHOW_SELF_PLACEMENTS = sorted(
    f"{hand}{verb}({obj},{obj})"
    for hand in ("Left", "Right")
    for verb, objects in (
        ("Put", ("boardgame", "chair", "cuttingboard", "oventray", "radio", "rug")),
        ("PutIn", ("box", "clothespile", "cookingpot")),
    )
    for obj in objects
)
#: Per scenario: its declared irreflexive relations and the self-placements they make.
EXPECTED = {
    "robowaiter": (("On",), []),
    "virtualhome": (("IsOn", "IsIn"), ["LeftPut(plate,plate)", "RightPut(plate,plate)"]),
    "robothow-small": (("IsOn", "IsIn"), []),
    "robothow": (("IsOn", "IsIn"), ROBOTHOW_SELF_PLACEMENTS),
}
#: The paper's action counts (Table II and the reference notes).
PAPER_ACTIONS = {"robowaiter": 174, "virtualhome": 480, "robothow-small": 155, "robothow": 7329}
ROBUST_GOAL = "IsIn_milk_fridge & IsClose_fridge"


def _same_objects(action: str) -> bool:
    """An action name over one object twice (``LeftPut(chair,chair)``), read off the name alone."""
    match = re.fullmatch(r"\w+\(([^,()]+),([^,()]+)\)", action)
    return match is not None and match.group(1) == match.group(2)


# ------------------------------------------------------------------------- the derivation
@pytest.mark.parametrize("name", scenario_names())
def test_the_data_declares_the_placement_relations_irreflexive(name: str) -> None:
    assert tuple(ScenarioOptions.shipped(name).irreflexive) == EXPECTED[name][0]


@pytest.mark.parametrize("name", scenario_names())
def test_the_derivation_finds_exactly_the_expected_actions(name: str) -> None:
    paper = paper_scenario(name)
    found = [a.name for a in self_placements(paper.task, ScenarioOptions.shipped(name).irreflexive)]
    assert sorted(found) == EXPECTED[name][1]
    # Independently: in these domains, every action over one object twice puts it on or in itself.
    assert sorted(a.name for a in paper.task.actions if _same_objects(a.name)) == EXPECTED[name][1]


def test_robothow_has_eighteen_self_placements_twelve_of_them_puts() -> None:
    assert len(ROBOTHOW_SELF_PLACEMENTS) == 18
    assert len([a for a in ROBOTHOW_SELF_PLACEMENTS if "PutIn" not in a]) == 12
    assert {"LeftPut(chair,chair)", "LeftPut(boardgame,boardgame)"} <= set(ROBOTHOW_SELF_PLACEMENTS)


def test_nothing_is_left_out_without_declared_relations() -> None:
    paper = paper_scenario("robothow")
    assert self_placements(paper.task, ()) == ()
    assert paper.without_self_placements(()) is paper


def test_declared_relations_are_checked() -> None:
    task = paper_scenario("robothow-small").task
    with pytest.raises(InputError, match=r"unknown predicate 'IsOnn' \(did you mean 'IsOn'"):
        self_placements(task, ["IsOnn"])
    with pytest.raises(InputError, match="'IsOpen' has 1 argument"):
        self_placements(task, ["IsOpen"])


# ------------------------------------------------------------- plans leave them out, the paper keeps them
@pytest.mark.parametrize("name", scenario_names())
def test_plans_leave_them_out_and_the_benchmarks_keep_the_papers_action_space(name: str) -> None:
    paper, planned = paper_scenario(name), load_scenario(name)
    expected = EXPECTED[name][1]
    assert len(paper.task.actions) == PAPER_ACTIONS[name]
    assert paper.left_out == ()
    assert paper is load_scenario(name, keep_self_placements=True)
    assert len(planned.task.actions) == PAPER_ACTIONS[name] - len(expected)
    assert sorted(planned.left_out) == expected
    assert planned.summary()["left_out"] == len(expected)
    assert load_scenario(name) is planned  # kept
    kept = [a for a in paper.task.actions if a.name not in expected]
    assert [a.signature for a in planned.task.actions] == [a.signature for a in kept]
    assert all(
        (mine.pre, mine.add, mine.delete, mine.cost) == (theirs.pre, theirs.add, theirs.delete, theirs.cost)
        for mine, theirs in zip(planned.task.actions, kept, strict=True)
    )
    assert planned.task.atoms == paper.task.atoms
    assert planned.task.initial_state == paper.task.initial_state
    assert planned.mutexes is paper.mutexes
    if not expected:
        assert planned is paper


def test_the_benchmarks_load_only_the_papers_action_space() -> None:
    assert paper_options("robothow").keep_self_placements
    assert len(paper_scaled("virtualhome", 1.0).task.actions) == 480
    bench = Path(__file__).parent.parent.parent / "src" / "hbtp" / "bench"
    for module in sorted(bench.glob("*.py")):
        if module.name == "paper.py":
            continue
        text = module.read_text(encoding="utf-8")
        for loader in ("load_scenario(", "scaled_scenario(", "ScenarioOptions.shipped("):
            assert loader not in text, f"{module.name} calls {loader}: use hbtp.bench.paper"


def test_scaled_worlds_leave_them_out_unless_kept() -> None:
    planned, paper = scaled_scenario("virtualhome", 1.5), paper_scaled("virtualhome", 1.5)
    left_out = {a.name for a in paper.task.actions} - {a.name for a in planned.task.actions}
    assert left_out == set(planned.left_out)
    assert {"LeftPut(plate,plate)", "RightPut(plate,plate)"} <= left_out
    assert all(_same_objects(name) for name in left_out)


@pytest.mark.parametrize("keep", [False, True])
def test_the_names_of_a_world_not_grounded_leave_out_the_same_actions(keep: bool) -> None:
    shipped = load_scenario("virtualhome", keep_self_placements=keep)
    options = ScenarioOptions.shipped("virtualhome", keep_self_placements=keep)
    world = PrunedWorld.load(shipped.domain_file, shipped.problem_file, options)
    assert world.names.actions == names_of(shipped.task).actions
    part = world.part(frozenset({"RightPut", "LeftPut"}), frozenset({"plate"}))
    assert sorted(a.name for a in part.task.actions) == ([] if not keep else EXPECTED["virtualhome"][1])


# ------------------------------------------------------------------------- the robust tree
def _tree_actions(tree: Node, task: GroundTask) -> set[str]:
    return {task.actions[node.action].name for node in walk(tree) if isinstance(node, Action)}


def test_the_robust_robothow_tree_has_no_self_placement_and_reaches_the_goal() -> None:
    planned = load_scenario("robothow")
    result = plan(planned.task, ROBUST_GOAL, "obtea", mutexes=planned.mutexes, extra_expansions=200)
    assert result.solved
    tree = tree_of(result)
    goal = planned.task.resolve_goal(ROBUST_GOAL)
    actions = _tree_actions(tree, planned.task)
    assert len(actions) > 50
    assert not actions & set(ROBOTHOW_SELF_PLACEMENTS)
    assert not any(_same_objects(name) for name in actions)
    check = verify(tree, planned.task, goal, from_initial_state=True)
    assert check.ok, check.summary()
    assert check.proved_goal_reaching
    run = simulate(tree, planned.task)
    assert run.reached(goal)
    assert run.cost == result.cost == 59
    disturbed = disturbed_runs(tree, planned.task, planned.mutexes, 0.1, 10, seed=3)
    assert sum(r.reached(goal) for r in disturbed) >= 8
    for r in disturbed:
        assert not {planned.task.actions[i].name for i in r.executed} & set(ROBOTHOW_SELF_PLACEMENTS)


def test_the_same_tree_in_the_papers_action_space_holds_self_placements() -> None:
    paper = paper_scenario("robothow")
    result = plan(paper.task, ROBUST_GOAL, "obtea", mutexes=paper.mutexes, extra_expansions=200)
    assert {"LeftPut(chair,chair)", "LeftPut(boardgame,boardgame)"} <= _tree_actions(tree_of(result), paper.task)


def test_hbtp_plan_robust_leaves_them_out_and_its_tree_runs(capsys: pytest.CaptureFixture[str], tmp_path: Path) -> None:
    out = tmp_path / "robust.json"
    argv = ["plan", "-s", "robothow", "-g", ROBUST_GOAL, "-p", "obtea", "--robust", "200", "-o", str(out)]
    code, _, _ = cli(capsys, *argv)
    assert code == EXIT_OK
    text = out.read_text(encoding="utf-8")
    names = set(re.findall(r'"(\w+\([\w,]*\))"', text))
    assert any(name.startswith("LeftPutIn(") for name in names)
    assert not names & set(ROBOTHOW_SELF_PLACEMENTS)
    code, stdout, err = cli(capsys, "run", str(out))
    assert code == EXIT_OK, err
    assert stdout.startswith("goal reached")
    code, _, _ = cli(capsys, "verify", str(out))
    assert code == EXIT_OK
    code, _, _ = cli(capsys, *argv, "--keep-self-placements", "-o", str(tmp_path / "paper.json"))
    assert code == EXIT_OK
    assert "LeftPut(chair,chair)" in (tmp_path / "paper.json").read_text(encoding="utf-8")


# ------------------------------------------------------------------------- a user's PDDL
DOMAIN = """(define (domain stacking)
  (:requirements :strips)
  (:predicates (block ?x) (on ?x ?y) (holding ?x) (handempty) (clear ?x))
  (:action pick :parameters (?x)
    :precondition (and (block ?x) (handempty) (clear ?x))
    :effect (and (holding ?x) (not (handempty))))
  (:action stack :parameters (?x ?y)
    :precondition (and (block ?x) (block ?y) (holding ?x))
    :effect (and (on ?x ?y) (handempty) (not (holding ?x)))))
"""
PROBLEM = """(define (problem two) (:domain stacking)
  (:objects a b)
  (:init (block a) (block b) (handempty) (clear a) (clear b))
  (:goal (on a b)))
"""


@pytest.fixture
def stacking(tmp_path: Path) -> tuple[Path, Path]:
    domain, problem = tmp_path / "domain.pddl", tmp_path / "problem.pddl"
    domain.write_text(DOMAIN, encoding="utf-8")
    problem.write_text(PROBLEM, encoding="utf-8")
    return domain, problem


def _stack_names(scenario: Scenario) -> list[str]:
    return sorted(a.name for a in scenario.task.actions if a.predicate == "stack")


def test_a_users_pddl_is_untouched_unless_it_declares_irreflexive_relations(stacking: tuple[Path, Path]) -> None:
    domain, problem = stacking
    plain = load_pddl_scenario(domain, problem)
    assert _stack_names(plain) == ["stack(a,a)", "stack(a,b)", "stack(b,a)", "stack(b,b)"]
    assert plain.left_out == ()
    declared = load_pddl_scenario(domain, problem, ScenarioOptions(irreflexive=["on"]))
    assert _stack_names(declared) == ["stack(a,b)", "stack(b,a)"]
    assert declared.left_out == ("stack(a,a)", "stack(b,b)")
    kept = load_pddl_scenario(domain, problem, ScenarioOptions(irreflexive=["on"], keep_self_placements=True))
    assert _stack_names(kept) == _stack_names(plain)
    with pytest.raises(InputError, match="'holding' has 1 argument"):
        load_pddl_scenario(domain, problem, ScenarioOptions(irreflexive=["holding"], keep_self_placements=True))
    world = PrunedWorld.load(domain, problem, ScenarioOptions(irreflexive=["on"]))
    assert [str(a) for a in world.names.actions if a.predicate == "stack"] == ["stack(a,b)", "stack(b,a)"]


def test_irreflexive_on_the_command_line(capsys: pytest.CaptureFixture[str], stacking: tuple[Path, Path]) -> None:
    domain, problem = stacking
    pddl = ["--pddl", str(domain), str(problem)]
    code, out, _ = cli(capsys, "ground", *pddl, "--names")
    assert code == EXIT_OK
    assert "stack(a,a)" in out.split()
    code, out, _ = cli(capsys, "ground", *pddl, "--names", "--irreflexive", "on")
    assert code == EXIT_OK
    assert out.split() == ["pick(a)", "pick(b)", "stack(a,b)", "stack(b,a)"]
    tree = domain.parent / "tree.json"
    code, _, _ = cli(capsys, "plan", *pddl, "--irreflexive", "on", "-o", str(tree))
    assert code == EXIT_OK
    assert json.loads(tree.read_text(encoding="utf-8"))["pddl"]["irreflexive"] == ["on"]
    code, out, _ = cli(capsys, "run", str(tree))  # the recorded options: no --pddl needed
    assert code == EXIT_OK
    assert out.startswith("goal reached")
    code, _, err = cli(capsys, "ground", "-s", "robothow", "--irreflexive", "IsOn")
    assert code == 2
    assert "--irreflexive" in one_error_line(err)
    code, _, err = cli(capsys, "ground", *pddl, "--irreflexive", "clear")
    assert code == 2
    assert "'clear' has 1 argument" in one_error_line(err)
