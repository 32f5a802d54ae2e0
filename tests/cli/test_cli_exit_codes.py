"""One exit-code table and one error prefix for every command; a closed pipe keeps the exit code."""

from __future__ import annotations

import os
import subprocess
import sys
from pathlib import Path

import click
import pytest
from click.testing import CliRunner

import hbtp.cli
from hbtp.bt import Action, Condition, Fallback, Node, Sequence
from hbtp.bt.jsonio import tree_to_json
from hbtp.cli import EXIT_INPUT, EXIT_INTERNAL, EXIT_NOT_SOLVED, EXIT_OK, main
from hbtp.cli.exit_codes import ERROR_PREFIX, ExitCode, error_line, plan_exit_code
from hbtp.cli.run_command import EXIT_FAILED, abbreviate_steps, run_command
from hbtp.domains import Scenario
from hbtp.planning.result import Status

GOAL = "IsIn_apple_fridge & IsClose_fridge"


def test_one_table() -> None:
    assert [int(code) for code in ExitCode] == [0, 1, 2, 3, 130]
    assert (EXIT_OK, EXIT_NOT_SOLVED, EXIT_INPUT, EXIT_INTERNAL) == (0, 1, 2, 3)
    assert EXIT_FAILED is ExitCode.NOT_SOLVED
    assert error_line("two\nlines") == "hbtp: error: two; lines"


@pytest.mark.parametrize(
    ("argv", "message"),
    [
        (["run"], "Missing argument 'TREE_FILE'"),
        (["plan", "-s", "robothow-small", "-p", "nope"], "Invalid value for '-p' / '--planner'"),
        (["plan", "--no-such-option"], "No such option"),
        (["no-such-command"], "No such command 'no-such-command'"),
        (["run", "tree.json", "--perturb", "2"], "[0, 1]"),
    ],
)
def test_usage_errors_carry_the_prefix(argv: list[str], message: str, capsys: pytest.CaptureFixture[str]) -> None:
    assert main(argv) == EXIT_INPUT
    lines = capsys.readouterr().err.splitlines()
    assert len(lines) == 1, lines  # one line, no usage block above it
    assert lines[0].startswith(ERROR_PREFIX)
    assert message in lines[0]
    assert lines[0].endswith("-h')")  # where the help is


def test_run_and_verify_errors_carry_the_prefix(tmp_path: Path, capsys: pytest.CaptureFixture[str]) -> None:
    bad = tmp_path / "bad.json"
    bad.write_text("not json at all", encoding="utf-8")
    for command in ("run", "verify"):
        assert main([command, str(bad), "-s", "robothow-small"]) == EXIT_INPUT
        err = capsys.readouterr().err
        assert err == f"{ERROR_PREFIX}{bad}: not valid JSON (Expecting value at line 1)\n"
    # The same line when the command runs on its own (click's standalone mode).
    result = CliRunner().invoke(run_command, [str(bad), "-s", "robothow-small"])
    assert result.exit_code == EXIT_INPUT
    assert result.output.startswith(ERROR_PREFIX)


def test_internal_errors_carry_the_prefix(monkeypatch: pytest.MonkeyPatch, capsys: pytest.CaptureFixture[str]) -> None:
    @click.command("boom")
    def boom() -> None:
        raise RuntimeError("a bug")

    commands = {**hbtp.cli.cli.loaded_commands(), "boom": boom}
    group = click.Group(name="hbtp", commands=commands, params=hbtp.cli.cli.params)
    monkeypatch.setattr(hbtp.cli, "cli", group)
    assert main(["boom"]) == EXIT_INTERNAL
    assert (
        capsys.readouterr().err == f"{ERROR_PREFIX}internal error: RuntimeError: a bug (run with --debug for details)\n"
    )


# ------------------------------------------------------------------------------- abbreviated runs
def test_abbreviate_steps() -> None:
    assert abbreviate_steps([]) == "(nothing)"
    assert abbreviate_steps(["Walk(fridge)"] * 1000) == "Walk(fridge) ×1000"
    assert abbreviate_steps(["A", "B", "B", "C"]) == "A -> B ×2 -> C"
    assert abbreviate_steps(["Walk(a)"] + ["Open(x)", "Close(x)"] * 50) == "Walk(a) -> (Open(x) -> Close(x)) ×50"
    long = abbreviate_steps([f"Walk(o{i})" for i in range(40)], shown=30)
    assert long.endswith("Walk(o29) -> ... 10 more step(s)")


def test_run_abbreviates_a_broken_tree(tmp_path: Path, robothow_small: Scenario) -> None:
    task = robothow_small.task
    walk = task.action("Walk(apple)").index
    tree = Fallback((Condition(task.resolve_goal(GOAL).ids), Sequence((Condition(frozenset()), Action(walk)))))
    path = tmp_path / "tree.json"
    path.write_text(tree_to_json(tree, task, scenario="robothow-small", goal=GOAL), encoding="utf-8")
    result = CliRunner().invoke(run_command, [str(path)])
    assert result.exit_code == EXIT_NOT_SOLVED
    assert result.output.splitlines()[1] == "executes: Walk(apple) ×1000"


# ------------------------------------------------------------------------------------ broken pipe
@pytest.fixture(scope="module")
def unguarded_tree(tmp_path_factory: pytest.TempPathFactory, robothow_small: Scenario) -> Path:
    """A tree of 3000 unguarded actions: ``hbtp verify`` prints a problem line for each and exits 1."""
    task = robothow_small.task
    walks = tuple(Action(action.index) for action in task.actions if action.name.startswith("Walk("))
    tree: Node = Fallback((Condition(task.resolve_goal(GOAL).ids), *(walks * (3000 // len(walks) + 1))[:3000]))
    path = tmp_path_factory.mktemp("pipe") / "unguarded.json"
    path.write_text(tree_to_json(tree, task, scenario="robothow-small", goal=GOAL), encoding="utf-8")
    return path


def _into_a_closed_pipe(argv: list[str]) -> tuple[int, str]:
    """``hbtp ARGV | head -0``: standard output is a pipe whose reader is gone before anything is
    written (deterministic, unlike racing a reader that leaves after one line)."""
    read_end, write_end = os.pipe()
    os.close(read_end)
    try:
        process = subprocess.run(
            [sys.executable, "-m", "hbtp", *argv], stdout=write_end, stderr=subprocess.PIPE, timeout=120, check=False
        )
    finally:
        os.close(write_end)
    return process.returncode, process.stderr.decode("utf-8", "replace")


@pytest.mark.parametrize(
    ("argv", "expected"),
    [
        (["plan", "-s", "robothow-small", "-g", GOAL], EXIT_OK),
        (["plan", "-s", "robothow-small", "-g", GOAL, "--max-expansions", "2"], EXIT_NOT_SOLVED),
        (["export", "TREE", "-f", "text"], EXIT_OK),
        (["verify", "TREE"], EXIT_NOT_SOLVED),
        (["verify", "TREE", "--goal", "IsFlying_self"], EXIT_INPUT),
    ],
)
def test_a_closed_pipe_keeps_the_exit_code(argv: list[str], expected: int, unguarded_tree: Path) -> None:
    code, error = _into_a_closed_pipe([str(unguarded_tree) if a == "TREE" else a for a in argv])
    assert code == expected, error
    assert "Traceback" not in error
    assert "Exception ignored" not in error
    assert "internal error" not in error


def test_a_bare_hbtp_prints_the_help(capsys: pytest.CaptureFixture[str]) -> None:
    assert main([]) == EXIT_INPUT
    err = capsys.readouterr().err
    assert err.startswith("Usage: hbtp")
    assert "Commands:" in err
    assert ERROR_PREFIX not in err


@pytest.mark.parametrize("status", list(Status))
def test_a_planning_status_has_one_exit_code(status: Status) -> None:
    expected = {Status.SOLVED: ExitCode.OK, Status.ERROR: ExitCode.INTERNAL}.get(status, ExitCode.NOT_SOLVED)
    assert plan_exit_code(status) is expected
