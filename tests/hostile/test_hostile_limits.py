"""Limits that must hold under hostile input (issue: hostile input, part B): deep nesting, the time
limit of the whole command, names that must read back, sizes, the runtime's bounds, and errors that
stay on one line. Every case is bounded in time and memory, and touches no device file."""

from __future__ import annotations

import json
import math
import time
from collections.abc import Iterable
from pathlib import Path

import pytest
from hypothesis import HealthCheck, given, settings
from hypothesis import strategies as st

from hbtp.bt.jsonio import json_document
from hbtp.cli import EXIT_INPUT, EXIT_NOT_SOLVED, EXIT_OK, main
from hbtp.domains import Scenario
from hbtp.errors import InputError
from hbtp.logic.goals import MAX_DEPTH, parse_goal
from hbtp.runtime import Runtime, RuntimeFailure
from helpers import cli as run
from helpers import one_error_line

GRIPPER_DOMAIN = """\
(define (domain gripper-strips)
  (:predicates (room ?r) (ball ?b) (gripper ?g) (at-robby ?r) (at ?b ?r) (free ?g) (carry ?o ?g))
  (:action move :parameters (?from ?to)
    :precondition (and (room ?from) (room ?to) (at-robby ?from))
    :effect (and (at-robby ?to) (not (at-robby ?from))))
  (:action pick :parameters (?obj ?room ?gripper)
    :precondition (and (ball ?obj) (room ?room) (gripper ?gripper) (at ?obj ?room) (at-robby ?room) (free ?gripper))
    :effect (and (carry ?obj ?gripper) (not (at ?obj ?room)) (not (free ?gripper))))
  (:action drop :parameters (?obj ?room ?gripper)
    :precondition (and (ball ?obj) (room ?room) (gripper ?gripper) (carry ?obj ?gripper) (at-robby ?room))
    :effect (and (at ?obj ?room) (free ?gripper) (not (carry ?obj ?gripper)))))
"""


# ----------------------------------------------------------------------------- 4. deep nesting
@pytest.mark.parametrize(
    "goal",
    [
        "(" * 400 + "On_Coffee_Table1" + ")" * 400,
        "~(" * 3000 + "On_Coffee_Table1" + ")" * 3000,
        "(and " * 400 + "(On Coffee Table1)" + ")" * 400,
    ],
    ids=["parentheses", "not-parentheses", "pddl"],
)
def test_a_goal_nested_too_deep_is_one_line_exit_2(goal: str, capsys: pytest.CaptureFixture[str]) -> None:
    code, _, err = run(capsys, "plan", "-s", "robowaiter", "-g", goal)
    assert code == EXIT_INPUT
    assert f"nested more than {MAX_DEPTH} deep" in one_error_line(err)
    assert "RecursionError" not in err


def test_a_long_run_of_negations_is_read_without_recursion() -> None:
    assert parse_goal("~" * 1000 + "A") == parse_goal("A")
    assert parse_goal("~" * 1001 + "A") == parse_goal("~A")


def test_nesting_up_to_the_limit_is_read() -> None:
    depth = MAX_DEPTH - 1
    assert parse_goal("(" * depth + "A & B" + ")" * depth) == parse_goal("A & B")


# ----------------------------------------------------------------------------- 5. -t bounds everything
def test_a_long_conjunction_is_read_in_linear_time_within_the_time_limit(
    tmp_path: Path, capsys: pytest.CaptureFixture[str]
) -> None:
    # 60,000 copies of one literal (just under the goal's 1 MiB cap): this took minutes when each
    # conjunct was joined to a growing tuple.
    goal = tmp_path / "goal.txt"
    goal.write_text(" & ".join(["On_Coffee_Table1"] * 55_000), encoding="utf-8")
    started = time.perf_counter()
    code, out, err = run(capsys, "plan", "-s", "robowaiter", "-g", f"@{goal}", "-t", "5")
    assert time.perf_counter() - started < 5 + 2
    assert code == EXIT_OK, err
    assert "solved" in out


def _gripper(folder: Path, balls: int) -> tuple[str, str]:
    domain, problem = folder / "domain.pddl", folder / "problem.pddl"
    domain.write_text(GRIPPER_DOMAIN, encoding="utf-8")
    names = " ".join(f"ball{i}" for i in range(balls))
    init = " ".join(f"(ball ball{i}) (at ball{i} rooma)" for i in range(balls))
    problem.write_text(
        f"(define (problem big) (:domain gripper-strips) (:objects rooma roomb left right {names})"
        f" (:init (room rooma) (room roomb) (gripper left) (gripper right) (at-robby rooma) (free left) (free right)"
        f" {init}) (:goal (at ball0 roomb)))",
        encoding="utf-8",
    )
    return str(domain), str(problem)


@pytest.mark.parametrize("command", ["ground", "plan"])
def test_the_time_limit_bounds_grounding_in_ground_and_plan(
    command: str, tmp_path: Path, capsys: pytest.CaptureFixture[str]
) -> None:
    domain, problem = _gripper(tmp_path, 20_000)
    started = time.perf_counter()
    code, _, err = run(capsys, command, "--pddl", domain, problem, "-t", "0.5")
    assert time.perf_counter() - started < 0.5 + 1.5
    assert code == EXIT_NOT_SOLVED
    assert one_error_line(err).startswith("hbtp: error: time limit of 0.5 s reached while")


def test_ground_takes_the_time_limit_option(capsys: pytest.CaptureFixture[str]) -> None:
    code, out, _ = run(capsys, "ground", "--help")
    assert code == EXIT_OK
    assert "--time-limit" in out


# ----------------------------------------------------------------------------- 6. names read back
def test_a_name_that_would_not_read_back_is_refused_at_load(tmp_path: Path, capsys: pytest.CaptureFixture[str]) -> None:
    domain, problem = _gripper(tmp_path, 1)
    text = Path(problem).read_text(encoding="utf-8").replace("ball0", "</script><img/src=x/onerror=alert`1`>")
    Path(problem).write_text(text, encoding="utf-8")
    code, _, err = run(capsys, "plan", "--pddl", domain, problem, "-o", str(tmp_path / "tree.json"))
    assert code == EXIT_INPUT
    line = one_error_line(err)
    assert line.startswith(f"hbtp: error: {problem}:1:")  # file:line:column
    assert "is not a PDDL name" in line
    assert not (tmp_path / "tree.json").exists()


NAMES = st.from_regex(r"[A-Za-z][A-Za-z0-9_\-]{0,12}", fullmatch=True).filter(
    lambda name: name.lower() not in {"either", "object", "and", "or", "not", "imply", "exists", "forall", "when"}
)


@settings(max_examples=12, deadline=None, suppress_health_check=[HealthCheck.function_scoped_fixture])
@given(objects=st.lists(NAMES, min_size=2, max_size=2, unique_by=str.lower))
def test_whatever_name_hbtp_writes_it_reads_back(objects: list[str], tmp_path_factory: pytest.TempPathFactory) -> None:
    folder = tmp_path_factory.mktemp("names")
    (folder / "domain.pddl").write_text(
        "(define (domain d) (:requirements :strips :typing) (:types thing)"
        " (:predicates (at ?x - thing) (free))"
        " (:action take-it :parameters (?x - thing) :precondition (free) :effect (at ?x)))",
        encoding="utf-8",
    )
    (folder / "problem.pddl").write_text(
        f"(define (problem p) (:domain d) (:objects {' '.join(objects)} - thing) (:init (free))"
        f" (:goal (and (at {objects[0]}) (at {objects[1]}))))",
        encoding="utf-8",
    )
    pddl = [str(folder / "domain.pddl"), str(folder / "problem.pddl")]
    tree, xml = str(folder / "tree.json"), str(folder / "tree.xml")
    assert main(["plan", "--pddl", *pddl, "-o", tree, "--export", xml]) == EXIT_OK
    for written in (tree, xml):
        assert main(["verify", written, "--pddl", *pddl]) == EXIT_OK
        assert main(["run", written, "--pddl", *pddl]) == EXIT_OK
    assert main(["view", tree, "-o", str(folder / "page.html")]) == EXIT_OK


# ----------------------------------------------------------------------------- 7. sizes and echoes
def _chain(nodes: int) -> dict[str, object]:
    leaf = {"type": "Condition", "literals": []}
    return {"type": "Sequence", "children": [leaf] * (nodes - 1)}


def test_a_json_tree_over_the_node_limit_is_refused(monkeypatch: pytest.MonkeyPatch) -> None:
    monkeypatch.setattr("hbtp.bt.jsonio.MAX_TREE_NODES", 1_000)  # the limit is 1,000,000: the same code path
    document = {"format": "hbtp-tree", "version": 1, "root": _chain(1_000)}
    assert json_document(json.dumps(document), "t.json")["root"]["type"] == "Sequence"
    document["root"] = _chain(1_001)
    with pytest.raises(InputError, match="more than 1,000 nodes"):
        json_document(json.dumps(document), "t.json")


def test_an_error_echoes_at_most_200_characters_of_a_long_name(capsys: pytest.CaptureFixture[str]) -> None:
    name = "A" * 500_000
    code, _, err = run(capsys, "plan", "-s", "robowaiter", "-g", f"{name}_Coffee")
    assert code == EXIT_INPUT
    line = one_error_line(err)
    assert len(line) < 2_500
    assert "A" * 201 not in line
    assert "characters)" in line


# ----------------------------------------------------------------------------- 8. runtime bounds
def _observe_after(seconds: float) -> Iterable[str]:
    time.sleep(seconds)
    return ["RobotNear(Bar)"]


def test_an_observer_that_hangs_is_timed_out(robowaiter: Scenario) -> None:
    runtime = Runtime(robowaiter, "On_Coffee_Table1", {}, lambda: _observe_after(3.0), tick_timeout_s=0.3)
    started = time.perf_counter()
    with pytest.raises(RuntimeFailure, match=r"the state observer did not return within 0\.3 s"):
        runtime.run()
    assert time.perf_counter() - started < 2.0


@pytest.mark.parametrize("timeout", [math.nan, -1.0, 0.0, math.inf, "10"])
def test_the_tick_timeout_must_be_positive_and_finite(timeout: object, robowaiter: Scenario) -> None:
    with pytest.raises(InputError, match="tick_timeout_s must be a positive, finite number"):
        Runtime(robowaiter, "On_Coffee_Table1", {}, list, tick_timeout_s=timeout)  # type: ignore[arg-type]


@pytest.mark.parametrize("failures", [0, -3, 1.5, True])
def test_max_failures_must_be_at_least_one(failures: object, robowaiter: Scenario) -> None:
    with pytest.raises(InputError, match="max_failures must be a whole number of at least 1"):
        Runtime(robowaiter, "On_Coffee_Table1", {}, list, max_failures=failures)  # type: ignore[arg-type]


@pytest.mark.parametrize("ticks", [0, -1])
def test_max_ticks_must_be_at_least_one(ticks: int, robowaiter: Scenario) -> None:
    with pytest.raises(InputError, match="max_ticks must be a whole number of at least 1"):
        Runtime(robowaiter, "On_Coffee_Table1", {}, list).run(max_ticks=ticks)


class _Treacherous(str):
    def strip(self, chars: str | None = None) -> str:
        raise RuntimeError("strip")

    def __repr__(self) -> str:
        raise RuntimeError("repr")


class _Unprintable:
    def __str__(self) -> str:
        raise RuntimeError("str")


def test_answers_that_raise_when_read_are_failures_not_escapes(robowaiter: Scenario) -> None:
    state = {"RobotNear(Bar)"}
    calls: list[str] = []

    def move(place: str) -> str:
        calls.append(place)
        return _Treacherous("success")  # strip() and repr() raise: read as the text it holds

    runtime = Runtime(robowaiter, "RobotNear_Table1", {"MoveTo": move}, lambda: sorted(state), max_failures=1)
    report = runtime.run(max_ticks=3)
    assert calls  # called, and its answer read as success (the world never changed, so it is called again)
    garbage = Runtime(robowaiter, "RobotNear_Table1", {"MoveTo": lambda _: _Treacherous("nonsense")}, list)
    assert garbage.run(max_ticks=2).failures >= 1
    unreadable = Runtime(robowaiter, "RobotNear_Table1", {}, lambda: [_Unprintable()])
    with pytest.raises(RuntimeFailure, match="the state observer failed: RuntimeError"):
        unreadable.run()
    assert report.ticks == 3


# ----------------------------------------------------------------------------- 9. one line
@pytest.mark.parametrize(
    "argv",
    [
        ["plan", "-s", "robowaiter", "-g", "On_Coffee_Table1", "-t", "abc"],
        ["plan", "-s", "robowaiter", "-g", "On_Coffee_Table1", "-t", "0"],
        ["plan", "-s", "robowaiter", "-g", "On_Coffee_Table1", "-t", "nan"],
        ["run", "{tree}", "--replan", "-1"],
        ["run", "{tree}", "--perturb", "2"],
        ["run", "{tree}", "--perturb", "0.1", "--runs", "0"],
        ["run", "{tree}", "--max-ticks", "0"],
        ["plan", "--pddl", "{folder}", "{folder}", "-g", "x"],
    ],
)
def test_usage_errors_are_one_line(argv: list[str], tmp_path: Path, capsys: pytest.CaptureFixture[str]) -> None:
    tree = tmp_path / "tree.json"
    assert main(["plan", "-s", "robowaiter", "-g", "On_Coffee_Table1", "-o", str(tree)]) == EXIT_OK
    capsys.readouterr()
    code, _, err = run(capsys, *[item.format(tree=tree, folder=tmp_path) for item in argv])
    assert code in (EXIT_INPUT, EXIT_NOT_SOLVED)
    one_error_line(err)


def test_a_warning_before_an_error_is_held_and_counted(tmp_path: Path, capsys: pytest.CaptureFixture[str]) -> None:
    tree = tmp_path / "tree.json"
    assert main(["plan", "-s", "robothow-small", "-g", "IsIn_apple_fridge", "-o", str(tree)]) == EXIT_OK
    capsys.readouterr()
    code, _, err = run(capsys, "export", str(tree), "-s", "robowaiter", "-f", "text")  # warns, then fails
    assert code == EXIT_INPUT
    assert one_error_line(err).endswith("(1 warning before it: -v shows it)")
    code, _, err = run(capsys, "-v", "export", str(tree), "-s", "robowaiter", "-f", "text")
    assert "was written for scenario 'robothow-small'" in err.splitlines()[0]


@pytest.mark.parametrize(
    ("domain", "where", "message"),
    [
        ("(define (domain t)\n (:types a - b b - a)\n (:predicates (p ?x - a)))", ":2:", "its own ancestor"),
        ("", ":1:1:", "the file is empty"),
        ("; nothing\n", ":1:1:", "holds only comments"),
        ("(define (domain t)\n  (:predicates (p\0)))", ":2:18:", "a NUL byte"),
        (b"(define (domain t)\n  (:predicates (p\xff)))", ":2:18:", "not UTF-8 text (byte 36)"),
        (
            "(define (domain q) (:requirements :adl) (:predicates (p ?a ?b ?c ?d) (r))\n"
            " (:action big :parameters () :precondition (forall (?a ?b ?c ?d) (p ?a ?b ?c ?d)) :effect (r)))",
            ":2:2:",
            "more than 200,000 literals",
        ),
    ],
    ids=["cyclic-types", "empty", "comments", "nul", "utf8", "quantifiers"],
)
def test_pddl_errors_name_file_line_and_column(
    domain: str | bytes, where: str, message: str, tmp_path: Path, capsys: pytest.CaptureFixture[str]
) -> None:
    path = tmp_path / "domain.pddl"
    if isinstance(domain, bytes):
        path.write_bytes(domain)
    else:
        path.write_text(domain, encoding="utf-8")
    objects = " ".join(f"o{i}" for i in range(30))
    problem = tmp_path / "problem.pddl"
    problem.write_text(f"(define (problem p) (:domain q) (:objects {objects}) (:init) (:goal (r)))", encoding="utf-8")
    code, _, err = run(capsys, "ground", "--pddl", str(path), str(problem))
    assert code == EXIT_INPUT
    line = one_error_line(err)
    assert line.startswith(f"hbtp: error: {path}{where}"), line
    assert message in line


def test_a_trace_with_a_replan_tick_that_is_not_a_number_is_refused(
    tmp_path: Path, capsys: pytest.CaptureFixture[str]
) -> None:
    tree, trace = tmp_path / "tree.json", tmp_path / "trace.jsonl"
    assert main(["plan", "-s", "robowaiter", "-g", "On_Coffee_Table1", "-o", str(tree)]) == EXIT_OK
    assert main(["run", str(tree), "--trace", str(trace)]) == EXIT_OK
    lines = trace.read_text(encoding="utf-8").splitlines()
    lines.insert(1, json.dumps({"run": 0, "replan": {"tick": "abc", "reason": "x"}}))
    trace.write_text("\n".join(lines) + "\n", encoding="utf-8")
    capsys.readouterr()
    code, _, err = run(capsys, "view", str(tree), "--trace", str(trace), "-o", str(tmp_path / "page.html"))
    assert code == EXIT_INPUT
    assert "replan.tick must be a whole number" in one_error_line(err)
