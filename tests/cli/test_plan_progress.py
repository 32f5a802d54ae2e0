"""``hbtp plan --llm``: what it is doing, on stderr, only on a terminal and never with ``--json``."""

from __future__ import annotations

import io
import json
import sys

import pytest

from hbtp.cli import main

GOAL = "IsIn_cutlets_fridge & IsClose_fridge"


class Terminal(io.StringIO):
    def isatty(self) -> bool:
        return True


def run(monkeypatch: pytest.MonkeyPatch, capsys: pytest.CaptureFixture[str], *extra: str) -> tuple[str, str]:
    capsys.readouterr()
    terminal = Terminal()
    monkeypatch.setattr(sys, "stderr", terminal)
    code = main(["plan", "-s", "robothow-small", "-g", GOAL, "--llm", "oracle", *extra])
    assert code == 0
    return capsys.readouterr().out, terminal.getvalue()


def test_a_terminal_is_told_what_is_happening(
    monkeypatch: pytest.MonkeyPatch, capsys: pytest.CaptureFixture[str]
) -> None:
    _, shown = run(monkeypatch, capsys)
    lines = shown.splitlines()
    assert lines[0] == "hbtp: round 1 of 4"
    assert lines[1] == "hbtp: asking oracle"
    assert lines[2].startswith("hbtp: answered: ")
    assert lines[3].startswith("hbtp: planning in ")


def test_json_stays_quiet(monkeypatch: pytest.MonkeyPatch, capsys: pytest.CaptureFixture[str]) -> None:
    out, shown = run(monkeypatch, capsys, "--json")
    assert "hbtp: round" not in shown
    record = json.loads(out)["llm"]
    assert record["llm_calls"] == 1
    assert record["rounds"][0]["calls"][0]["unknown"] == 0
