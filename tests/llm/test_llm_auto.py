"""Auto mode (``plan_auto``, ``hbtp plan --llm auto:BACKEND``): LLM-free first, the LLM only when that
gives no verdict within the probe; the backend is never built when the probe solves the task."""

from __future__ import annotations

import json
import time
from typing import Any

import pytest

from hbtp.bt import tree_of
from hbtp.bt.simulate import simulate
from hbtp.cli import EXIT_INPUT, EXIT_NOT_SOLVED, EXIT_OK, main
from hbtp.deadline import Deadline, seconds_left
from hbtp.domains import Scenario
from hbtp.errors import InputError
from hbtp.llm.backend import Backend, PromptStyle, Reply, Request
from hbtp.llm.backends.oracle import OracleBackend
from hbtp.llm.backends.registry import BackendOptions, LlmSpec, make_backend
from hbtp.pipeline import AutoResult, LoopOptions, Outcome, plan_auto
from hbtp.planning.result import Status
from helpers import reaches

GOAL = "IsIn_cutlets_fridge & IsClose_fridge"  # 7 actions: more than one expansion
GARBAGE = "lorem ipsum dolor sit amet"


class Factory:
    """A backend factory that counts its calls and remembers what it built."""

    def __init__(self, make: Any) -> None:
        self.make = make
        self.built: list[Any] = []

    def __call__(self) -> Backend:
        backend = self.make()
        self.built.append(backend)
        return backend


class Slow:
    """Answers garbage after ``seconds`` (or the request's time limit, if shorter)."""

    name = "slow"
    prompt_style = PromptStyle.CHAT

    def __init__(self, seconds: float) -> None:
        self.seconds = seconds
        self.calls = 0
        self.closed = False

    def complete(self, request: Request) -> Reply:
        self.calls += 1
        time.sleep(min(self.seconds, seconds_left(request.deadline)))
        return Reply(GARBAGE + f" {self.calls}", self.seconds)

    def close(self) -> None:
        self.closed = True


def assert_verified(scenario: Scenario, auto: AutoResult) -> None:
    result = auto.result
    assert result.solved, (result.status, result.message)
    assert reaches(scenario.task, result.executed, result.goal.ids)
    assert simulate(tree_of(result, "full"), scenario.task).reached(result.goal.ids)


def test_an_easy_task_is_solved_by_the_probe_without_building_the_backend(robothow_small: Scenario) -> None:
    factory = Factory(lambda: pytest.fail("the backend must not be built"))
    pool_asked: list[bool] = []
    auto = plan_auto(robothow_small, GOAL, factory, lambda: pool_asked.append(True) or [], LoopOptions(), 2.0)
    assert not factory.built
    assert not pool_asked
    assert auto.loop is None
    assert not auto.asked_llm
    assert auto.probe.status is Status.SOLVED
    assert auto.probe_s < 2.0
    assert_verified(robothow_small, auto)
    assert auto.to_dict() == {
        "probe_s": round(auto.probe_s, 6),
        "probe_budget_s": 2.0,
        "probe_status": "solved",
        "asked_llm": False,
    }


def test_a_probe_without_verdict_goes_to_the_llm_loop(robothow_small: Scenario) -> None:
    factory = Factory(lambda: OracleBackend(robothow_small))
    auto = plan_auto(robothow_small, GOAL, factory, (), LoopOptions(), probe_seconds=1e-9)
    assert auto.probe.status is Status.TIMEOUT
    assert len(factory.built) == 1
    assert auto.asked_llm
    assert auto.loop is not None
    assert auto.loop.outcome == Outcome.after(0)
    assert_verified(robothow_small, auto)
    assert auto.to_dict()["probe_status"] == "timeout"
    assert auto.to_dict()["asked_llm"] is True


def test_the_loop_falls_back_when_the_llm_is_useless_and_closes_the_backend(robothow_small: Scenario) -> None:
    factory = Factory(lambda: Slow(0.0))
    auto = plan_auto(robothow_small, GOAL, factory, (), LoopOptions(feedback_rounds=1), probe_seconds=1e-9)
    assert auto.loop is not None
    assert auto.loop.outcome == Outcome.FALLBACK
    assert factory.built[0].closed
    assert_verified(robothow_small, auto)


def test_the_time_limit_bounds_probe_and_loop(robothow_small: Scenario) -> None:
    factory = Factory(lambda: Slow(10.0))
    options = LoopOptions(fallback=False, feedback_rounds=10)
    started = time.perf_counter()
    auto = plan_auto(robothow_small, GOAL, factory, (), options, probe_seconds=1e-9, deadline=Deadline(0.5))
    assert time.perf_counter() - started < 1.5
    assert auto.asked_llm
    assert not auto.solved


def test_no_time_left_after_the_probe_means_no_backend(robothow_small: Scenario) -> None:
    factory = Factory(lambda: pytest.fail("the backend must not be built"))
    auto = plan_auto(robothow_small, GOAL, factory, (), LoopOptions(), probe_seconds=2.0, deadline=Deadline(1e-9))
    assert auto.probe.status is Status.TIMEOUT
    assert not auto.asked_llm
    assert not auto.solved


def test_the_probe_budget_must_be_positive(robothow_small: Scenario) -> None:
    with pytest.raises(ValueError, match="positive"):
        plan_auto(robothow_small, GOAL, Factory(OracleBackend), (), None, probe_seconds=0.0)


@pytest.mark.parametrize(
    ("spec", "inner"),
    [
        ("auto", "local"),
        ("auto:openai", "openai"),
        ("auto:oracle", "oracle"),
        ("auto:replay:x.jsonl", "replay:x.jsonl"),
    ],
)
def test_auto_specs(spec: str, inner: str) -> None:
    parsed = LlmSpec.parse(spec)
    assert parsed.auto
    assert str(parsed.backend) == inner
    assert str(parsed) == f"auto:{inner}"


@pytest.mark.parametrize("spec", ["auto:", "auto:auto", "auto:bogus", "auto:replay:"])
def test_bad_auto_specs_are_input_errors(spec: str) -> None:
    with pytest.raises(InputError):
        LlmSpec.parse(spec)


def test_auto_is_not_a_backend(robothow_small: Scenario) -> None:
    assert not LlmSpec.parse("oracle").auto
    with pytest.raises(InputError, match="mode"):
        make_backend("auto:oracle", robothow_small, BackendOptions())


# ------------------------------------------------------------------------------------- the CLI
def plan_json(capsys: pytest.CaptureFixture[str], *extra: str) -> tuple[int, dict[str, Any]]:
    code = main(["plan", "-s", "robothow-small", "-g", GOAL, "--json", *extra])
    captured = capsys.readouterr()
    assert "Traceback" not in captured.err
    return code, json.loads(captured.out)


def test_cli_auto_solved_llm_free(capsys: pytest.CaptureFixture[str]) -> None:
    code, record = plan_json(capsys, "--llm", "auto:oracle")
    assert code == EXIT_OK
    assert record["status"] == "solved"
    assert record["auto"]["asked_llm"] is False
    assert record["auto"]["probe_status"] == "solved"
    assert record["auto"]["probe_budget_s"] == 2.0
    assert record["hints"] == "none"
    assert "llm" not in record


def test_cli_auto_asks_the_llm_after_the_probe(capsys: pytest.CaptureFixture[str]) -> None:
    code, record = plan_json(capsys, "--llm", "auto:oracle", "--auto-probe", "1e-9")
    assert code == EXIT_OK
    assert record["status"] == "solved"
    assert record["auto"]["asked_llm"] is True
    assert record["auto"]["probe_status"] == "timeout"
    assert record["llm"]["outcome"] == "NF"
    assert record["hints"] == "llm"


def test_cli_auto_text_says_which_path(capsys: pytest.CaptureFixture[str]) -> None:
    assert main(["plan", "-s", "robothow-small", "-g", GOAL, "--llm", "auto:oracle"]) == EXIT_OK
    first = capsys.readouterr().out.splitlines()[0]
    assert first.startswith("auto: LLM-free planning solved")
    assert "not asked" in first
    assert main(["plan", "-s", "robothow-small", "-g", GOAL, "--llm", "auto:oracle", "--auto-probe", "1e-9"]) == 0
    lines = capsys.readouterr().out.splitlines()
    assert lines[0].endswith("asked the LLM")
    assert lines[1].startswith("LLM: solved with the LLM's first answer (NF)")


def test_cli_time_limit_bounds_auto(capsys: pytest.CaptureFixture[str]) -> None:
    code, record = plan_json(capsys, "--llm", "auto:oracle", "-t", "1e-6")
    assert code == EXIT_NOT_SOLVED
    assert record["status"] == "timeout"
    assert record["auto"]["asked_llm"] is False


@pytest.mark.parametrize(
    "extra",
    [("--llm", "auto:bogus"), ("--llm", "auto:oracle", "--auto-probe", "0"), ("--llm", "auto", "--hints", "oracle")],
)
def test_cli_auto_input_errors_are_one_line(capsys: pytest.CaptureFixture[str], extra: tuple[str, ...]) -> None:
    code = main(["plan", "-s", "robothow-small", "-g", GOAL, *extra])
    err = capsys.readouterr().err
    assert code == EXIT_INPUT
    assert "Traceback" not in err
    assert [line for line in err.splitlines() if line.startswith("hbtp: error")]
