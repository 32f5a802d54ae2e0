"""Grounding by relaxed reachability from s0, the fallback when the static bound on ground actions
exceeds the limit (issue 13 item 1: load what Fast Downward loads, such as tetris or tidybot, whose
static bound is in the millions): it must give exactly the actions that grounding everything and
then pruning by relaxed reachability gives."""

from __future__ import annotations

import json
from pathlib import Path

import pytest
from test_conditional_effects import RandomConditional
from test_negative_preconditions import RandomPddl
from test_quantified_preconditions import RandomQuantified

import hbtp.domains.ground_reach as ground_reach
import hbtp.domains.grounding as grounding
from hbtp.cli import main
from hbtp.domains import ground, read_domain_file, read_problem_file
from hbtp.errors import GroundingError
from hbtp.logic.task import GroundTask

IPC = Path(__file__).resolve().parents[3] / "shared" / "benchmarks" / "ipc"


@pytest.fixture
def forced(monkeypatch: pytest.MonkeyPatch) -> None:
    """Every grounding takes the fallback, as if the static bound were over the limit."""
    monkeypatch.setattr(grounding, "check_size", lambda prepared, limit: "(forced by the test)")


def _actions(task: GroundTask) -> set[tuple[str, tuple[str, ...], tuple[str, ...], tuple[str, ...], int]]:
    return {
        (a.name, tuple(task.names(a.pre)), tuple(task.names(a.add)), tuple(task.names(a.delete)), a.cost)
        for a in task.actions
    }


def _both(domain_file: Path, problem_file: Path, monkeypatch: pytest.MonkeyPatch) -> tuple[GroundTask, GroundTask]:
    """Grounded with ``reachable_only`` normally, then through the fallback."""
    domain = read_domain_file(domain_file)
    problem = read_problem_file(problem_file, domain)
    normal = ground(domain, problem, reachable_only=True)
    with monkeypatch.context() as patch:
        patch.setattr(grounding, "check_size", lambda prepared, limit: "(forced by the test)")
        reached = ground(domain, problem, reachable_only=True)
    return normal, reached


@pytest.mark.skipif(not IPC.is_dir(), reason="needs ../shared/benchmarks/ipc")
def test_the_fallback_grounds_the_same_actions_on_every_shipped_ipc_domain(monkeypatch: pytest.MonkeyPatch) -> None:
    for folder in sorted(p for p in IPC.iterdir() if p.is_dir()):
        problem = sorted(p for p in folder.glob("*.pddl") if "domain" not in p.name)[0]
        normal, reached = _both(folder / "domain.pddl", problem, monkeypatch)
        assert _actions(reached) == _actions(normal), folder.name
        assert reached.atoms == normal.atoms, folder.name


@pytest.mark.parametrize("kind", [RandomPddl, RandomQuantified, RandomConditional])
def test_the_fallback_grounds_the_same_actions_on_random_domains(
    kind: type, tmp_path: Path, monkeypatch: pytest.MonkeyPatch
) -> None:
    """Negative and disjunctive preconditions, quantifiers, conditional effects: the fallback joins
    only the positive fluent atoms, the rest is decided per ground action as usual."""
    nonempty = 0
    for seed in range(100):
        case = kind(seed)
        (tmp_path / "d.pddl").write_text(case.domain_text(), encoding="utf-8")
        (tmp_path / "p.pddl").write_text(case.problem_text(), encoding="utf-8")
        normal, reached = _both(tmp_path / "d.pddl", tmp_path / "p.pddl", monkeypatch)
        assert _actions(reached) == _actions(normal), f"seed={seed}\n{case.domain_text()}\n{case.problem_text()}"
        nonempty += bool(normal.actions)
    assert nonempty >= 50


GATED = """(define (domain gated)
  (:requirements :strips)
  (:predicates (at ?x) (open ?x) (done))
  (:action go :parameters (?a ?b) :precondition (and (at ?a) (open ?b)) :effect (and (at ?b) (not (at ?a))))
  (:action finish :parameters (?a) :precondition (and (at ?a) (open ?a)) :effect (done)))
"""


def _gated(tmp_path: Path, objects: int, opened: int) -> tuple[str, str]:
    """``go`` over every pair of objects statically, but only into the few objects that are open."""
    names = " ".join(f"o{i}" for i in range(objects))
    gates = " ".join(f"(open o{i})" for i in range(1, opened + 1))
    (tmp_path / "d.pddl").write_text(GATED, encoding="utf-8")
    (tmp_path / "p.pddl").write_text(
        f"(define (problem p) (:domain gated) (:objects {names}) (:init (at o0) {gates}) (:goal (done)))",
        encoding="utf-8",
    )
    return str(tmp_path / "d.pddl"), str(tmp_path / "p.pddl")


def test_a_task_over_the_static_bound_plans_through_the_fallback(
    tmp_path: Path, monkeypatch: pytest.MonkeyPatch, capsys: pytest.CaptureFixture[str]
) -> None:
    # Static bound: 60 x 60 go + 60 finish = 3,660. Reachable: from o0 into the 3 open objects and
    # between them (go(o1,o1) changes nothing), and finish in each: 3 + 6 + 3 actions.
    monkeypatch.setenv("HBTP_MAX_GROUND_ACTIONS", "100")
    domain, problem = _gated(tmp_path, 60, 3)
    tree = tmp_path / "tree.json"
    assert main(["plan", "--pddl", domain, problem, "-o", str(tree)]) == 0
    assert "solved: cost 2," in capsys.readouterr().out  # go into an open object, finish there
    assert json.loads(tree.read_text(encoding="utf-8"))
    assert main(["ground", "--pddl", domain, problem, "--names"]) == 0
    names = capsys.readouterr().out.split()
    assert len(names) == 12
    assert "go(o0,o1)" in names
    assert "go(o5,o1)" not in names  # o5 is never reached


def test_the_fallback_is_refused_past_the_limit_in_one_line(
    tmp_path: Path, monkeypatch: pytest.MonkeyPatch, capsys: pytest.CaptureFixture[str]
) -> None:
    monkeypatch.setenv("HBTP_MAX_GROUND_ACTIONS", "10")
    domain, problem = _gated(tmp_path, 60, 3)
    tree = tmp_path / "tree.json"
    assert main(["plan", "--pddl", domain, problem, "-o", str(tree)]) == 2
    error = capsys.readouterr().err
    assert error.count("\n") == 1
    assert "reachable from s0 would create more than the limit of 10 " in error
    assert not tree.exists()


def test_the_fallbacks_work_is_bounded(tmp_path: Path, monkeypatch: pytest.MonkeyPatch, forced: None) -> None:
    monkeypatch.setattr(ground_reach, "REACH_WORK", 1)
    monkeypatch.setattr(ground_reach, "REACH_FLOOR", 1)
    domain_file, problem_file = _gated(tmp_path, 300, 200)
    domain = read_domain_file(domain_file)
    with pytest.raises(GroundingError, match="took more than 1 units of work per allowed action"):
        ground(domain, read_problem_file(problem_file, domain), max_ground_actions=100_000)
