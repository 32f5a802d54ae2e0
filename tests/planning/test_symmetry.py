"""Interchangeable objects and the symmetry pruning of the backward search (hbtp.planning.symmetry).

* on random tasks grounded from random schemas over three objects of one kind and one other, with
  s0 and goal closed under permutations of some of the three (so they are interchangeable), OBTEA
  with symmetry pruning finds the brute-force optimum, its tree is verified and reaches the goal, and
  it prunes conditions in many of them;
* every canonical image is a condition that costs exactly as much to reach from s0 as the condition
  itself (brute force), and is the condition with its class objects permuted;
* a goal that names one of the objects makes it no longer interchangeable; a pruned space and a
  heuristic path switch the pruning off;
* gripper (shipped IPC files): the balls are one class, OBTEA finds the optimal cost with far fewer
  conditions.
"""

from __future__ import annotations

import itertools
import json
import logging
import random
from pathlib import Path

import pytest

from hbtp.bt import full_tree
from hbtp.cli import EXIT_INPUT, EXIT_OK, main
from hbtp.domains import DomainBuilder
from hbtp.domains.scenarios import load_pddl_scenario
from hbtp.logic.task import GroundTask
from hbtp.planning import plan
from hbtp.planning.heuristic_names import HeuristicName
from hbtp.planning.hints import Hints
from hbtp.planning.planners import planner_config
from hbtp.planning.symmetry import find_symmetry
from helpers import brute_force, run_tree

IPC = Path(__file__).resolve().parents[3] / "shared" / "benchmarks" / "ipc"
KIND = ("a0", "a1", "a2")
OBJECTS = (*KIND, "c0")


def _orbit(atoms: set[str], group: tuple[str, ...]) -> set[str]:
    """``atoms`` with every permutation of ``group`` applied (text atoms ``P(x,y)``)."""
    closed = set()
    for order in itertools.permutations(group):
        rename = dict(zip(group, order, strict=True))
        for atom in atoms:
            name, _, rest = atom.partition("(")
            args = [rename.get(x, x) for x in rest.rstrip(")").split(",") if x]
            closed.add(f"{name}({','.join(args)})")
    return closed


def symmetric_task(seed: int) -> tuple[GroundTask, list[str], tuple[str, ...]]:
    """A random task whose s0 and goal are closed under the permutations of ``group`` (two or three
    of the a-objects): schemas over unary P, D and binary R, grounded over every object tuple.

    Every third task is then made nearly symmetric, in a way that the objects' counts of atoms and
    actions do not show: s0 gets a directed cycle R(a0,a1), R(a1,a2), R(a2,a0) (symmetric under
    rotation only), or one ground action costs one more, or adds one more atom."""
    rng = random.Random(seed)
    group = KIND[: rng.choice((2, 3))]
    breaking = rng.choice(("cycle", "cost", "effect")) if seed % 3 == 0 else None
    builder = DomainBuilder(f"symmetric-{seed}")
    odd = rng.randrange(6)  # which ground action of the first schema is made different
    for j in range(rng.randint(3, 5)):
        arity = rng.choice((1, 2))
        params = ("?x", "?y")[:arity]
        atoms = [f"P({p})" for p in params] + [f"D({p})" for p in params]
        if arity == 2:
            atoms += ["R(?x,?y)", "R(?y,?x)"]
        pre = rng.sample(atoms, rng.randint(0, 2))
        add = rng.sample(atoms, rng.randint(1, 2))
        others = [a for a in atoms if a not in add]
        delete = rng.sample(others, min(len(others), rng.randint(0, 1)))
        cost = rng.randint(1, 4)
        for number, args in enumerate(itertools.permutations(OBJECTS, arity)):
            bind = dict(zip(params, args, strict=True))
            different = j == 0 and number == odd
            extra_cost = 1 if different and breaking == "cost" else 0
            extra_add = ["D(?x)" if "D(?x)" not in add else "P(?x)"] if different and breaking == "effect" else []

            def ground(atom: str, bind: dict[str, str] = bind) -> str:
                for param, value in bind.items():
                    atom = atom.replace(param, value)
                return atom

            adds = [ground(a) for a in (*add, *extra_add)]
            deletes = [ground(a) for a in delete if a not in extra_add]
            builder.action(f"S{j}({','.join(args)})", pre=[ground(a) for a in pre], add=adds, delete=deletes,
                           cost=cost + extra_cost)  # fmt: skip
    facts = [f"{p}({o})" for p in "PD" for o in OBJECTS] + [
        f"R({x},{y})" for x, y in itertools.permutations(OBJECTS, 2)
    ]
    initial = _orbit(set(rng.sample(facts, rng.randint(1, 3))), group)
    if breaking == "cycle":
        initial |= {"R(a0,a1)", "R(a1,a2)", "R(a2,a0)"}
    builder.initial(sorted(initial))
    task = builder.build()
    known = {str(atom) for atom in task.atoms}
    goal = sorted(a for a in _orbit(set(rng.sample(facts, rng.randint(1, 2))), group) if a in known)
    if not goal:  # the drawn atoms are in no action: the orbit of one that is
        goal = sorted(_orbit({rng.choice(sorted(known))}, group))
    return task, goal, group


@pytest.mark.parametrize("heuristic", ["none", "lm"])
@pytest.mark.parametrize("seed", range(150))
def test_obtea_with_symmetry_pruning_is_optimal_on_symmetric_tasks(seed: int, heuristic: HeuristicName) -> None:
    task, goal_atoms, _ = symmetric_task(seed)
    goal = task.resolve_goal(goal_atoms)
    optimum = None if goal.unsolvable else brute_force(task, goal.ids)[0]
    result = plan(task, goal, planner_config("obtea", heuristic=heuristic, symmetry=True))
    if optimum is None:
        assert not result.solved
        return
    assert result.solved, seed
    assert result.cost == optimum, (seed, result.cost, optimum)
    run = run_tree(full_tree(result.expansions), task, task.initial_state, 200)
    assert run.reached
    assert run.cost == optimum


def test_the_random_symmetric_tasks_exercise_the_pruning() -> None:
    pruned = 0
    for seed in range(150):
        task, goal_atoms, _ = symmetric_task(seed)
        result = plan(task, task.resolve_goal(goal_atoms), planner_config("obtea", heuristic="lm", symmetry=True))
        pruned += result.stats.pruned_symmetric > 0
    assert pruned >= 15


@pytest.mark.parametrize("seed", range(80))
def test_a_canonical_image_is_a_permutation_that_costs_the_same(seed: int) -> None:
    task, goal_atoms, _ = symmetric_task(seed)
    symmetry = find_symmetry(task, task.resolve_goal(goal_atoms).disjuncts, task.actions)
    if symmetry is None:
        return
    renamings = [
        {
            o: t
            for members, order in zip(symmetry.classes, orders, strict=True)
            for o, t in zip(members, order, strict=True)
        }
        for orders in itertools.product(*(itertools.permutations(members) for members in symmetry.classes))
    ]
    rng = random.Random(seed)
    names = [str(atom) for atom in task.atoms]
    for _ in range(6):
        condition = frozenset(rng.sample(range(len(task.atoms)), rng.randint(1, 3)))
        image = symmetry.canonical(condition)
        texts = {names[i] for i in condition}
        assert {names[i] for i in image} in [_orbit_one(texts, rename) for rename in renamings]
        assert brute_force(task, condition)[0] == brute_force(task, image)[0], (seed, sorted(texts))


def _orbit_one(atoms: set[str], rename: dict[str, str]) -> set[str]:
    result = set()
    for atom in atoms:
        name, _, rest = atom.partition("(")
        args = [rename.get(x, x) for x in rest.rstrip(")").split(",") if x]
        result.add(f"{name}({','.join(args)})")
    return result


def gripper(balls: int, dearer: str | None = None) -> GroundTask:
    """Gripper with ``balls`` balls; the action named ``dearer`` costs 2."""
    builder = DomainBuilder(f"gripper-{balls}")
    for here, there in itertools.permutations("ab"):
        builder.action(
            f"Move({here},{there})", pre=[f"Robby({here})"], add=[f"Robby({there})"], delete=[f"Robby({here})"]
        )
    for ball, room, hand in itertools.product(range(balls), "ab", ("left", "right")):
        at, carry, robby, free = f"At(b{ball},{room})", f"Carry(b{ball},{hand})", f"Robby({room})", f"Free({hand})"
        pick = f"Pick(b{ball},{room},{hand})"
        builder.action(pick, pre=[at, robby, free], add=[carry], delete=[at, free], cost=2 if pick == dearer else 1)
        builder.action(f"Drop(b{ball},{room},{hand})", pre=[carry, robby], add=[at, free], delete=[carry])
    builder.initial(["Robby(a)", "Free(left)", "Free(right)", *(f"At(b{i},a)" for i in range(balls))])
    return builder.build()


def test_a_goal_that_names_an_object_keeps_it_apart() -> None:
    task = gripper(4)
    every = task.resolve_goal([f"At(b{i},b)" for i in range(4)])
    symmetry = find_symmetry(task, every.disjuncts, task.actions)
    assert symmetry is not None
    assert sorted(map(sorted, symmetry.classes)) == [["b0", "b1", "b2", "b3"], ["left", "right"]]
    one = task.resolve_goal(["At(b0,b)"])
    symmetry = find_symmetry(task, one.disjuncts, task.actions)
    assert symmetry is not None
    assert sorted(map(sorted, symmetry.classes)) == [["b1", "b2", "b3"], ["left", "right"]]
    assert find_symmetry(task, every.disjuncts, task.actions[:-1]) is None


def test_an_action_that_costs_more_keeps_its_objects_apart() -> None:
    task = gripper(3, dearer="Pick(b0,a,left)")
    symmetry = find_symmetry(task, task.resolve_goal([f"At(b{i},b)" for i in range(3)]).disjuncts, task.actions)
    assert symmetry is not None
    assert sorted(map(sorted, symmetry.classes)) == [["b1", "b2"]]


def test_symmetry_pruning_is_off_with_a_heuristic_path(caplog: pytest.LogCaptureFixture) -> None:
    task = gripper(4)
    goal = task.resolve_goal([f"At(b{i},b)" for i in range(4)])
    hints = Hints(path=("Pick(b0,a,left)",))
    with caplog.at_level(logging.INFO, logger="hbtp.planning.search_state"):
        with_path = plan(task, goal, planner_config("hbtp-s", symmetry=True), hints=hints)
    assert "no symmetry pruning: it needs the whole action space and no heuristic path" in caplog.text
    assert with_path.solved
    assert with_path.stats.pruned_symmetric == 0


def test_gripper_balls_and_hands_are_interchangeable() -> None:
    task = gripper(6)
    goal = task.resolve_goal([f"At(b{i},b)" for i in range(6)])
    plain = plan(task, goal, "obtea", heuristic="lmcut")
    pruned = plan(task, goal, planner_config("obtea", heuristic="lmcut", symmetry=True))
    assert plain.solved
    assert pruned.solved
    assert pruned.cost == plain.cost == 17
    assert pruned.stats.explored * 10 < plain.stats.explored
    assert run_tree(full_tree(pruned.expansions), task, task.initial_state, 100).reached


@pytest.mark.skipif(not (IPC / "gripper").is_dir(), reason="the shared IPC benchmarks are not beside the checkout")
def test_gripper_from_the_ipc_files() -> None:
    scenario = load_pddl_scenario(IPC / "gripper" / "domain.pddl", IPC / "gripper" / "prob03.pddl")
    result = plan(
        scenario.task,
        scenario.problem_goal(),
        planner_config("obtea", heuristic="lmcut", symmetry=True),
        mutexes=scenario.mutexes,
    )
    assert result.solved
    assert result.cost == 23
    assert result.stats.pruned_symmetric > 0
    assert run_tree(full_tree(result.expansions), scenario.task, scenario.task.initial_state, 200).reached


@pytest.mark.skipif(not (IPC / "gripper").is_dir(), reason="the shared IPC benchmarks are not beside the checkout")
def test_the_command_line_flags(tmp_path: Path, capsys: pytest.CaptureFixture[str]) -> None:
    files = [str(IPC / "gripper" / "domain.pddl"), str(IPC / "gripper" / "prob02.pddl")]
    tree = tmp_path / "tree.json"
    argv = ["plan", "--pddl", *files, "-p", "obtea", "--heuristic", "lmcut", "--symmetry", "-o", str(tree)]
    assert main(argv) == EXIT_OK
    assert tree.is_file()
    capsys.readouterr()
    assert main(["plan", "--pddl", *files, "--llm", "oracle", "--symmetry"]) == EXIT_INPUT
    error = capsys.readouterr().err.strip()
    assert error == "hbtp: error: --symmetry applies to planning without an LLM (drop --llm or --symmetry)"
    suite = tmp_path / "suite" / "gripper"
    suite.mkdir(parents=True)
    for name in ("domain.pddl", "prob01.pddl"):
        (suite / name).write_text((IPC / "gripper" / name).read_text(encoding="utf-8"), encoding="utf-8")
    for flag, pruned in (("--symmetry", True), ("--no-symmetry", False)):
        out = tmp_path / flag
        assert (
            main(["bench", "pddl", str(suite.parent), flag, "--executor", "inline", "--no-progress", "-o", str(out)])
            == 0
        )
        row = json.loads((out / "results.jsonl").read_text(encoding="utf-8").splitlines()[0])
        assert row["symmetry"] is pruned
        assert row["solved"]
        assert row["cost"] == 11  # Fast Downward's optimum
        assert (row["pruned_symmetric"] > 0) is pruned
