"""Record and replay across backends: a run recorded with one backend replays with the same replies,
and a request's key leaves out what is bookkeeping.
"""

from __future__ import annotations

import importlib.util
import json
from collections.abc import Callable
from pathlib import Path
from typing import Any

import pytest
from servers import GOAL, needs_openai, plan_openai, run

from hbtp.cli import EXIT_OK
from hbtp.datasets import load_dataset
from hbtp.deadline import Deadline
from hbtp.domains import Scenario
from hbtp.llm.backend import Message, Request
from hbtp.llm.backends.oracle import OracleBackend


def _replay_matches(capsys: pytest.CaptureFixture[str], argv: list[str], record_file: Path) -> None:
    code, out, err, _ = run(capsys, *argv, "--record", str(record_file), "--json")
    assert code == EXIT_OK, err
    recorded = json.loads(out)
    plan = argv[: argv.index("--llm")]
    code, out, err, _ = run(capsys, *plan, "--llm", f"replay:{record_file}", "--json")
    assert code == EXIT_OK, err
    replayed = json.loads(out)
    assert "no reply" not in err
    assert replayed["llm"]["outcome"] == recorded["llm"]["outcome"]
    assert [r["replies"] for r in replayed["llm"]["rounds"]] == [r["replies"] for r in recorded["llm"]["rounds"]]
    assert all(not r["error"] for r in replayed["llm"]["rounds"])


def test_record_then_replay_noisy_oracle(capsys: pytest.CaptureFixture[str], tmp_path: Path) -> None:
    goal = load_dataset("table2_robothow_small_50")[0].goal
    argv = ["plan", "-s", "robothow-small", "-g", goal, "--llm", "noisy-oracle", "--noise-drop", "0.6"]
    _replay_matches(capsys, argv, tmp_path / "noisy.jsonl")


@needs_openai
def test_record_then_replay_openai(
    json_server: Any, capsys: pytest.CaptureFixture[str], tmp_path: Path, robowaiter: Scenario
) -> None:
    oracle = OracleBackend(robowaiter)

    def respond(path: str, payload: dict[str, Any]) -> tuple[int, Any]:
        goal = payload["messages"][-1]["content"].rsplit("Goals: ", 1)[1].split("\n", 1)[0]
        text = oracle.complete(Request((), "", goal=goal)).text
        choice = {"index": 0, "finish_reason": "stop", "message": {"role": "assistant", "content": text}}
        return 200, {"id": "x", "object": "chat.completion", "created": 0, "model": "m", "choices": [choice]}

    server = json_server(respond)
    _replay_matches(capsys, plan_openai(server.base_url), tmp_path / "openai.jsonl")


def test_record_then_replay_local(
    capsys: pytest.CaptureFixture[str], tmp_path: Path, monkeypatch: pytest.MonkeyPatch, robowaiter: Scenario
) -> None:
    """The local backend (completion prompts, 160 tokens) replays under the chat defaults (256)."""
    from hbtp.llm.backends import local

    oracle = OracleBackend(robowaiter)

    class FakeLlama:
        def handle_completions(self, body: dict[str, Any], callback: Callable[[Any], bool]) -> None:
            goal = body["prompt"].rsplit("Goals: ", 1)[1].split("\n", 1)[0]
            text = oracle.complete(Request((), "", goal=goal)).text.removeprefix("Optimal Actions:")
            callback({"choices": [{"text": text, "finish_reason": "stop"}], "usage": {}})

    def load(self: Any) -> None:
        self._server = FakeLlama()

    find_spec = importlib.util.find_spec
    monkeypatch.setattr(
        importlib.util, "find_spec", lambda name, *a: object() if name == "xllamacpp" else find_spec(name, *a)
    )
    monkeypatch.setattr(local.LocalBackend, "load", load)
    argv = ["plan", "-s", "robowaiter", "-g", GOAL, "--llm", "local"]
    _replay_matches(capsys, argv, tmp_path / "local.jsonl")


@pytest.mark.llm
def test_record_then_replay_the_real_local_model(capsys: pytest.CaptureFixture[str], tmp_path: Path) -> None:
    pytest.importorskip("xllamacpp")
    argv = ["plan", "-s", "robowaiter", "-g", GOAL, "--llm", "local", "--feedback-rounds", "1"]
    _replay_matches(capsys, argv, tmp_path / "gemma.jsonl")


def test_the_key_ignores_style_defaults() -> None:
    base = Request((Message("user", "Goals: X"),), "Goals: X\nOptimal Actions:", goal="X")
    for changed in (
        Request(base.messages, base.completion_prompt, goal="X", max_tokens=160),
        Request(base.messages, base.completion_prompt, goal="X", stop=("\n\n",), deadline=Deadline(3.0), round=1),
    ):
        assert changed.key() == base.key()
    assert Request(base.messages, "other", goal="X").key() != base.key()
    assert Request(base.messages, base.completion_prompt, goal="X", temperature=0.7).key() != base.key()
