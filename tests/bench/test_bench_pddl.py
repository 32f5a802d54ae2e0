"""``hbtp bench pddl DIR`` in process: discovery of domains and instances, verified trees, reference
costs with a deliberately wrong one flagged, resuming, and a one-line error for a bad folder."""

from __future__ import annotations

import json
from pathlib import Path
from typing import Any

import pytest

from hbtp import compiled
from hbtp.bench.pddl_suite import discover, mismatch
from hbtp.cli import EXIT_INPUT, EXIT_OK, main

INLINE = ["--executor", "inline", "--no-progress"]

SWITCH_DOMAIN = """(define (domain switch)
  (:requirements :strips :typing)
  (:types lamp)
  (:predicates (on ?l - lamp) (off ?l - lamp))
  (:action turn-on :parameters (?l - lamp) :precondition (off ?l) :effect (and (on ?l) (not (off ?l)))))
"""

MOVE_DOMAIN = """(define (domain move)
  (:requirements :strips :typing)
  (:types room)
  (:predicates (at ?r - room) (door ?a - room ?b - room))
  (:action go :parameters (?a - room ?b - room)
    :precondition (and (at ?a) (door ?a ?b)) :effect (and (at ?b) (not (at ?a)))))
"""


def _switch_problem(name: str, lamps: int) -> str:
    objects = " ".join(f"l{i}" for i in range(lamps))
    init = " ".join(f"(off l{i})" for i in range(lamps))
    goal = " ".join(f"(on l{i})" for i in range(lamps))
    return f"(define (problem {name}) (:domain switch) (:objects {objects} - lamp) (:init {init}) (:goal (and {goal})))"


def _move_problem(name: str, rooms: int) -> str:
    objects = " ".join(f"r{i}" for i in range(rooms))
    doors = " ".join(f"(door r{i} r{i + 1})" for i in range(rooms - 1))
    return (
        f"(define (problem {name}) (:domain move) (:objects {objects} - room) (:init (at r0) {doors}) "
        f"(:goal (at r{rooms - 1})))"
    )


@pytest.fixture
def suite(tmp_path: Path) -> Path:
    """Two domains, two instances each; a reference file with one wrong entry (move/m2 is 2, not 3)."""
    root = tmp_path / "benchmarks"
    for domain, text, problems in (
        ("switch", SWITCH_DOMAIN, {"s1": _switch_problem("s1", 1), "s2": _switch_problem("s2", 2)}),
        ("move", MOVE_DOMAIN, {"m1": _move_problem("m1", 2), "m2": _move_problem("m2", 3)}),
    ):
        (root / domain).mkdir(parents=True)
        (root / domain / "domain.pddl").write_text(text, encoding="utf-8")
        for name, problem in problems.items():
            (root / domain / f"{name}.pddl").write_text(problem, encoding="utf-8")
    references = {"switch": {"s1": 1, "s2": 2}, "move": {"m1": 1, "m2": 3}}
    (root / "fd_optimal_costs.json").write_text(json.dumps(references), encoding="utf-8")
    return root


def rows(path: Path) -> list[dict[str, Any]]:
    return [json.loads(line) for line in path.read_text(encoding="utf-8").splitlines() if line.strip()]


def test_discover_pairs_domains_and_problems(suite: Path, tmp_path: Path) -> None:
    found = {(i.domain, i.name) for i in discover(suite)}
    assert found == {("switch", "s1"), ("switch", "s2"), ("move", "m1"), ("move", "m2")}
    paired = tmp_path / "paired" / "d"
    paired.mkdir(parents=True)
    (paired / "domain_p1.pddl").write_text(SWITCH_DOMAIN, encoding="utf-8")
    (paired / "p1.pddl").write_text(_switch_problem("p1", 1), encoding="utf-8")
    (instance,) = discover(paired.parent)
    assert instance.domain_file.name == "domain_p1.pddl"


def test_mismatch_rules() -> None:
    assert mismatch("obtea", 3.0, 2.0)
    assert mismatch("obtea", 1.0, 2.0)
    assert not mismatch("hbtp-s", 3.0, 2.0)
    assert mismatch("hbtp-s", 1.0, 2.0)
    assert not mismatch("obtea", None, 2.0)
    assert not mismatch("obtea", 2.0, None)


def test_pddl_runs_verifies_flags_the_wrong_reference_and_resumes(
    suite: Path, tmp_path: Path, capsys: pytest.CaptureFixture[str]
) -> None:
    out = tmp_path / "out"
    argv = ["bench", "pddl", str(suite), "--planners", "obtea,bte", "-t", "10", *INLINE, "-o", str(out)]
    assert main(argv) == EXIT_OK
    printed = capsys.readouterr().out
    results = rows(out / "results.jsonl")
    assert len(results) == 8
    assert all(r["solved"] and r["verified"] and r["actions"] > 0 and r["load_s"] >= 0 for r in results)
    obtea = {(r["domain"], r["instance"]): r["cost"] for r in results if r["planner"] == "obtea"}
    assert obtea == {("switch", "s1"): 1, ("switch", "s2"): 2, ("move", "m1"): 1, ("move", "m2"): 2}
    summary = json.loads((out / "summary.json").read_text(encoding="utf-8"))
    assert summary["planners"]["obtea"]["verified"] == 4
    assert summary["planners"]["obtea"]["by_domain"] == {"switch": 2, "move": 2}
    assert [(m["instance"], m["planner"]) for m in summary["mismatches"]] == [("m2", "obtea"), ("m2", "bte")]
    assert "MISMATCH move/m2 obtea" in printed
    report = (out / "report.md").read_text(encoding="utf-8")
    assert "2 MISMATCH(ES)" in report
    built = compiled.built()
    assert summary["config"]["c_extensions"] == built
    assert (
        f"every C extension built ({', '.join(sorted(built))})," if all(built.values()) else "(C extensions not built)"
    ) in report
    before = (out / "results.jsonl").read_text(encoding="utf-8")
    assert main(argv) == EXIT_OK  # resumed: nothing runs again
    assert (out / "results.jsonl").read_text(encoding="utf-8") == before


def _bench_one_switch_problem(tmp_path: Path, objects: str, init: str, goal: str) -> dict[str, Any]:
    """The row of OBTEA on one problem of the switch domain."""
    root = tmp_path / "bench" / "switch"
    root.mkdir(parents=True)
    (root / "domain.pddl").write_text(SWITCH_DOMAIN, encoding="utf-8")
    problem = f"(define (problem one) (:domain switch) (:objects {objects} - lamp) (:init {init}) (:goal {goal}))"
    (root / "one.pddl").write_text(problem, encoding="utf-8")
    out = tmp_path / "out"
    assert main(["bench", "pddl", str(root.parent), *INLINE, "-o", str(out)]) == EXIT_OK
    (row,) = rows(out / "results.jsonl")
    return row


def test_pddl_plans_a_goal_with_negative_literals(tmp_path: Path) -> None:
    """A :goal with (not ...) needs the negated twins, as `hbtp plan --pddl` gives them."""
    row = _bench_one_switch_problem(tmp_path, "l0 l1", "(off l0) (off l1)", "(and (on l0) (not (off l1)))")
    assert (row["status"], row["cost"], row["verified"]) == ("solved", 2, True)


def test_pddl_searches_the_actions_relevant_to_the_goal(tmp_path: Path) -> None:
    """Of three lamps the goal names one: the task searched has its one action, as Fast Downward's
    translator keeps, and the row says how many the whole reachable grounding has."""
    row = _bench_one_switch_problem(tmp_path, "l0 l1 l2", "(off l0) (off l1) (off l2)", "(on l1)")
    assert (row["status"], row["cost"], row["verified"]) == ("solved", 1, True)
    assert (row["actions"], row["reachable_actions"]) == (1, 3)


def test_pddl_bad_folder_is_a_one_line_error(tmp_path: Path, capsys: pytest.CaptureFixture[str]) -> None:
    for folder in (tmp_path / "missing", tmp_path):
        assert main(["bench", "pddl", str(folder), *INLINE, "-o", str(tmp_path / "out")]) == EXIT_INPUT
        error = capsys.readouterr().err.strip()
        assert error.count("\n") == 0
        assert str(folder) in error


@pytest.mark.validate
def test_pddl_validate_runs_fast_downward_where_no_reference(tmp_path: Path) -> None:
    pytest.importorskip("up_fast_downward")
    root = tmp_path / "bench" / "switch"
    root.mkdir(parents=True)
    (root / "domain.pddl").write_text(SWITCH_DOMAIN, encoding="utf-8")
    (root / "s2.pddl").write_text(_switch_problem("s2", 2), encoding="utf-8")
    out = tmp_path / "out"
    assert main(["bench", "pddl", str(root.parent), "--validate", *INLINE, "-o", str(out)]) == EXIT_OK
    ours, fd = rows(out / "results.jsonl")
    assert (ours["planner"], fd["planner"]) == ("obtea", "fast-downward")
    assert ours["cost"] == fd["cost"] == 2
    assert fd["actions"] > 0  # the translator's operators
    summary = json.loads((out / "summary.json").read_text(encoding="utf-8"))
    assert summary["planners"]["fast-downward"]["verified"] == 1
    assert summary["compared"] == 1
    assert summary["mismatches"] == []
    assert summary["grounding"]["instances"] == 1
    assert summary["grounding"]["max_ratio"] == ours["actions"] / fd["actions"]
    report = (out / "report.md").read_text(encoding="utf-8")
    assert "Fast Downward (A* + LM-cut)" in report
    assert "the grounding other goals share) at most 1.00x" in report


IPC = Path(__file__).resolve().parents[3] / "shared" / "benchmarks" / "ipc"


@pytest.mark.validate
@pytest.mark.skipif(not IPC.is_dir(), reason="the IPC benchmark files (../shared/benchmarks/ipc) are absent")
def test_pddl_on_the_first_instance_of_every_shipped_ipc_domain(tmp_path: Path) -> None:
    """The documented CI subset of ``hbtp bench pddl ../shared/benchmarks/ipc --validate``: the first
    instance (by name) of each of the 16 domains, 10 s per run, OBTEA with seq (the default) beside Fast Downward.
    Coverage depends on the machine's load; costs, mismatches and tree checks do not."""
    pytest.importorskip("up_fast_downward")
    root = tmp_path / "ipc"
    for domain in sorted(p for p in IPC.iterdir() if p.is_dir()):
        first = sorted(p for p in domain.glob("*.pddl") if "domain" not in p.stem.lower())[0]
        (root / domain.name).mkdir(parents=True)
        for source in (domain / "domain.pddl", first):
            (root / domain.name / source.name).symlink_to(source)
    (root / "fd_optimal_costs.json").symlink_to(IPC / "fd_optimal_costs.json")
    out = tmp_path / "out"
    argv = ["bench", "pddl", str(root), "--validate", "-t", "10", "--jobs", "2", "--no-progress", "-o", str(out)]
    assert main(argv) == EXIT_OK
    results = rows(out / "results.jsonl")
    assert len(results) == 2 * 16
    ours = {r["domain"]: r for r in results if r["planner"] == "obtea"}
    assert {r["heuristic"] for r in ours.values()} == {"seq"}
    assert all(r["verified"] for r in ours.values() if r["solved"])
    assert {r["status"] for r in ours.values()} <= {"solved", "timeout"}  # every domain loads
    summary = json.loads((out / "summary.json").read_text(encoding="utf-8"))
    assert summary["mismatches"] == []
    assert summary["compared"] >= 10
    assert summary["grounding"]["instances"] == 16
    assert summary["grounding"]["above_target"] == []  # ground actions for the goal within 1.5x of FD's
