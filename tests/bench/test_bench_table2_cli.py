"""``hbtp bench table2`` and ``hbtp plan --llm`` in process: results, resuming, recorded hints,
repeated runs, the per-round record, record/replay and the errors."""

from __future__ import annotations

import json
from pathlib import Path
from typing import Any

import pytest

from hbtp.bench.table2 import PAPER
from hbtp.cli import EXIT_INPUT, EXIT_OK, main
from hbtp.datasets import load_dataset, write_text
from hbtp.datasets.records import Record

ROUND_FIELDS = {
    "round",
    "prompts",
    "replies",
    "hints",
    "repairs",
    "blacklist",
    "action_space",
    "status",
    "explored",
    "llm_seconds",
    "planning_seconds",
    "error",
    "calls",
}
MILK = "IsIn_milk_fridge & IsClose_fridge"


def run(capsys: pytest.CaptureFixture[str], *argv: str) -> tuple[int, str, str]:
    code = main(list(argv))
    captured = capsys.readouterr()
    return code, captured.out, captured.err


def rows(path: Path) -> list[dict[str, Any]]:
    return [json.loads(line) for line in path.read_text(encoding="utf-8").splitlines() if line.strip()]


def one_line(err: str) -> str:
    lines = [line for line in err.splitlines() if line.strip()]
    assert len(lines) == 1, err
    assert "Traceback" not in err
    return lines[0]


# ---------------------------------------------------------------------------------- bench table2
def test_table2_with_the_oracle_and_resume(capsys: pytest.CaptureFixture[str], tmp_path: Path) -> None:
    out = tmp_path / "t2"
    argv = ["bench", "table2", "--llm", "oracle", "-s", "robowaiter", "--limit", "5", "-o", str(out), "--no-progress"]
    code, printed, err = run(capsys, *argv)
    assert code == EXIT_OK, err
    results = rows(out / "robowaiter" / "results.jsonl")
    assert len(results) == 5
    expected_ids = [r.id for r in load_dataset("table2_robowaiter_50")[:5]]
    assert [r["task"] for r in results] == expected_ids
    optimal_costs = {"1": 5, "2": 57, "3": 5, "4": 57, "5": 3}  # Make_Coffee; Make_Water ... PutDown_Water_Table1; ...
    plans = {r.id: r.optimal_actions for r in load_dataset("table2_robowaiter_50")[:5]}
    for row in results:
        assert (row["scenario"], row["backend"], row["run"]) == ("robowaiter", "oracle", 0)
        assert (row["outcome"], row["solved"], row["rounds"]) == ("NF", True, 1)
        assert row["cost"] == optimal_costs[row["task"]]
        assert row["p_hat"] == row["p_star"] == len(plans[row["task"]])
        assert row["action_space"] == row["A_star"] == len(set(plans[row["task"]]))
        assert row["explored"] == row["p_star"] + 1  # a perfect p̂: HBTP-S expands |p*| + 1 conditions
        assert row["errors"] == []
    summary = json.loads((out / "robowaiter" / "summary.json").read_text(encoding="utf-8"))
    assert summary["tasks"] == 5
    for column in ("NF", "1F", "2F", "3F", "final"):
        assert summary[column] == 100.0, column
    assert summary["fallback"] == 0.0
    assert summary["dataset"] == "table2_robowaiter_50"
    assert summary["problem"] == {"A": 174, "Q": 6, "O": 31}
    assert summary["paper"] == PAPER["robowaiter"]
    assert (summary["paper"]["NF"], summary["paper"]["1F"], summary["paper"]["3F"]) == (92.0, 98.67, 99.33)
    assert summary["A_minus"] > 0
    assert summary["p_hat"] > 0
    overall = json.loads((out / "summary.json").read_text(encoding="utf-8"))
    assert [s["scenario"] for s in overall["scenarios"]] == ["robowaiter"]
    assert "92.0/98.67/99.33" in printed
    assert "robowaiter" in printed
    assert "100.0" in printed

    # re-running resumes: nothing new is run or written
    before = (out / "robowaiter" / "results.jsonl").read_text(encoding="utf-8")
    code, _, err = run(capsys, *argv)
    assert code == EXIT_OK, err
    assert (out / "robowaiter" / "results.jsonl").read_text(encoding="utf-8") == before
    again = json.loads((out / "robowaiter" / "summary.json").read_text(encoding="utf-8"))
    assert again["NF"] == 100.0
    assert again["tasks"] == 5
    # a larger limit runs only the new tasks
    code, _, err = run(capsys, *[a if a != "5" else "7" for a in argv])
    assert code == EXIT_OK, err
    grown = rows(out / "robowaiter" / "results.jsonl")
    assert len(grown) == 7
    assert grown[:5] == results


def test_table2_hints_from_a_dataset_file(capsys: pytest.CaptureFixture[str], tmp_path: Path) -> None:
    records = load_dataset("table2_robothow_small_50")[:4]
    wrong = records[1]  # its recorded reply misses an action: only feedback or the fallback can help
    spoiled = Record(wrong.id, wrong.goal, ("Walk_tv", "SwitchOn_tv"), ("Walk", "SwitchOn"), ("tv",), wrong.instruction)
    hints = tmp_path / "replies.txt"
    hints.write_text(write_text([records[0], spoiled, *records[2:]]), encoding="utf-8")
    out = tmp_path / "hf"
    common = ["bench", "table2", "-s", "robothow-small", "--limit", "4", "--no-progress", "--hints-from", str(hints)]
    code, _, err = run(capsys, *common, "-o", str(out))
    assert code == EXIT_OK, err
    results = {r["task"]: r for r in rows(out / "robothow-small" / "results.jsonl")}
    assert len(results) == 4
    assert {r["backend"] for r in results.values()} == {"hints-from:replies.txt"}
    assert results[spoiled.id]["outcome"] == "fallback"  # no backend for the feedback rounds
    assert results[spoiled.id]["solved"] is True
    assert "first round only" in results[spoiled.id]["errors"][0]
    assert all(results[r.id]["outcome"] == "NF" for r in (records[0], *records[2:]))
    summary = json.loads((out / "robothow-small" / "summary.json").read_text(encoding="utf-8"))
    assert (summary["NF"], summary["3F"], summary["final"], summary["fallback"]) == (75.0, 75.0, 100.0, 25.0)

    # with a backend for the feedback rounds the spoiled task is solved by feedback
    code, _, err = run(capsys, *common, "--llm", "oracle", "-o", str(tmp_path / "hf2"))
    assert code == EXIT_OK, err
    results = {r["task"]: r for r in rows(tmp_path / "hf2" / "robothow-small" / "results.jsonl")}
    assert results[spoiled.id]["outcome"] == "1F"
    assert {r["backend"] for r in results.values()} == {"hints-from:replies.txt+oracle"}


def test_table2_noisy_oracle_two_runs(capsys: pytest.CaptureFixture[str], tmp_path: Path) -> None:
    out = tmp_path / "noisy"
    argv = ["bench", "table2", "--llm", "noisy-oracle", "-s", "robothow-small", "--limit", "3", "--runs", "2",
            "--noise-drop", "0.5", "--noise-insert", "0.5", "-o", str(out), "--no-progress"]  # fmt: skip
    code, _, err = run(capsys, *argv)
    assert code == EXIT_OK, err
    results = rows(out / "robothow-small" / "results.jsonl")
    assert len(results) == 6
    per_task: dict[str, list[int]] = {}
    for row in results:
        per_task.setdefault(row["task"], []).append(row["run"])
        assert row["solved"] is True
        assert row["backend"] == "noisy-oracle"
    assert all(sorted(runs) == [0, 1] for runs in per_task.values())
    assert len(per_task) == 3
    summary = json.loads((out / "robothow-small" / "summary.json").read_text(encoding="utf-8"))
    assert (summary["runs"], summary["tasks"], summary["final"]) == (2, 6, 100.0)


def test_table2_unknown_backend(capsys: pytest.CaptureFixture[str], tmp_path: Path) -> None:
    code, _, err = run(capsys, "bench", "table2", "--llm", "gpt5", "-s", "robowaiter", "--limit", "1",
                       "-o", str(tmp_path / "x"), "--no-progress")  # fmt: skip
    assert code == EXIT_INPUT
    assert "unknown LLM backend 'gpt5'" in one_line(err)


# ---------------------------------------------------------------------------------- plan --llm
def test_plan_with_the_oracle_prints_the_round_record(capsys: pytest.CaptureFixture[str]) -> None:
    code, out, err = run(capsys, "plan", "-s", "robothow", "-g", MILK, "--llm", "oracle", "--json")
    assert code == EXIT_OK, err
    record = json.loads(out)
    assert record["status"] == "solved"
    assert record["hints"] == "llm"
    llm = record["llm"]
    assert llm["outcome"] == "NF"
    (first,) = llm["rounds"]
    assert set(first) == ROUND_FIELDS
    assert first["status"] == "solved"
    assert first["round"] == 0
    assert first["error"] == ""
    assert 0 < first["action_space"] < 7329
    assert first["llm_seconds"] >= 0
    assert first["planning_seconds"] >= 0
    (call,) = first["calls"]  # one call, counted and timed
    assert (call["round"], call["unknown"]) == (0, 0)
    assert llm["llm_calls"] == 1
    (prompt,) = first["prompts"]
    assert set(prompt) == {"key", "round", "attempt", "messages", "completion_prompt"}
    assert [m["role"] for m in prompt["messages"]] == ["system", "user"]
    assert prompt["messages"][1]["content"] == f"Goals: {MILK}"
    (reply,) = first["replies"]
    assert reply.startswith("Optimal Actions: Walk_milk")
    assert first["hints"]["path"][0] == "Walk(milk)"
    assert "fridge" in first["hints"]["objects"]
    assert record["executed"][-1] == "Close(fridge)"


def test_plan_text_output_names_the_outcome(capsys: pytest.CaptureFixture[str]) -> None:
    code, out, err = run(capsys, "plan", "-s", "robowaiter", "-g", "On_Coffee_Table1", "--llm", "oracle")
    assert code == EXIT_OK, err
    assert out.startswith("LLM: solved with the LLM's first answer (NF)")
    assert "round 0: solved in a space of " in out


def test_record_then_replay_gives_the_same_tree(capsys: pytest.CaptureFixture[str], tmp_path: Path) -> None:
    replies = tmp_path / "replies.jsonl"
    common = ["plan", "-s", "robothow-small", "-g", "IsIn_cutlets_fridge & IsClose_fridge", "--llm"]
    noise = ["--noise-drop", "0.6", "--noise-insert", "0.6", "--seed", "4", "--json"]
    code, out, err = run(capsys, *common, "noisy-oracle", *noise, "--record", str(replies), "-o",
                         str(tmp_path / "a.json"))  # fmt: skip
    assert code == EXIT_OK, err
    recorded = json.loads(out)
    assert replies.exists()
    lines = rows(replies)
    assert len(lines) == sum(len(r["prompts"]) for r in recorded["llm"]["rounds"])
    code, out, err = run(capsys, *common, f"replay:{replies}", *noise, "-o", str(tmp_path / "b.json"))
    assert code == EXIT_OK, err
    replayed = json.loads(out)
    assert (tmp_path / "a.json").read_text(encoding="utf-8") == (tmp_path / "b.json").read_text(encoding="utf-8")
    assert replayed["executed"] == recorded["executed"]
    assert replayed["cost"] == recorded["cost"]
    assert replayed["llm"]["outcome"] == recorded["llm"]["outcome"]
    assert [r["replies"] for r in replayed["llm"]["rounds"]] == [r["replies"] for r in recorded["llm"]["rounds"]]
    assert rows(replies) == lines  # replaying writes nothing


def test_plan_unknown_backend_exits_2(capsys: pytest.CaptureFixture[str]) -> None:
    code, out, err = run(capsys, "plan", "-s", "robowaiter", "-g", "On_Coffee_Table1", "--llm", "claude")
    assert code == EXIT_INPUT
    assert out == ""
    line = one_line(err)
    assert "unknown LLM backend 'claude'" in line
    assert "oracle" in line  # the choices are named


def test_plan_replay_file_missing_exits_2(capsys: pytest.CaptureFixture[str], tmp_path: Path) -> None:
    missing = tmp_path / "nothing.jsonl"
    code, out, err = run(capsys, "plan", "-s", "robowaiter", "-g", "On_Coffee_Table1", "--llm", f"replay:{missing}")
    assert code == EXIT_INPUT
    assert out == ""
    line = one_line(err)
    assert line.startswith("hbtp: error: replay file")
    assert str(missing) in line
    assert "does not exist" in line


def test_plan_replay_without_a_file_exits_2(capsys: pytest.CaptureFixture[str]) -> None:
    code, _, err = run(capsys, "plan", "-s", "robowaiter", "-g", "On_Coffee_Table1", "--llm", "replay")
    assert code == EXIT_INPUT
    assert "replay needs a file" in one_line(err)


def test_plan_replay_of_another_goal_falls_back(capsys: pytest.CaptureFixture[str], tmp_path: Path) -> None:
    """A replay file without this prompt: the backend fails, the loop falls back, the task is solved."""
    replies = tmp_path / "replies.jsonl"
    code, _, err = run(capsys, "plan", "-s", "robowaiter", "-g", "On_Coffee_Table1", "--llm", "oracle",
                       "--record", str(replies))  # fmt: skip
    assert code == EXIT_OK, err
    code, out, err = run(capsys, "plan", "-s", "robowaiter", "-g", "On_Water_Table1", "--llm", f"replay:{replies}",
                         "--json")  # fmt: skip
    assert code == EXIT_OK, err
    record = json.loads(out)
    assert record["llm"]["outcome"] == "fallback"
    assert "has no reply for this prompt" in record["llm"]["rounds"][0]["error"]
    assert "goal 'On_Water_Table1', round 0" in record["llm"]["rounds"][0]["error"]
