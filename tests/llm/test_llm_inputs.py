"""What the LLM side reads, refused as one-line errors when bad: replay and record files, base URLs,
and hints files that must hold the goal's record.
"""

from __future__ import annotations

import logging
from pathlib import Path

import pytest
from servers import GOAL, one_line, run

from hbtp.cli import EXIT_INPUT, EXIT_OK
from hbtp.cli.hints_file import HintsSource, load_hints
from hbtp.datasets import load_dataset
from hbtp.domains import Scenario
from hbtp.errors import InputError
from hbtp.llm.backend import Request
from hbtp.llm.backends.oracle import OracleBackend
from hbtp.llm.parse import hints_from_record
from hbtp.planning import Limits


def test_bad_llm_inputs_are_one_line_errors(capsys: pytest.CaptureFixture[str], tmp_path: Path) -> None:
    binary = tmp_path / "replies.jsonl"
    binary.write_bytes(b"\xff\xfe\x00garbage")
    base = ["plan", "-s", "robowaiter", "-g", GOAL]
    cases = [
        ([*base, "--llm", f"replay:{binary}"], "not UTF-8"),
        ([*base, "--llm", f"replay:{tmp_path}"], "it is a folder"),
        ([*base, "--llm", "oracle", "--record", "/proc/x/rec.jsonl"], "the folder /proc/x does not exist"),
        ([*base, "--llm", "openai", "--base-url", "http://[::1"], "malformed"),
    ]
    for argv, expected in cases:
        code, _, err, _ = run(capsys, *argv)
        assert code == EXIT_INPUT, argv
        assert expected in one_line(err), argv


def _robowaiter_text() -> str:
    from hbtp.datasets import dataset_path

    return dataset_path("fewshot_robowaiter_100").read_text(encoding="utf-8")


def test_a_multi_record_file_with_a_malformed_record_gives_the_goals_record(
    tmp_path: Path, robowaiter: Scenario, caplog: pytest.LogCaptureFixture
) -> None:
    records = load_dataset("fewshot_robowaiter_100")
    wanted = records[10]
    blocks = _robowaiter_text().split("\n\n")
    blocks[3] = blocks[3].replace("Environment:1", "Environment:").replace("Vital Objects:", "Vital Objects :: ::")
    path = tmp_path / "RW_llm_data.txt"
    path.write_text("\n\n".join(blocks), encoding="utf-8")
    goal = robowaiter.task.resolve_goal(wanted.goal)
    with caplog.at_level(logging.WARNING):
        hints = load_hints(HintsSource(file=path), robowaiter, goal, Limits(time_s=10))
    assert hints == hints_from_record(wanted)
    assert hints != hints_from_record(records[0])
    assert "not a valid dataset file" in caplog.text


def test_a_hints_file_without_the_goal_is_rejected(
    tmp_path: Path, robowaiter: Scenario, capsys: pytest.CaptureFixture[str]
) -> None:
    records = load_dataset("fewshot_robowaiter_100")
    goals = {r.goal.strip() for r in records}
    absent = next(g for g in ("RobotNear_BrightTable2", "RobotNear_Bar", "RobotNear_Table1") if g not in goals)
    malformed = tmp_path / "malformed.txt"
    malformed.write_text(_robowaiter_text().replace("Environment:1", "Environment:", 1), encoding="utf-8")
    single = tmp_path / "single.txt"
    single.write_text(_robowaiter_text().split("\n\n")[0] + "\n", encoding="utf-8")
    for path in (malformed, single):
        code, _, err, _ = run(capsys, "plan", "-s", "robowaiter", "-g", absent, "--hints", str(path))
        assert code == EXIT_INPUT
        assert f"the goal {absent}" in one_line(err)
    with pytest.raises(InputError, match="its only record is not for the goal"):
        load_hints(HintsSource(file=single), robowaiter, robowaiter.task.resolve_goal(absent), Limits(time_s=10))


def test_a_non_utf8_hints_file_is_one_line(tmp_path: Path, capsys: pytest.CaptureFixture[str]) -> None:
    path = tmp_path / "hints.txt"
    path.write_bytes(b"Optimal Actions: Walk_\xff\xfe\n")
    code, _, err, _ = run(capsys, "plan", "-s", "robowaiter", "-g", GOAL, "--hints", str(path))
    assert code == EXIT_INPUT
    assert "not UTF-8" in one_line(err)


def test_a_raw_reply_without_a_goal_still_works(
    tmp_path: Path, capsys: pytest.CaptureFixture[str], robowaiter: Scenario
) -> None:
    path = tmp_path / "reply.txt"
    reply = OracleBackend(robowaiter).complete(Request((), "", goal=GOAL)).text
    path.write_text(f"Sure!\n{reply}\n", encoding="utf-8")
    code, _, err, _ = run(capsys, "plan", "-s", "robowaiter", "-g", GOAL, "--hints", str(path))
    assert code == EXIT_OK, err
