"""Bounds of ``hbtp plan --pddl``: grounding size, one time limit for the whole command, and bad
numbers, nesting or encodings in PDDL files, each a one-line error with the right exit code."""

from __future__ import annotations

import time
from pathlib import Path

import pytest

from hbtp.cli import EXIT_INPUT, EXIT_NOT_SOLVED, EXIT_OK, main
from hbtp.domains import load_scenario

CUBE = """\
(define (domain cube)
  (:requirements :strips)
  (:predicates (p ?x ?y ?z) (q))
  (:action a :parameters (?x ?y ?z) :precondition (q) :effect (p ?x ?y ?z)))
"""
SMALL = """\
(define (domain small)
  (:requirements :strips :action-costs)
  (:predicates (p) (q))
  (:functions (total-cost) - number)
  (:action a :parameters () :precondition %s :effect (and (p) (increase (total-cost) %s))))
"""
SMALL_PROBLEM = "(define (problem one) (:domain small) (:init (q)) (:goal (p)))\n"


def run(capsys: pytest.CaptureFixture[str], *argv: str) -> tuple[int, str, str]:
    code = main(list(argv))
    captured = capsys.readouterr()
    return code, captured.out, captured.err


def _cube(tmp_path: Path, objects: int) -> tuple[str, str]:
    domain, problem = tmp_path / "domain.pddl", tmp_path / "problem.pddl"
    domain.write_text(CUBE, encoding="utf-8")
    names = " ".join(f"o{i}" for i in range(objects))
    problem.write_text(f"(define (problem p) (:domain cube) (:objects {names}) (:init (q)) (:goal (p o1 o2 o3)))")
    return str(domain), str(problem)


def _small(tmp_path: Path, precondition: str = "(q)", cost: str = "1", prefix: bytes = b"") -> tuple[str, str]:
    domain, problem = tmp_path / "domain.pddl", tmp_path / "problem.pddl"
    domain.write_bytes(prefix + (SMALL % (precondition, cost)).encode())
    problem.write_text(SMALL_PROBLEM, encoding="utf-8")
    return str(domain), str(problem)


def test_a_grounding_too_large_is_refused_naming_the_limit(capsys: pytest.CaptureFixture[str], tmp_path: Path) -> None:
    # 8 million ground actions, all reachable from s0: this ran 56 s into a MemoryError (exit 3).
    # The static bound is too large, so only the reachable actions are grounded, up to the limit.
    code, out, err = run(capsys, "plan", "--pddl", *_cube(tmp_path, 200), "-g", "p(o1,o2,o3)")
    assert code == EXIT_INPUT
    assert out == ""
    assert err.count("\n") == 1
    assert err.startswith(
        "hbtp: error: grounding the actions reachable from s0 would create more than the limit of 1,000,000"
    )
    assert "HBTP_MAX_GROUND_ACTIONS" in err


def test_the_time_limit_covers_grounding(
    capsys: pytest.CaptureFixture[str], tmp_path: Path, monkeypatch: pytest.MonkeyPatch
) -> None:
    monkeypatch.setenv("HBTP_MAX_GROUND_ACTIONS", "100000000")
    started = time.perf_counter()
    code, out, err = run(capsys, "plan", "--pddl", *_cube(tmp_path, 200), "-g", "p(o1,o2,o3)", "-t", "0.5")
    assert out == ""
    elapsed = time.perf_counter() - started
    assert code == EXIT_NOT_SOLVED
    assert err == "hbtp: error: time limit of 0.5 s reached while grounding\n"
    assert elapsed < 0.5 + 1.0


def test_the_time_limit_covers_loading_and_search_together(capsys: pytest.CaptureFixture[str]) -> None:
    robothow = load_scenario("robothow")  # its PDDL files, loaded again by the command (about 1 s)
    time_limit = 2.0
    started = time.perf_counter()
    code, out, err = run(
        capsys,
        "plan", "--pddl", str(robothow.domain_file), str(robothow.problem_file),
        "-g", "IsIn_cutlets_box & IsCut_cutlets", "-p", "obtea", "--heuristic", "none",
        "-t", str(time_limit), "--json",
    )  # fmt: skip
    elapsed = time.perf_counter() - started
    assert code == EXIT_NOT_SOLVED
    assert '"status": "timeout"' in out or "reached while" in err
    assert elapsed < time_limit + 0.75, f"the command took {elapsed:.2f} s with -t {time_limit}"


@pytest.mark.parametrize(
    ("precondition", "cost", "message"),
    [
        ("(and " * 500 + "(q)" + ")" * 500, "1", "parentheses nested deeper than 100 levels"),
        ("(q)", "9" * 400, "cost 999999999999... (400 digits) is too large (at most 1000000)"),
        ("(q)", "\u0663", "cost '\u0663' is not a whole number"),
        ("(q)", "1_0", "cost '1_0' is not a whole number"),
    ],
    ids=["nesting-500", "cost-400-digits", "arabic-indic-digit", "underscore"],
)
def test_bad_pddl_is_a_one_line_input_error(
    capsys: pytest.CaptureFixture[str], tmp_path: Path, precondition: str, cost: str, message: str
) -> None:
    code, out, err = run(capsys, "plan", "--pddl", *_small(tmp_path, precondition, cost), "-g", "p()")
    assert code == EXIT_INPUT
    assert out == ""
    assert err.count("\n") == 1
    assert err.startswith(f"hbtp: error: {tmp_path / 'domain.pddl'}:5:")
    assert message in err


def test_a_file_with_a_byte_order_mark_plans(capsys: pytest.CaptureFixture[str], tmp_path: Path) -> None:
    code, out, err = run(capsys, "plan", "--pddl", *_small(tmp_path, prefix=b"\xef\xbb\xbf"), "-g", "p()")
    assert code == EXIT_OK, err
    assert out.startswith("solved: cost 1,")
