"""Generated datasets and demonstrations: valid, optimal, deterministic, cached, and a too-small domain."""

from __future__ import annotations

import logging
from pathlib import Path

import pytest
from tests.helpers import brute_force, random_task

from hbtp.cli import EXIT_INPUT, main
from hbtp.datasets import read_text_file, validate_records
from hbtp.domains import Scenario, load_pddl_scenario
from hbtp.errors import InputError
from hbtp.llm import demonstrations
from hbtp.llm.demonstrations import PoolSettings, generated_pool, pool_key
from hbtp.llm.pool import example_pool
from hbtp.logic.execution import apply_actions
from hbtp.planning.generate import LEVELS, Draw, Sampling, generate_records, relaxed_reachable, sample_goals

HOUSE = Path(__file__).parent.parent / "data" / "household"
DOMAIN, PROBLEM, TINY = HOUSE / "domain.pddl", HOUSE / "problem.pddl", HOUSE / "tiny.problem.pddl"


@pytest.fixture(scope="module")
def house() -> Scenario:
    return load_pddl_scenario(DOMAIN, PROBLEM)


@pytest.mark.parametrize("draw", list(Draw))
@pytest.mark.parametrize("level", ["easy", "medium", "hard", "any"])
def test_generated_records_validate_fit_their_level_and_are_optimal(house: Scenario, level: str, draw: Draw) -> None:
    records = generate_records(house.task, level, 6, Sampling(seed=2, draw=draw), house.mutexes)
    assert len(records) == 6
    assert validate_records(records, house.task).valid
    window = LEVELS[level]
    for record in records:
        goal = house.task.resolve_goal(record.goal)
        assert window.fits(len(goal.atoms), len(record.optimal_actions))
        actions = [house.task.action(name) for name in record.optimal_actions]
        state, applied = apply_actions(house.task, actions)
        assert goal.ids <= state
        assert applied == len(actions)
        assert sum(a.cost for a in actions) == record.cost == brute_force(house.task, goal.ids)[0]


@pytest.mark.parametrize("draw", list(Draw))
@pytest.mark.parametrize("seed", range(12))
def test_sampled_goals_on_random_tasks_have_optimal_plans(seed: int, draw: Draw) -> None:
    task, _ = random_task(seed)
    if not any(a.pre <= task.initial_state for a in task.actions):
        with pytest.raises(InputError, match="no action applies"):
            sample_goals(task, LEVELS["any"], 4)
        return
    goals = sample_goals(task, LEVELS["any"], 4, Sampling(seed=seed, attempts=10, draw=draw))
    for labelled in goals:
        assert not labelled.goal.ids <= task.initial_state
        actions = [task.actions[i] for i in labelled.plan]
        state, applied = apply_actions(task, actions)
        assert labelled.goal.ids <= state
        assert applied == len(actions)
        assert sum(a.cost for a in actions) == labelled.cost == brute_force(task, labelled.goal.ids)[0]


@pytest.mark.parametrize("seed", range(12))
def test_relaxed_reachable_atoms_hold_every_atom_a_plan_reaches(seed: int) -> None:
    """Every state reached by applying actions from s0 lies within the relaxed reachable atoms, and
    every one of those atoms is added by an action whose preconditions are among them (or holds in s0)."""
    task, _ = random_task(seed)
    reached = relaxed_reachable(task)
    assert task.initial_state <= reached
    frontier, seen = [task.initial_state], {task.initial_state}
    while frontier:
        state = frontier.pop()
        assert state <= reached
        for action in task.actions:
            if action.pre <= state and (after := action.progress(state)) not in seen:
                seen.add(after)
                frontier.append(after)
    supported = set(task.initial_state) | {atom for a in task.actions if a.pre <= reached for atom in a.add}
    assert reached == supported


def test_reachable_goals_reach_further_than_walk_goals() -> None:
    """On RobotHow-Small, goals of the wide level drawn from the reachable atoms have longer optimal
    plans on average than those drawn from walks' ends (same seed and count: walks rarely reach the
    level's long plans)."""
    from hbtp.domains import load_scenario

    world = load_scenario("robothow-small")
    lengths = {}
    for draw in Draw:
        records = generate_records(world.task, "any", 12, Sampling(seed=3, draw=draw), world.mutexes)
        assert len(records) == 12
        lengths[draw] = sum(len(r.optimal_actions) for r in records) / len(records)
    assert lengths[Draw.REACHABLE] > lengths[Draw.WALK]


def _generate(tmp_path: Path, name: str, *extra: str) -> bytes:
    out = tmp_path / name
    args = ["dataset", "generate", "--pddl", str(DOMAIN), str(PROBLEM), "-n", "5", "-o", str(out), *extra]
    assert main(args) == 0
    return out.read_bytes()


def test_same_seed_same_bytes_and_the_file_validates(tmp_path: Path) -> None:
    first = _generate(tmp_path, "a.txt", "--level", "hard", "--seed", "7")
    assert first == _generate(tmp_path, "b.txt", "--level", "hard", "--seed", "7")
    assert first != _generate(tmp_path, "c.txt", "--level", "hard", "--seed", "8")
    assert main(["dataset", "validate", str(tmp_path / "a.txt"), "--pddl", str(DOMAIN), str(PROBLEM)]) == 0
    assert len(read_text_file(tmp_path / "a.txt")) == 5


def test_examples_command_writes_the_pool_the_domain_gets(
    tmp_path: Path, house: Scenario, monkeypatch: pytest.MonkeyPatch
) -> None:
    out = tmp_path / "examples.txt"
    assert main(["examples", "generate", "--pddl", str(DOMAIN), str(PROBLEM), "-o", str(out)]) == 0
    monkeypatch.setenv("HBTP_NO_CACHE", "1")
    assert read_text_file(out) == generated_pool(house)


def test_too_small_domain_is_a_one_line_error_or_an_empty_pool(
    capsys: pytest.CaptureFixture[str], caplog: pytest.LogCaptureFixture
) -> None:
    assert main(["examples", "generate", "--pddl", str(DOMAIN), str(TINY)]) == EXIT_INPUT
    error = capsys.readouterr().err.strip()
    assert error.count("\n") == 0
    assert "too small to sample goals from" in error
    with caplog.at_level(logging.WARNING):
        assert example_pool(load_pddl_scenario(DOMAIN, TINY)) == []
    assert any("none can be generated" in r.getMessage() for r in caplog.records)


def test_pool_is_generated_once_then_read_from_the_cache(
    tmp_path: Path, house: Scenario, monkeypatch: pytest.MonkeyPatch, caplog: pytest.LogCaptureFixture
) -> None:
    monkeypatch.delenv("HBTP_NO_CACHE", raising=False)
    monkeypatch.setenv("HBTP_CACHE_DIR", str(tmp_path / "cache"))
    settings = PoolSettings(count=5)
    with caplog.at_level(logging.WARNING):
        made = generated_pool(house, settings)
    assert len(made) == 5
    assert any("generated 5 from sampled goals (cached at" in r.getMessage() for r in caplog.records)
    files = list((tmp_path / "cache").glob("demonstrations-*.json"))
    assert len(files) == 1

    def refuse(*args: object, **kwargs: object) -> None:
        raise AssertionError("a cache hit must not generate")

    monkeypatch.setattr(demonstrations.generate, "generate_records", refuse)
    assert generated_pool(house, settings) == made  # hit
    monkeypatch.undo()
    monkeypatch.delenv("HBTP_NO_CACHE", raising=False)
    monkeypatch.setenv("HBTP_CACHE_DIR", str(tmp_path / "cache"))
    other = PoolSettings(count=5, sampling=Sampling(seed=1))
    assert pool_key(house, other) != pool_key(house, settings)
    generated_pool(house, other)  # miss: another key, another file
    assert len(list((tmp_path / "cache").glob("demonstrations-*.json"))) == 2
    files[0].write_text("{not json", encoding="utf-8")
    with caplog.at_level(logging.WARNING):
        assert generated_pool(house, settings) == made  # a broken entry is regenerated
    assert any("ignoring the demonstration cache" in r.getMessage() for r in caplog.records)


def test_key_follows_the_problem_contents(tmp_path: Path, house: Scenario) -> None:
    copy = tmp_path / "problem.pddl"
    copy.write_text(PROBLEM.read_text(encoding="utf-8").replace("(item-at book livingroom)", ""), encoding="utf-8")
    changed = load_pddl_scenario(DOMAIN, copy)
    assert pool_key(changed, PoolSettings()) != pool_key(house, PoolSettings())
