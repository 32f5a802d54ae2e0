"""Pruning before grounding: a world's names without grounding it, its parts, and the loop in it."""

from __future__ import annotations

import json
import random
from pathlib import Path

import pytest

from hbtp.bt import tree_of
from hbtp.bt.simulate import simulate
from hbtp.bt.verify import verify
from hbtp.cli import EXIT_OK, main
from hbtp.datasets import load_dataset
from hbtp.domains import load_scenario
from hbtp.domains.grounding import Selection, ground
from hbtp.domains.pruned import PrunedWorld, _named, lifted_names
from hbtp.domains.scenarios import Scenario, ScenarioOptions, read_pddl
from hbtp.llm.backend import PromptStyle, Reply, Request
from hbtp.llm.backends.oracle import OracleBackend
from hbtp.llm.pool import example_pool
from hbtp.llm.prompt import build_request
from hbtp.logic.names import names_of
from hbtp.logic.task import GroundTask
from hbtp.pipeline import LoopOptions, Outcome, run_hbtp
from hbtp.planning.result import PlanResult


def _world(name: str) -> PrunedWorld:
    shipped = load_scenario(name)
    return PrunedWorld.load(shipped.domain_file, shipped.problem_file, ScenarioOptions.shipped(name))


def _reaches(result: PlanResult, task: GroundTask, goal: str) -> bool:
    resolved = task.resolve_goal(goal)
    tree = tree_of(result)
    return verify(tree, task, resolved.ids, from_initial_state=True).ok and simulate(tree, task).reached(resolved.ids)


def _action_facts(task: GroundTask) -> dict[str, tuple[frozenset[str], frozenset[str], frozenset[str], int]]:
    def named(ids: frozenset[int]) -> frozenset[str]:
        return frozenset(str(task.atoms[i]) for i in ids)

    return {str(a.signature): (named(a.pre), named(a.add), named(a.delete), a.cost) for a in task.actions}


@pytest.mark.parametrize("name", ["robowaiter", "robothow-small", "virtualhome"])
def test_the_names_of_a_world_not_grounded_are_the_grounded_ones(name: str) -> None:
    full = names_of(load_scenario(name).task)
    listed = _world(name).names
    assert listed.actions == full.actions
    assert listed.costs == full.costs
    assert (listed.objects, listed.constants) == (full.objects, full.constants)
    assert dict(listed.categories) == dict(full.categories)
    assert set(listed.condition_slots) == set(full.condition_slots)
    for predicate, slots in full.condition_slots.items():  # read off the lifted model: a superset
        lifted = listed.condition_slots[predicate]
        assert all(mine <= theirs for mine, theirs in zip(slots, lifted, strict=False))


def test_a_part_is_the_full_worlds_actions_of_the_pruned_space(robothow_small: Scenario) -> None:
    world = _world("robothow-small")
    predicates, objects = frozenset({"Walk", "RightGrab", "RightPutIn", "Open"}), frozenset({"apple", "fridge"})
    part = world.part(predicates, objects)
    full = _action_facts(robothow_small.task)
    mine = _action_facts(part.task)
    expected = {
        str(a.signature)
        for a in robothow_small.task.actions
        if a.predicate in predicates and all(o in objects for o in a.objects)
    }
    assert set(mine) == expected
    assert mine, "the part must not be empty"
    assert all(mine[n] == full[n] for n in mine)  # the same preconditions, effects and costs
    assert world.part(predicates, objects) is part  # kept
    assert not world.grounded


class _Garbage:
    """A model that never names anything of the world: every round fails, the fallback decides."""

    name = "garbage"
    prompt_style = PromptStyle.CHAT

    def complete(self, request: Request) -> Reply:
        text = f"Optimal Actions: Teleport_unicorn\nVital Action Predicates: Fly\nVital Objects: moon{request.round}\n"
        return Reply(text, 0.01)

    def close(self) -> None:
        pass


@pytest.mark.parametrize("index", range(4))
def test_the_loop_in_a_pruned_world_plans_what_the_grounded_loop_plans(robothow_small: Scenario, index: int) -> None:
    record = load_dataset(robothow_small.test_set or "")[index]
    world = _world("robothow-small")
    pool = example_pool(robothow_small)
    pruned = run_hbtp(world, record.goal, OracleBackend(robothow_small), pool)
    grounded = run_hbtp(robothow_small, record.goal, OracleBackend(robothow_small), pool)
    assert pruned.outcome == Outcome.after(0)
    assert pruned.result.cost == grounded.result.cost
    assert len(pruned.scenario.task.actions) < len(robothow_small.task.actions)
    assert _reaches(pruned.result, pruned.scenario.task, record.goal)
    assert not world.grounded  # the fallback never ran, so the whole world was never grounded


def test_the_fallback_grounds_the_whole_world_once(robothow_small: Scenario) -> None:
    world = _world("robothow-small")
    goal = "IsIn_apple_fridge & IsClose_fridge"
    loop = run_hbtp(world, goal, _Garbage(), example_pool(robothow_small), LoopOptions(feedback_rounds=1))
    assert loop.outcome == Outcome.FALLBACK
    assert world.grounded
    assert loop.scenario is world.whole()
    assert len(loop.scenario.task.actions) == len(robothow_small.task.actions)
    assert _reaches(loop.result, loop.scenario.task, goal)


def test_prompts_of_a_pruned_world_name_only_existing_actions(robothow_small: Scenario) -> None:
    world = _world("robothow-small")
    request = build_request(world.names, "IsIn_apple_fridge", [], scenario="robothow-small")
    grounded = build_request(robothow_small.task, "IsIn_apple_fridge", [], scenario="robothow-small")
    assert request.constraint == grounded.constraint  # the same grammar: the same action names
    assert request.completion_prompt == grounded.completion_prompt


def test_plan_pruned_from_the_command_line(tmp_path: Path, capsys: pytest.CaptureFixture[str]) -> None:
    shipped = load_scenario("robothow-small")
    tree = tmp_path / "tree.json"
    argv = ["plan", "--pddl", str(shipped.domain_file), str(shipped.problem_file), "-g", "IsIn_apple_fridge"]
    argv += ["--llm", "noisy-oracle", "--grounding", "pruned", "--json", "-o", str(tree)]
    assert main(argv) == EXIT_OK
    record = json.loads(capsys.readouterr().out)
    assert record["status"] == "solved"
    assert record["llm"]["outcome"] in ("NF", "1F", "2F", "3F", "fallback")
    verify_argv = ["verify", str(tree), "--pddl", str(shipped.domain_file), str(shipped.problem_file)]
    assert main(verify_argv) == EXIT_OK


def test_plan_pruned_rejects_auto(tmp_path: Path, capsys: pytest.CaptureFixture[str]) -> None:
    shipped = load_scenario("robowaiter")
    argv = ["plan", "--pddl", str(shipped.domain_file), str(shipped.problem_file), "-g", "On_Coffee_Bar"]
    assert main([*argv, "--llm", "auto:oracle", "--grounding", "pruned"]) == 2
    err = capsys.readouterr().err.strip().splitlines()
    assert len(err) == 1
    assert "--grounding pruned does not go with --llm auto" in err[0]


def test_payoff_runs_the_pruned_configuration(tmp_path: Path) -> None:
    out = tmp_path / "payoff"
    argv = ["bench", "payoff", "--llm", "oracle", "--pruned", "--sets", "none", "--levels", "none"]
    argv += ["--scales", "1.05", "--tasks", "2", "--executor", "inline", "--no-progress", "-o", str(out)]
    assert main(argv) == EXIT_OK
    rows = [json.loads(line) for line in (out / "results.jsonl").read_text(encoding="utf-8").splitlines()]
    pruned = [r for r in rows if r["config"] == "hbtp-pruned:oracle"]
    assert len(pruned) == 2
    assert all(r["verified"] and r["outcome"] == "NF" and not r["grounded_whole"] for r in pruned)
    assert all(r["load_kind"] == "names listed, pruned before grounding" for r in pruned)
    summary = json.loads((out / "summary.json").read_text(encoding="utf-8"))
    assert "hbtp-pruned:oracle" in summary["cells"][0]["against"]


IPC = Path(__file__).resolve().parents[3] / "shared" / "benchmarks" / "ipc"


@pytest.mark.skipif(not IPC.is_dir(), reason="the IPC benchmark files are not beside the checkout")
@pytest.mark.parametrize(
    ("domain", "problem"), [("rovers", "p01.pddl"), ("depot", "p01.pddl"), ("gripper", "prob01.pddl")]
)
def test_a_selection_grounds_what_its_filter_grounds(domain: str, problem: str) -> None:
    pddl = read_pddl(IPC / domain / "domain.pddl", IPC / domain / problem)
    names = PrunedWorld.load(IPC / domain / "domain.pddl", IPC / domain / problem, parsed=pddl).names
    rng = random.Random(domain)
    for _ in range(5):
        chosen = Selection(
            frozenset(rng.sample(names.action_predicates, k=max(1, len(names.action_predicates) // 2))),
            frozenset(rng.sample(sorted(names.symbols), k=max(1, len(names.symbols) * 2 // 3))),
        )
        fast = ground(pddl.domain, pddl.problem, only=chosen, reachable_only=True)
        plain = ground(pddl.domain, pddl.problem, only=lambda s, a, c=chosen: c(s, a), reachable_only=True)
        assert _action_facts(fast) == _action_facts(plain)
        assert fast.atoms == plain.atoms


IPC = Path(__file__).resolve().parents[2] / ".." / "shared" / "benchmarks" / "ipc"


@pytest.mark.skipif(not IPC.is_dir(), reason="the IPC benchmark files (../shared/benchmarks/ipc) are absent")
@pytest.mark.parametrize(
    ("folder", "problem"),
    [
        ("elevators-opt08-strips", "p01.pddl"),  # costs from :init, some undefined (dropped)
        ("barman-opt11-strips", "pfile01-001.pddl"),
        ("parking-opt11-strips", "pfile03-011.pddl"),
        ("scanalyzer-08-strips", "p01.pddl"),
        ("depot", "p01.pddl"),
    ],
)
def test_listed_names_come_in_the_grounded_order_with_the_grounded_costs(folder: str, problem: str) -> None:
    pddl = read_pddl(IPC / folder / "domain.pddl", IPC / folder / problem)
    listed = lifted_names(pddl)
    full = names_of(ground(pddl.domain, pddl.problem))
    assert list(listed.actions) == sorted(listed.actions, key=str)
    # the listing keeps the actions that change nothing (drive from a place to itself), which a grounding drops
    cost = dict(zip(listed.actions, listed.costs, strict=True))
    assert [cost.get(action) for action in full.actions] == list(full.costs)


def test_names_that_sort_before_the_comma_are_ordered_by_the_names_themselves() -> None:
    # "go!(b)" < "go(b!)" < "go(b)" as names, while the schemas and arguments sort the other way.
    pddl = load_scenario("robowaiter").pddl
    bindings = {"go": ((("b",), 1), (("b!",), 1)), "go!": ((("b",), 2),)}
    named = _named(bindings, {}, pddl)
    assert [str(atom) for atom, _ in named] == ["go!(b)", "go(b!)", "go(b)"]
    assert [cost for _, cost in named] == [2, 1, 1]
    plain = _named({"go": ((("b",), 1), (("bb",), 1)), "go_on": ((("a",), 2),)}, {}, pddl)
    assert [str(atom) for atom, _ in plain] == ["go(b)", "go(bb)", "go_on(a)"]
