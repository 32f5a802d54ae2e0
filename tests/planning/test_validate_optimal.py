"""OBTEA's D(T) against Fast Downward's optimal cost (the validate extra), and the command around it."""

from __future__ import annotations

import json
import sys
from collections.abc import Iterator
from pathlib import Path
from typing import Any

import pytest
from click.testing import CliRunner

from hbtp.cli import validate_command
from hbtp.cli.validate_command import validate_optimal
from hbtp.domains import Scenario, load_scenario, write_grounded
from hbtp.errors import BackendError, InputError
from hbtp.validation import (
    INSTALL_HINT,
    RunStatus,
    choose_engine,
    compare_optimal,
    decided,
    fast_downward_cost,
    run_fast_downward,
)
from hbtp.validation.fast_downward import _read_plan_file


@pytest.fixture
def fast_downward() -> None:
    """Skip unless the validate extra (unified-planning and Fast Downward) is installed."""
    pytest.importorskip("unified_planning")
    pytest.importorskip("up_fast_downward")


def _check_rows(rows: list[dict[str, Any]], expected: int) -> None:
    assert len(rows) == expected
    for row in rows:
        assert row["fd_status"] == "optimal", row
        assert row["match"], row
        assert row["obtea_unpruned_cost"] == row["fd_cost"] == row["obtea_cost"], row
        assert not row["mutexes_change_optimum"]
        assert row["fd_plan"]


# --------------------------------------------------------- real comparisons
@pytest.mark.validate
@pytest.mark.usefixtures("fast_downward")
@pytest.mark.parametrize("name", ["robowaiter", "virtualhome", "robothow-small"])
def test_obtea_matches_fast_downward_on_table2_records(name: str) -> None:
    _check_rows(compare_optimal(name, limit=5, time_limit=60, engine="driver"), 5)


@pytest.mark.validate
@pytest.mark.usefixtures("fast_downward")
def test_obtea_matches_fast_downward_on_robothow() -> None:
    rows = compare_optimal("robothow", "table2_robothow_50", limit=1, time_limit=120)
    _check_rows(rows, 1)
    assert rows[0]["fd_engine"] == "driver"  # auto: 7329 actions are too many for unified-planning's reader
    assert rows[0]["declared_mutexes"]


@pytest.mark.validate
@pytest.mark.usefixtures("fast_downward")
def test_unified_planning_route_reads_the_export_once_per_task(
    monkeypatch: pytest.MonkeyPatch, robothow_small: Scenario
) -> None:
    from unified_planning.io import PDDLReader

    parses: list[str] = []
    original = PDDLReader.parse_problem

    def counting(self: Any, domain: str, problem: str | None = None) -> Any:
        parses.append(domain)
        return original(self, domain, problem)

    monkeypatch.setattr(PDDLReader, "parse_problem", counting)
    robothow_small.task.tables().clear()  # the parsed problem is kept with the task: start without it
    assert choose_engine(robothow_small.task) == "unified-planning"
    rows = compare_optimal("robothow-small", limit=3, time_limit=60, engine="unified-planning")
    _check_rows(rows, 3)
    assert {row["fd_engine"] for row in rows} == {"unified-planning"}
    assert len(parses) == 1  # the later records reuse the parsed problem with a new goal


@pytest.mark.validate
@pytest.mark.usefixtures("fast_downward")
def test_keyword_predicate_and_shared_names_pass_through_unified_planning(robowaiter: Scenario) -> None:
    # RoboWaiter's predicate Exists is a PDDL keyword; its objects On/Off share a name with a predicate.
    task = robowaiter.task
    run = run_fast_downward(task, task.resolve_goal("Exists_Coffee"), engine="unified-planning")
    assert run.status is RunStatus.OPTIMAL, run.message
    assert run.plan == ("Make(Coffee)",)
    assert run.cost == task.action("Make_Coffee").cost


@pytest.mark.validate
@pytest.mark.usefixtures("fast_downward")
def test_fast_downward_proves_a_contradictory_goal_unsolvable(robothow_small: Scenario) -> None:
    task = robothow_small.task
    assert fast_downward_cost(task, task.resolve_goal("IsOpen_fridge & IsClose_fridge"), engine="driver") is None


@pytest.mark.validate
@pytest.mark.usefixtures("fast_downward")
def test_validate_optimal_command_writes_rows(tmp_path: Path) -> None:
    out = tmp_path / "rows.jsonl"
    args = ["-s", "robothow-small", "-n", "2", "--engine", "driver", "--out", str(out)]
    result = CliRunner().invoke(validate_optimal, args, standalone_mode=False)
    assert result.exception is None, result.output
    assert result.return_value == 0
    assert "robothow-small: 2 records, 2 matches, 0 mismatches" in result.output
    rows = [json.loads(line) for line in out.read_text(encoding="utf-8").splitlines()]
    assert [row["record"] for row in rows] == ["1", "2"]


# -------------------------------------------------- without Fast Downward
def test_missing_extra_raises_backend_error(monkeypatch: pytest.MonkeyPatch, robothow_small: Scenario) -> None:
    monkeypatch.setitem(sys.modules, "unified_planning", None)  # makes "import unified_planning" fail
    task = robothow_small.task
    with pytest.raises(BackendError, match=r"pip install -e '\.\[validate\]'"):
        fast_downward_cost(task, task.resolve_goal("IsOpen_fridge"))
    with pytest.raises(BackendError, match="validate extra"):
        compare_optimal("robothow-small", limit=1)
    assert "pip install -e '.[validate]'" in INSTALL_HINT


def test_plan_file_is_read_with_its_cost(tmp_path: Path) -> None:
    plan = tmp_path / "plan.txt"
    plan.write_text("(walk_apple)\n(rightgrab_apple)\n; cost = 12 (general cost)\n", encoding="utf-8")
    outcome = _read_plan_file(plan)
    assert outcome.status is RunStatus.OPTIMAL
    assert outcome.names == ("walk_apple", "rightgrab_apple")
    assert outcome.reported_cost == 12


def test_a_row_is_decided_when_both_planners_answered() -> None:
    def row(obtea: str, fd: str) -> dict[str, str]:
        return {"obtea_unpruned_status": obtea, "fd_status": fd}

    assert decided(row("solved", "optimal"))
    assert decided(row("unsolvable", "unsolvable"))
    assert not decided(row("timeout", "optimal"))
    assert not decided(row("solved", "timeout"))
    assert not decided(row("solved", "error"))
    assert [s.decided for s in RunStatus] == [True, True, False, False]


def test_engine_choice(robothow_small: Scenario) -> None:
    assert choose_engine(load_scenario("robothow").task) == "driver"
    assert choose_engine(robothow_small.task, "driver") == "driver"
    with pytest.raises(InputError, match="unknown engine"):
        choose_engine(robothow_small.task, "pyperplan")  # type: ignore[arg-type]


def test_grounded_export_can_rename_keyword_predicates(robowaiter: Scenario) -> None:
    task = robowaiter.task
    goal = task.resolve_goal("Exists_Coffee")
    plain_domain, plain_problem = write_grounded(task, goal, rename_keywords=False)
    domain, problem = write_grounded(task, goal)  # renaming is the default: Fast Downward reads it
    assert "(Exists ?a0)" in plain_domain
    assert "(Exists Coffee)" in plain_problem
    assert "(Exists_ ?a0)" in domain
    assert "(:goal (and (Exists_ Coffee)))" in problem
    assert "(Exists " not in domain + problem
    assert domain.replace("(Exists_ ", "(Exists ") == plain_domain


def _rows(*matches: bool) -> Iterator[dict[str, Any]]:
    for index, match in enumerate(matches, start=1):
        yield {
            "scenario": "robowaiter",
            "record": str(index),
            "goal": "Exists_Coffee",
            "obtea_cost": 5,
            "obtea_status": "solved",
            "obtea_time_s": 0.001,
            "obtea_unpruned_cost": 5,
            "obtea_unpruned_status": "solved",
            "obtea_unpruned_time_s": 0.001,
            "fd_cost": 5 if match else 6,
            "fd_status": "optimal",
            "fd_time_s": 0.5,
            "fd_engine": "driver",
            "fd_plan": ["Make(Coffee)"],
            "match": match,
            "declared_mutexes": False,
            "mutexes_change_optimum": False,
        }


def test_command_exits_1_on_a_mismatch(monkeypatch: pytest.MonkeyPatch) -> None:
    monkeypatch.setattr(validate_command, "iter_comparisons", lambda *args, **kwargs: _rows(True, False))
    result = CliRunner().invoke(validate_optimal, ["-s", "robowaiter", "--json"], standalone_mode=False)
    assert result.exception is None, result.output
    assert result.return_value == 1
    summary = json.loads(result.output)["summary"]
    assert (summary["records"], summary["matches"], summary["mismatches"]) == (2, 1, 1)


def test_dataset_goes_with_one_scenario() -> None:
    result = CliRunner().invoke(
        validate_optimal, ["-s", "robowaiter", "-s", "virtualhome", "--dataset", "x"], standalone_mode=False
    )
    assert isinstance(result.exception, InputError)


IPC = Path(__file__).resolve().parents[3] / "shared" / "benchmarks" / "ipc"


def _smallest(domain: str) -> tuple[str, str]:
    problems = sorted(p for p in (IPC / domain).glob("*.pddl") if "domain" not in p.name)
    return str(IPC / domain / "domain.pddl"), str(problems[0])


@pytest.mark.validate
@pytest.mark.usefixtures("fast_downward")
def test_validate_optimal_on_pddl_files_uses_fast_downwards_own_translator(tmp_path: Path) -> None:
    if not IPC.is_dir():
        pytest.skip(f"no IPC benchmarks at {IPC}")
    argv = ["--json", "-t", "60"]
    for domain in ("gripper", "blocks"):
        argv += ["--pddl", *_smallest(domain)]
    result = CliRunner().invoke(validate_optimal, argv, standalone_mode=False)
    assert result.exception is None, result.output
    assert result.return_value == 0
    document = json.loads(result.output)
    assert document["summary"] == {"instances": 2, "mismatches": 0, "undecided": 0}
    for row in document["rows"]:
        assert row["match"], row
        assert row["tree_verified"], row
        assert row["obtea_cost"] == row["fd_cost"] is not None
        assert row["fd_operators"] > 0
        assert row["ground_ratio"] == round(row["grounded_actions"] / row["fd_operators"], 3)
        assert row["grounded_actions"] <= row["reachable_actions"]
        assert row["ground_ratio"] <= 1.5, row


def test_pddl_files_go_without_scenarios(tmp_path: Path) -> None:
    (tmp_path / "d.pddl").write_text("(define (domain d))", encoding="utf-8")
    (tmp_path / "p.pddl").write_text("(define (problem p) (:domain d))", encoding="utf-8")
    argv = ["-s", "robowaiter", "--pddl", str(tmp_path / "d.pddl"), str(tmp_path / "p.pddl")]
    result = CliRunner().invoke(validate_optimal, argv, standalone_mode=False)
    assert isinstance(result.exception, InputError)
    assert "without --scenario" in str(result.exception)


def test_a_file_row_that_fast_downward_did_not_decide_reads_undecided_not_mismatch() -> None:
    from hbtp.cli.validate_command import _file_line

    row = {
        "instance": "p01.pddl", "obtea_cost": 12, "obtea_status": "solved", "obtea_time_s": 6.9,
        "tree_verified": True, "fd_cost": None, "fd_status": "timeout", "fd_time_s": 59.3,
        "grounded_actions": 241, "reachable_actions": 241, "fd_operators": 241, "ground_ratio": 1.0,
        "reachable_ratio": 1.0, "match": False, "decided": False,
    }  # fmt: skip
    assert "  undecided  " in _file_line(row)
    assert "  MISMATCH  " in _file_line({**row, "fd_cost": 11, "fd_status": "optimal", "decided": True})
    assert "  match  " in _file_line({**row, "fd_cost": 12, "fd_status": "optimal", "decided": True, "match": True})
