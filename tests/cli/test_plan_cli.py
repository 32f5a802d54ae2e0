"""The ``hbtp`` command line, in process: ``main(argv)`` returns the exit code, output via capsys.

Exit codes: 0 solved, 1 not solved (or invalid dataset records), 2 bad input, 3 internal error.
"""

from __future__ import annotations

import io
import json
from fractions import Fraction
from pathlib import Path
from typing import Any

import pytest

from hbtp.bt import Fallback, Sequence, tree_of
from hbtp.bt.jsonio import tree_from_json, tree_to_json
from hbtp.cli import EXIT_INPUT, EXIT_NOT_SOLVED, EXIT_OK, main
from hbtp.datasets import load_dataset, write_text
from hbtp.domains import Scenario, load_scenario, scenario_names
from hbtp.errors import InputError
from hbtp.llm.parse import hints_from_record, parse_reply
from hbtp.logic.relevance import relevant_actions
from hbtp.planning import Hints, plan, pruned_action_space, resolve_hints
from hbtp.planning.oracle import oracle_hints
from helpers import run_tree

MILK = "IsIn_milk_fridge & IsClose_fridge"
PAPER_REPLY = """Here is my reasoning for the task.

Heuristic Path: Walk_milk, RightGrab_milk, Walk_fridge, PlugIn_fridge, Open_fridge, RightPutIn_milk_fridge, Close_fridge
Relevant Action Predicates: Walk, RightGrab, PlugIn, Open, RightPutIn, Close
Relevant Objects: milk, fridge
"""
NONSENSE_REPLY = """Heuristic Path: Teleport_milk_fridge, Walk_milk, Fly_fridge, RightGrab_milk, Shrink(fridge),
  Close_fridge
Relevant Action Predicates: Walk, RightGrab, Open, PlugIn, RightPutIn, Close, Levitate
Relevant Objects: milk, fridge, unicorn, moon
"""


def run(capsys: pytest.CaptureFixture[str], *argv: str) -> tuple[int, str, str]:
    code = main(list(argv))
    captured = capsys.readouterr()
    return code, captured.out, captured.err


def run_json(capsys: pytest.CaptureFixture[str], *argv: str) -> tuple[int, dict[str, Any]]:
    code, out, err = run(capsys, *argv, "--json")
    assert "Traceback" not in err
    return code, json.loads(out)


def one_line_error(err: str) -> str:
    lines = [line for line in err.splitlines() if line.strip()]
    assert len(lines) == 1, err
    assert "Traceback" not in err
    return lines[0]


# ------------------------------------------------------------------ plan: outcomes and exit codes
def test_solved_plan_prints_the_tree_and_exits_0(capsys: pytest.CaptureFixture[str], robowaiter: Scenario) -> None:
    code, out, err = run(
        capsys, "plan", "-s", "robowaiter", "-g", "On_Coffee_Table1", "-p", "obtea", "--heuristic", "none"
    )
    assert code == EXIT_OK, err
    expected = plan(robowaiter.task, "On_Coffee_Table1", "obtea", mutexes=robowaiter.mutexes, heuristic="none")
    lines = out.splitlines()
    assert lines[0].startswith(
        f"solved: cost {expected.cost}, a plan of {len(expected.executed)} actions; "
        f"explored {len(expected.expansions)} conditions"
    )
    assert lines[1] == "executes: " + " -> ".join(robowaiter.task.actions[i].name for i in expected.executed)
    assert lines[2] == "? Fallback"
    assert lines[3].endswith("[C] On(Coffee,Table1)")
    assert sum("[A] " in line for line in lines) == len(expected.expansions) - 1


def test_json_output_has_the_documented_keys(capsys: pytest.CaptureFixture[str], robowaiter: Scenario) -> None:
    code, record = run_json(
        capsys, "plan", "-s", "robowaiter", "-g", "On_Coffee_Table1", "-p", "hbtp-o", "--heuristic", "lm"
    )
    assert code == EXIT_OK
    assert {"status", "cost", "explored", "generated", "time_s", "action_space", "executed"} <= set(record)
    expected = plan(robowaiter.task, "On_Coffee_Table1", "hbtp-o", mutexes=robowaiter.mutexes, heuristic="lm")
    assert record["status"] == "solved"
    assert record["cost"] == expected.cost
    assert record["explored"] == expected.stats.explored == len(expected.expansions)
    assert record["generated"] == expected.stats.generated
    # a search without hints keeps the actions relevant to its goal (Scenario.for_goal)
    assert (
        record["action_space"] == len(relevant_actions(robowaiter.task, expected.goal)) < len(robowaiter.task.actions)
    )
    assert record["executed"] == [robowaiter.task.actions[i].name for i in expected.executed]
    assert isinstance(record["time_s"], float)
    assert record["time_s"] >= 0


def test_unknown_planner_is_a_usage_error(capsys: pytest.CaptureFixture[str]) -> None:
    code, out, err = run(capsys, "plan", "-s", "robowaiter", "-g", "On_Coffee_Table1", "-p", "astar")
    assert code == EXIT_INPUT
    assert "astar" in err
    assert "Traceback" not in err
    assert out == ""


@pytest.mark.parametrize("limit", ["0", "-1", "-0.5"])
def test_non_positive_time_limit_is_a_one_line_input_error(capsys: pytest.CaptureFixture[str], limit: str) -> None:
    code, out, err = run(capsys, "plan", "-s", "robowaiter", "-g", "On_Coffee_Table1", "--time-limit", limit)
    assert code == EXIT_INPUT
    assert out == ""
    line = one_line_error(err)
    assert line.startswith("hbtp: error: time limit must be a positive number")


def test_non_positive_expansion_limit_is_an_input_error(capsys: pytest.CaptureFixture[str]) -> None:
    code, _, err = run(capsys, "plan", "-s", "robowaiter", "-g", "On_Coffee_Table1", "--max-expansions", "0")
    assert code == EXIT_INPUT
    assert "expansion limit must be at least 1" in one_line_error(err)


def test_goal_with_mutually_exclusive_literals_is_not_solved(capsys: pytest.CaptureFixture[str]) -> None:
    code, out, err = run(capsys, "plan", "-s", "robothow", "-g", "IsOpen_fridge & IsClose_fridge")
    assert code == EXIT_NOT_SOLVED, err
    first = out.splitlines()[0]
    assert first.startswith("unsolvable:")
    assert "IsOpen(fridge)" in first
    assert "IsClose(fridge)" in first
    code, record = run_json(capsys, "plan", "-s", "robothow", "-g", "IsOpen_fridge & IsClose_fridge")
    assert code == EXIT_NOT_SOLVED
    assert record["status"] == "unsolvable"
    assert record["cost"] is None
    assert record["explored"] == 0
    assert "IsOpen(fridge)" in record["message"]
    assert "IsClose(fridge)" in record["message"]


def test_goal_literal_that_nothing_achieves_is_not_solved(
    capsys: pytest.CaptureFixture[str], robothow_small: Scenario
) -> None:
    # well formed (IsClose is a fluent, apple an object) but no action adds it and s0 lacks it
    assert [str(a) for a in robothow_small.task.resolve_goal("IsClose_apple").unreachable] == ["IsClose(apple)"]
    code, out, err = run(capsys, "plan", "-s", "robothow-small", "-g", "IsClose_apple & IsOpen_fridge")
    assert code == EXIT_NOT_SOLVED, err
    assert out.startswith("unsolvable:")
    assert "no action makes IsClose(apple) true" in out.splitlines()[0]


@pytest.mark.parametrize(
    ("goal", "needle"),
    [
        ("IsIn_milkk_fridge", "unknown object 'milkk'"),
        ("IsFlying_milk", "unknown predicate 'IsFlying'"),
        ("IsIn_milk", "takes 2 argument"),
        ("IsIn(milk,", "malformed"),
    ],
)
def test_malformed_or_unknown_goal_is_an_input_error(
    capsys: pytest.CaptureFixture[str], goal: str, needle: str
) -> None:
    code, out, err = run(capsys, "plan", "-s", "robothow", "-g", goal)
    assert code == EXIT_INPUT
    assert out == ""
    assert needle in one_line_error(err)


def test_goal_already_true_in_s0_costs_nothing(capsys: pytest.CaptureFixture[str]) -> None:
    code, out, _ = run(capsys, "plan", "-s", "robothow", "-g", "IsClose_fridge")
    assert code == EXIT_OK
    assert out.startswith("solved: cost 0, a plan of 0 actions; explored 1 condition ")
    assert "executes: (nothing)" in out
    code, record = run_json(capsys, "plan", "-s", "robothow", "-g", "IsClose_fridge", "-p", "obtea")
    assert code == EXIT_OK
    assert record["cost"] == 0
    assert record["executed"] == []
    assert record["explored"] == 1


def test_search_stopped_by_a_limit_exits_1(capsys: pytest.CaptureFixture[str]) -> None:
    code, record = run_json(
        capsys,
        "plan",
        "-s",
        "robothow",
        "-g",
        "IsIn_cutlets_box & IsCut_cutlets",
        "-p",
        "obtea",
        "--max-expansions",
        "5",
    )
    assert code == EXIT_NOT_SOLVED
    assert record["status"] == "node-limit"
    assert record["explored"] == 5
    assert record["tree"]["kind"] == "full"  # the partial tree is still reported


# ------------------------------------------------------------------ hints files
def expected_with(scenario: Scenario, goal: str, planner: str, hints: Hints) -> tuple[int, int | None]:
    """(size of the pruned space, D(T)) of the same run through the API (heuristic lm)."""
    task = scenario.task
    space = pruned_action_space(task, resolve_hints(task, hints))
    result = plan(task, goal, planner, hints=hints, space="pruned", mutexes=scenario.mutexes, heuristic="lm")
    return len(space), result.cost


def test_hints_from_a_dataset_record_file(
    capsys: pytest.CaptureFixture[str], tmp_path: Path, robothow: Scenario
) -> None:
    records = load_dataset("table1_robothow_100")
    record = next(r for r in records if r.goal.strip() == "IsIn_milk_fridge")
    single = tmp_path / "record.txt"
    single.write_text(write_text([record]), encoding="utf-8")
    hints = hints_from_record(record)
    space, cost = expected_with(robothow, "IsIn_milk_fridge", "hbtp-o", hints)
    code, result = run_json(
        capsys,
        "plan",
        "-s",
        "robothow",
        "-g",
        "IsIn_milk_fridge",
        "-p",
        "hbtp-o",
        "--heuristic",
        "lm",
        "--hints",
        str(single),
    )
    assert code == EXIT_OK
    assert result["hints"] == "file"
    assert result["action_space"] == space < len(robothow.task.actions)
    assert result["cost"] == cost == 56
    # in a file of many records, the one with the goal is used
    several = tmp_path / "records.txt"
    several.write_text(write_text(records[:10]), encoding="utf-8")
    code, result = run_json(capsys, "plan", "-s", "robothow", "-g", "IsIn_milk_fridge", "--hints", str(several))
    assert code == EXIT_OK
    assert result["action_space"] == space
    # ... and none matching is an input error
    code, _, err = run(capsys, "plan", "-s", "robothow", "-g", MILK, "--hints", str(several))
    assert code == EXIT_INPUT
    assert "none of its 10 records has the goal" in one_line_error(err)


def test_hints_from_a_raw_llm_reply_with_the_papers_headings(
    capsys: pytest.CaptureFixture[str], tmp_path: Path, robothow: Scenario
) -> None:
    reply = tmp_path / "reply.txt"
    reply.write_text(PAPER_REPLY, encoding="utf-8")
    parsed = parse_reply(PAPER_REPLY)
    assert parsed.complete
    space, cost = expected_with(robothow, MILK, "hbtp-s", parsed.hints)
    code, result = run_json(
        capsys, "plan", "-s", "robothow", "-g", MILK, "-p", "hbtp-s", "--heuristic", "lm", "--hints", str(reply)
    )
    assert code == EXIT_OK
    assert result["status"] == "solved"
    assert (
        result["action_space"] == space == 9
    )  # Walk x2, RightGrab, PlugIn, Open, RightPutIn, Close (+ milk/fridge variants)
    assert result["cost"] == cost
    assert result["executed"][-1] == "Close(fridge)"


def test_hints_naming_actions_that_do_not_exist_are_ignored(
    capsys: pytest.CaptureFixture[str], tmp_path: Path, robothow: Scenario
) -> None:
    reply = tmp_path / "reply.txt"
    reply.write_text(NONSENSE_REPLY, encoding="utf-8")
    resolved = resolve_hints(robothow.task, parse_reply(NONSENSE_REPLY).hints)
    assert len(resolved.path) == 3  # Walk(milk), RightGrab(milk), Close(fridge)
    assert len(resolved.unknown) >= 6
    for planner in ("hbtp-o", "hbtp-s", "obtea", "bte"):
        code, result = run_json(capsys, "plan", "-s", "robothow", "-g", MILK, "-p", planner, "--hints", str(reply))
        assert code == EXIT_OK, planner
        assert result["status"] == "solved"
        assert result["executed"][-1] == "Close(fridge)"


def test_hints_file_without_any_hints_is_an_input_error(capsys: pytest.CaptureFixture[str], tmp_path: Path) -> None:
    reply = tmp_path / "reply.txt"
    reply.write_text("I am sorry, I cannot help with that.\n", encoding="utf-8")
    code, _, err = run(capsys, "plan", "-s", "robothow", "-g", MILK, "--hints", str(reply))
    assert code == EXIT_INPUT
    assert "no hints found" in one_line_error(err)
    code, _, err = run(capsys, "plan", "-s", "robothow", "-g", MILK, "--hints", str(tmp_path / "missing.txt"))
    assert code == EXIT_INPUT
    assert "cannot read the hints file" in one_line_error(err)


# ------------------------------------------------------------------ tree files and determinism
def test_out_writes_a_json_tree_that_reads_back_to_the_same_tree(
    capsys: pytest.CaptureFixture[str], tmp_path: Path, robothow: Scenario
) -> None:
    reply = tmp_path / "reply.txt"
    reply.write_text(PAPER_REPLY, encoding="utf-8")
    out = tmp_path / "trees" / "tree.json"
    out.parent.mkdir()
    code, _, _ = run(
        capsys,
        "plan",
        "-s",
        "robothow",
        "-g",
        MILK,
        "-p",
        "hbtp-o",
        "--heuristic",
        "none",
        "--hints",
        str(reply),
        "--out",
        str(out),
    )
    assert code == EXIT_OK
    text = out.read_text(encoding="utf-8")
    root, meta = tree_from_json(text, robothow.task, str(out))
    assert meta["format"] == "hbtp-tree"
    assert meta["scenario"] == "robothow"
    assert meta["goal"] == [str(atom) for atom in robothow.task.resolve_goal(MILK).atoms]  # literals, P(a,b) form
    hints = parse_reply(PAPER_REPLY).hints
    result = plan(
        robothow.task, MILK, "hbtp-o", hints=hints, space="pruned", mutexes=robothow.mutexes, heuristic="none"
    )
    assert root == tree_of(result)
    assert tree_to_json(root, robothow.task, scenario="robothow", goal=MILK, hints=hints) == text
    assert meta["hints"]["predicates"] == list(hints.predicates)  # planned in their space: re-plans search it
    # the path-only tree
    path_out = tmp_path / "path.json"
    code, _, _ = run(
        capsys, "plan", "-s", "robothow", "-g", MILK, "--hints", str(reply), "--tree", "path", "-o", str(path_out)
    )
    assert code == EXIT_OK
    path_root, _ = tree_from_json(path_out.read_text(encoding="utf-8"), robothow.task)
    assert isinstance(path_root, Sequence | Fallback)
    assert len(path_root.children) == 8  # the goal and 7 steps


def test_planning_is_deterministic(capsys: pytest.CaptureFixture[str], tmp_path: Path) -> None:
    reply = tmp_path / "reply.txt"
    reply.write_text(NONSENSE_REPLY, encoding="utf-8")
    for planner in ("hbtp-s", "obtea"):
        outputs, trees = [], []
        for attempt in range(2):
            tree_file = tmp_path / f"{planner}-{attempt}.json"
            code, out, _ = run(
                capsys,
                "plan",
                "-s",
                "robothow",
                "-g",
                MILK,
                "-p",
                planner,
                "--hints",
                str(reply),
                "-o",
                str(tree_file),
                "--json",
            )
            assert code == EXIT_OK
            record = json.loads(out)
            del record["time_s"]
            outputs.append(record)
            trees.append(tree_file.read_bytes())
        assert outputs[0] == outputs[1]
        assert trees[0] == trees[1]
        assert len(trees[0]) > 1000


# ------------------------------------------------------------------ other commands
def test_scenarios_json_counts(capsys: pytest.CaptureFixture[str]) -> None:
    code, out, _ = run(capsys, "scenarios", "--json")
    assert code == EXIT_OK
    rows = {row["name"]: row for row in json.loads(out)}
    assert list(rows) == list(scenario_names())
    # The actions plans use, and the self-placements left out (the paper's counts are their sums).
    expected = {
        "robowaiter": (174, 0, 6, 31),
        "virtualhome": (478, 2, 11, 36),
        "robothow-small": (155, 0, 16, 17),
        "robothow": (7311, 18, 16, 126),
    }
    for name, figures in expected.items():
        row = rows[name]
        assert (row["actions"], row["left_out"], row["action_predicates"], row["objects"]) == figures, name
        assert rows[name] == load_scenario(name).summary()
    code, out, _ = run(capsys, "scenarios")
    assert code == EXIT_OK
    assert out.splitlines()[4].split()[:3] == ["robothow", "7311", "18"]


def test_ground_names_match_the_reference_action_list(capsys: pytest.CaptureFixture[str], data_dir: Path) -> None:
    code, out, _ = run(capsys, "ground", "-s", "robothow", "--names", "--keep-self-placements")
    assert code == EXIT_OK
    reference = (data_dir / "robothow_action_names.txt").read_text(encoding="utf-8").split()
    assert out.split() == reference
    assert len(reference) == 7329
    code, out, _ = run(capsys, "ground", "-s", "robothow", "--names")
    assert code == EXIT_OK
    planned = out.split()
    assert len(planned) == 7311
    assert set(reference) - set(planned) == {name for name in reference if "(" in name and _self_pair(name)}
    code, out, _ = run(capsys, "ground", "-s", "robothow")
    assert code == EXIT_OK
    assert "left_out           18 (self-placements such as LeftPut(boardgame,boardgame))" in out.splitlines()


def _self_pair(action: str) -> bool:
    """Whether the action name takes the same object twice: ``LeftPut(chair,chair)``."""
    args = action[action.index("(") + 1 : -1].split(",")
    return len(args) == 2 and args[0] == args[1]


def test_dataset_validate_reports_the_two_invalid_table1_records(capsys: pytest.CaptureFixture[str]) -> None:
    code, out, _ = run(capsys, "dataset", "validate", "table1_robothow_100")
    assert code == EXIT_NOT_SOLVED
    lines = out.splitlines()
    assert lines[-1] == "table1_robothow_100 vs robothow: 100 records, 2 invalid, 0 with warnings"
    flagged = {line.split(":")[0] for line in lines[:-1]}
    assert flagged == {"record 29", "record 99"}
    code, record = run_json(capsys, "dataset", "validate", "table1_robothow_100")
    assert code == EXIT_NOT_SOLVED
    assert record["invalid_ids"] == ["29", "99"]
    assert record["valid"] is False
    code, _, _ = run(capsys, "dataset", "validate", "table2_robowaiter_50")
    assert code == EXIT_OK


def test_export_pddl_writes_domain_and_problem(capsys: pytest.CaptureFixture[str], tmp_path: Path) -> None:
    out = tmp_path / "export"
    code, stdout, _ = run(capsys, "export-pddl", "-s", "robothow-small", "-g", "IsOpen_fridge", "-o", str(out))
    assert code == EXIT_OK
    assert sorted(p.name for p in out.iterdir()) == ["domain.pddl", "problem.pddl"]
    domain = (out / "domain.pddl").read_text(encoding="utf-8")
    problem = (out / "problem.pddl").read_text(encoding="utf-8")
    assert domain.lstrip().startswith("(define")
    assert "(:action" in domain
    assert problem.lstrip().startswith("(define")
    assert "(:goal" in problem
    assert "domain.pddl" in stdout
    assert "problem.pddl" in stdout


def test_export_pddl_with_an_unknown_goal_object_writes_nothing(
    capsys: pytest.CaptureFixture[str], tmp_path: Path
) -> None:
    out = tmp_path / "export"
    code, stdout, err = run(capsys, "export-pddl", "-s", "robothow-small", "-g", "IsOpen_frigde", "-o", str(out))
    assert code == EXIT_INPUT
    assert "unknown object 'frigde'" in one_line_error(err)
    assert stdout == ""
    assert not out.exists() or not any(out.iterdir())


# ------------------------------------------------------------------ -g @FILE (issue 14, G)
def test_goal_from_a_file_and_from_standard_input(
    capsys: pytest.CaptureFixture[str], monkeypatch: pytest.MonkeyPatch, tmp_path: Path, robowaiter: Scenario
) -> None:
    expected = plan(robowaiter.task, "On_Coffee_Table1", "obtea", mutexes=robowaiter.mutexes, heuristic="lm")
    goal_file = tmp_path / "goal.txt"
    goal_file.write_text("\ufeffOn_Coffee_Table1\n", encoding="utf-8")  # a byte order mark is dropped
    code, record = run_json(capsys, "plan", "-s", "robowaiter", "-p", "obtea", "-g", f"@{goal_file}")
    assert code == EXIT_OK
    assert (record["goal"], record["cost"]) == ("On_Coffee_Table1", expected.cost)
    monkeypatch.setattr("sys.stdin", io.TextIOWrapper(io.BytesIO(b"On_Coffee_Table1 &\n  On_Coffee_Table1\n")))
    code, record = run_json(capsys, "plan", "-s", "robowaiter", "-p", "obtea", "-g", "@-")
    assert code == EXIT_OK
    assert (record["goal"], record["cost"]) == ("On_Coffee_Table1", expected.cost)


@pytest.mark.parametrize(
    ("content", "name", "needle"),
    [
        (None, "missing.txt", "missing.txt: cannot read the goal: No such file or directory"),
        (None, "", "cannot read the goal: it is a folder"),
        (b"On_Coffee_\xff_Table1", "latin.txt", "latin.txt:1:11: the goal is not UTF-8 text (byte 10)"),
        (b"", "empty.txt", "empty goal"),
    ],
)
def test_unreadable_goal_file_is_a_one_line_input_error(
    capsys: pytest.CaptureFixture[str], tmp_path: Path, content: bytes | None, name: str, needle: str
) -> None:
    path = tmp_path / name
    if content is not None:
        path.write_bytes(content)
    code, out, err = run(capsys, "plan", "-s", "robowaiter", "-g", f"@{path}")
    assert code == EXIT_INPUT
    assert out == ""
    assert needle in one_line_error(err)


def test_goal_file_name_must_not_be_empty(capsys: pytest.CaptureFixture[str]) -> None:
    code, _, err = run(capsys, "plan", "-s", "robowaiter", "-g", "@")
    assert code == EXIT_INPUT
    assert "the file name is missing" in one_line_error(err)


def test_a_10000_literal_goal_file_is_rejected_with_one_short_line(
    capsys: pytest.CaptureFixture[str], tmp_path: Path
) -> None:
    goal_file = tmp_path / "goal.txt"
    goal_file.write_text(" &\n".join(f"IsIn(x{i},y{i})" for i in range(10_000)) + " &\n", encoding="utf-8")
    code, _, err = run(capsys, "plan", "-s", "robothow", "-g", f"@{goal_file}")
    assert code == EXIT_INPUT
    line = one_line_error(err)
    assert "expected a literal at character" in line
    assert len(line) < 250


# ----------------------------------------------------------------------- --alpha (issue 14, E)
@pytest.mark.parametrize(
    ("alpha", "needle"),
    [
        ("inf", "alpha must be a finite number, not inf"),
        ("-inf", "alpha must be a finite number, not -inf"),
        ("nan", "alpha must be a finite number, not nan"),
        ("1e-320", "alpha must be between 1 and 1,000,000,000, not 1e-320"),
        ("0", "alpha must be between 1 and 1,000,000,000, not 0.0"),
        ("0.5", "alpha must be between 1 and 1,000,000,000, not 0.5"),
        ("1e300", "alpha must be between 1 and 1,000,000,000, not 1e+300"),
    ],
)
@pytest.mark.parametrize("llm", [False, True])
def test_invalid_alpha_is_a_one_line_input_error(
    capsys: pytest.CaptureFixture[str], alpha: str, needle: str, llm: bool
) -> None:
    argv = ["plan", "-s", "robowaiter", "-p", "hbtp-o", "-g", "On_Coffee_Table1", "--alpha", alpha]
    code, out, err = run(capsys, *argv, *(["--llm", "oracle"] if llm else ["--hints", "oracle"]))
    assert code == EXIT_INPUT
    assert out == ""
    assert one_line_error(err) == f"hbtp: error: {needle}"


@pytest.mark.parametrize("alpha", ["1", "2.5", "1e9"])
def test_valid_alpha_plans_and_the_tree_reaches_the_goal(
    capsys: pytest.CaptureFixture[str], tmp_path: Path, robowaiter: Scenario, alpha: str
) -> None:
    out = tmp_path / "tree.json"
    code, _, err = run(
        capsys, "plan", "-s", "robowaiter", "-p", "hbtp-o", "-g", "On_Coffee_Table1", "--hints", "oracle",
        "--alpha", alpha, "-o", str(out),
    )  # fmt: skip
    assert code == EXIT_OK, err
    root, _ = tree_from_json(out.read_text(encoding="utf-8"), robowaiter.task, str(out))
    run_result = run_tree(root, robowaiter.task, robowaiter.task.initial_state, max_ticks=100)
    assert run_result.reached
    assert robowaiter.task.resolve_goal("On_Coffee_Table1").ids <= run_result.state


@pytest.mark.parametrize(
    "alpha", [float("inf"), float("nan"), 1e-320, 0, 0.999, -5, 10**10, 1e300, Fraction(1, 2), True, "10"]
)
def test_plan_api_rejects_an_invalid_alpha(robowaiter: Scenario, alpha: Any) -> None:
    with pytest.raises(InputError, match=r"^alpha must be"):
        plan(robowaiter.task, "On_Coffee_Table1", "hbtp-o", alpha=alpha)


@pytest.mark.parametrize("alpha", [1, 1.0, 2.5, Fraction(7, 2), 10_000, 10_000.0, 10**9])
def test_plan_api_accepts_a_valid_alpha(robowaiter: Scenario, alpha: Any) -> None:
    task = robowaiter.task
    hints = oracle_hints(task, task.resolve_goal("On_Coffee_Table1"), robowaiter.mutexes)
    result = plan(task, "On_Coffee_Table1", "hbtp-o", hints=hints, mutexes=robowaiter.mutexes, alpha=alpha)
    optimum = plan(task, "On_Coffee_Table1", "obtea", mutexes=robowaiter.mutexes)
    assert result.cost == optimum.cost  # a correct heuristic path: HBTP-O is optimal for any alpha
    run_result = run_tree(tree_of(result), task, task.initial_state, max_ticks=100)
    assert run_result.reached


def test_a_goal_with_many_unreachable_literals_gets_a_short_message(
    capsys: pytest.CaptureFixture[str], robothow_small: Scenario
) -> None:
    task = robothow_small.task
    candidates = [f"IsClose_{o}" for o in task.objects] + [f"IsOpen_{o}" for o in task.objects]
    unreachable = []
    for literal in candidates:
        try:
            if task.resolve_goal(literal).unreachable:
                unreachable.append(literal)
        except InputError:
            continue
    assert len(unreachable) > 12
    code, out, _ = run(capsys, "plan", "-s", "robothow-small", "-g", " & ".join(unreachable))
    assert code == EXIT_NOT_SOLVED
    first = out.splitlines()[0]
    assert first.startswith("unsolvable:")
    assert f"and {len(unreachable) - 10} more" in first
    assert len(first) < 600


# ------------------------------------------------------------------ the problem's :goal (issue 11, item 3)
HOUSEHOLD = Path(__file__).parent.parent / "data" / "household"


def test_without_goal_the_pddl_problems_goal_is_planned(capsys: pytest.CaptureFixture[str]) -> None:
    domain, problem = str(HOUSEHOLD / "domain.pddl"), str(HOUSEHOLD / "problem.pddl")
    code, record = run_json(capsys, "plan", "--pddl", domain, problem, "-p", "obtea")
    assert code == EXIT_OK
    assert record["goal"] == "inside_apple_fridge & closed_fridge"
    explicit_code, explicit = run_json(
        capsys, "plan", "--pddl", domain, problem, "-p", "obtea", "-g", "inside(apple,fridge) & closed(fridge)"
    )
    assert explicit_code == EXIT_OK
    assert (record["cost"], record["executed"]) == (explicit["cost"], explicit["executed"])


def test_without_goal_a_placeholder_is_a_one_line_error_and_a_disjunctive_goal_is_planned(
    capsys: pytest.CaptureFixture[str], tmp_path: Path
) -> None:
    code, out, err = run(capsys, "plan", "-s", "robowaiter")
    assert (code, out) == (EXIT_INPUT, "")
    assert "has no :goal to plan for; give one with -g" in one_line_error(err)
    problem = (HOUSEHOLD / "problem.pddl").read_text(encoding="utf-8")
    disjunctive = tmp_path / "or.pddl"
    disjunctive.write_text(
        problem.replace(
            "(:goal (and (inside apple fridge) (closed fridge)))", "(:goal (or (closed fridge) (opened fridge)))"
        ),
        encoding="utf-8",
    )
    code, record = run_json(capsys, "plan", "--pddl", str(HOUSEHOLD / "domain.pddl"), str(disjunctive), "-p", "obtea")
    assert code == EXIT_OK
    assert record["goal"] == "closed_fridge | opened_fridge"
    assert record["cost"] == 0  # the fridge is closed in s0: the first disjunct holds
    equality = tmp_path / "eq.pddl"
    equality.write_text(
        problem.replace("(:goal (and (inside apple fridge) (closed fridge)))", "(:goal (= apple fridge))"),
        encoding="utf-8",
    )
    code, out, err = run(capsys, "plan", "--pddl", str(HOUSEHOLD / "domain.pddl"), str(equality))
    assert (code, out) == (EXIT_INPUT, "")
    assert "the problem's :goal is never true once its exists/forall and = are evaluated" in one_line_error(err)


def test_the_library_plans_with_the_cli_defaults(capsys: pytest.CaptureFixture[str], robothow: Scenario) -> None:
    # One default heuristic (landmarks) for `hbtp plan` and hbtp.planning.plan(): the README's API
    # example and the command give the same search.
    code, out, err = run(capsys, "plan", "-s", "robothow", "-g", MILK, "--json")
    assert code == EXIT_OK, err
    shown = json.loads(out)
    scenario, goal = robothow.resolve_goal(MILK)
    scenario = scenario.for_goal(goal)
    result = plan(scenario.task, goal, mutexes=scenario.mutexes)
    assert result.cost == shown["cost"]
    assert len(result.expansions) == shown["explored"]
    without = plan(scenario.task, goal, mutexes=scenario.mutexes, heuristic="none")
    assert len(without.expansions) != shown["explored"]  # the default is a heuristic, not none
