"""The HBTP loop end to end: reason, check, prune, plan; reflective feedback; the full-space fallback.

Whatever the LLM answers (the optimal plan, garbage, nothing, names outside the domain, a plan that
misses an action or takes the wrong ones) or does (fail, hang, talk nonsense over HTTP), the loop
must return a tree that really reaches the goal, say honestly how it got there, and never hang.
"""

from __future__ import annotations

import dataclasses
import importlib.util
import json
import socket
import threading
import time
from collections.abc import Callable, Iterator
from http.server import BaseHTTPRequestHandler
from pathlib import Path
from typing import Any

import pytest

from hbtp.bt import tree_of
from hbtp.bt.simulate import simulate
from hbtp.datasets import load_dataset
from hbtp.domains import Scenario
from hbtp.errors import BackendError
from hbtp.llm.backend import PromptStyle, Reply, Request
from hbtp.llm.backends.oracle import NoisyOracleBackend, OracleBackend
from hbtp.llm.backends.replay import RecordingBackend, ReplayBackend
from hbtp.llm.pool import example_pool
from hbtp.llm.prompt import PromptOptions
from hbtp.pipeline import LoopOptions, LoopResult, Outcome, RoundStatus, run_hbtp
from hbtp.pipeline.loop import longest_paths
from hbtp.planning import Hints, plan
from hbtp.planning.execution import execute_expansions
from hbtp.planning.result import Status
from helpers import LoopbackHTTP, reaches, send_json_bytes

HAVE_XLLAMACPP = importlib.util.find_spec("xllamacpp") is not None
HAVE_OPENAI = importlib.util.find_spec("openai") is not None
needs_openai = pytest.mark.skipif(not HAVE_OPENAI, reason="the openai package is not installed")

GOAL = "IsIn_cutlets_fridge & IsClose_fridge"
PLAN = (
    "Walk_cutlets",
    "RightGrab_cutlets",
    "Walk_fridge",
    "Open_fridge",
    "PlugIn_fridge",
    "RightPutIn_cutlets_fridge",
    "Close_fridge",
)
RIGHT = (
    f"Optimal Actions: {', '.join(PLAN)}\n"
    "Vital Action Predicates: Walk, RightGrab, Open, PlugIn, RightPutIn, Close\n"
    "Vital Objects: cutlets, fridge"
)
MISSING_ACTION = (  # no PlugIn_fridge: the fridge cannot be opened
    "Optimal Actions: Walk_cutlets, RightGrab_cutlets, Walk_fridge, Open_fridge, RightPutIn_cutlets_fridge, "
    "Close_fridge\nVital Action Predicates: Walk, RightGrab, Open, RightPutIn, Close\nVital Objects: cutlets, fridge"
)
WRONG_ACTIONS = (
    "Optimal Actions: Walk_tv, PlugIn_tv, SwitchOn_tv\n"
    "Vital Action Predicates: Walk, PlugIn, SwitchOn\nVital Objects: tv"
)
EMPTY = "Optimal Actions: \nVital Action Predicates: \nVital Objects: "
UNKNOWN = "Optimal Actions: Teleport_cutlets_fridge\nVital Action Predicates: Teleport\nVital Objects: unicorn"
GARBAGE = "lorem ipsum dolor sit amet, consectetur adipiscing elit"
CASE_ERRORS = RIGHT.replace("Walk_cutlets", "walk_cutlets").replace("Vital Objects: cutlets", "Vital Objects: Cutlets")
TEST_SETS = {
    "robowaiter": ("table2_robowaiter_50", slice(None)),
    "virtualhome": ("table2_virtualhome_50", slice(None)),
    "robothow-small": ("table2_robothow_small_50", slice(None)),
    "robothow": ("table2_robothow_50", slice(None, None, 5)),
}


class Scripted:
    """A backend answering from a script, one entry per call (the last repeats); an exception entry
    is raised. Every request is kept for inspection."""

    name = "scripted"
    prompt_style = PromptStyle.CHAT

    def __init__(self, *script: str | Exception) -> None:
        self.script = script
        self.requests: list[Request] = []
        self.closed = False

    def complete(self, request: Request) -> Reply:
        self.requests.append(request)
        answer = self.script[min(len(self.requests), len(self.script)) - 1]
        if isinstance(answer, Exception):
            raise answer
        return Reply(answer, 0.25, prompt_tokens=10, completion_tokens=5)

    def close(self) -> None:
        self.closed = True


def assert_reaches_goal(scenario: Scenario, loop: LoopResult) -> None:
    """The returned tree, ticked from s0, reaches the goal; so does its expansion record."""
    task = scenario.task
    result = loop.result
    goal = result.goal.ids
    assert result.solved, (loop.outcome, result.status, result.message)
    run = execute_expansions(task, result.expansions)
    assert run.reached(goal)
    assert reaches(task, run.executed, goal)
    assert run.cost == result.cost
    ticked = simulate(tree_of(result, "full"), task)
    assert ticked.reached(goal)
    assert ticked.cost == result.cost
    assert reaches(task, result.solution, goal)


def assert_round_records_complete(loop: LoopResult, task_actions: int) -> None:
    assert loop.rounds
    for number, record in enumerate(loop.rounds):
        assert record.round == number
        assert record.prompts
        for attempt, prompt in enumerate(record.prompts):
            assert set(prompt) == {"key", "round", "attempt", "messages", "completion_prompt"}
            assert (prompt["round"], prompt["attempt"]) == (number, attempt)
            assert len(prompt["key"]) == 64
            assert prompt["messages"]
            assert prompt["messages"][0]["role"] == "system"
            assert prompt["completion_prompt"].endswith("Optimal Actions:")
        assert len(record.replies) in (len(record.prompts), len(record.prompts) - 1)
        assert 0 <= record.action_space <= task_actions
        assert record.status is not RoundStatus.SKIPPED
        assert record.to_dict()["status"] in ("solved", "unsolvable", "timeout", "node-limit", "memory-limit")
        assert record.llm_seconds >= 0
        assert record.planning_seconds >= 0
        json.dumps(record.to_dict())
    assert loop.llm_seconds >= 0
    assert loop.planning_seconds >= 0
    json.dumps(loop.to_dict())


def without_timing(loop: LoopResult) -> list[Any]:
    def untimed(calls: tuple[dict[str, Any], ...]) -> tuple[dict[str, Any], ...]:
        return tuple({k: v for k, v in call.items() if k not in ("seconds", "tokens_per_second")} for call in calls)

    return [dataclasses.replace(r, llm_seconds=0.0, planning_seconds=0.0, calls=untimed(r.calls)) for r in loop.rounds]


@pytest.fixture(scope="module")
def small_pool(robothow_small: Scenario) -> list[Any]:
    return example_pool(robothow_small)


def run_small(scenario: Scenario, pool: list[Any], backend: Any, **options: Any) -> LoopResult:
    return run_hbtp(scenario, GOAL, backend, pool, LoopOptions(**options))


# ---------------------------------------------------------------------------------- the oracle
@pytest.mark.parametrize("name", list(TEST_SETS))
def test_oracle_solves_the_table2_tasks_without_feedback(name: str, request: pytest.FixtureRequest) -> None:
    scenario: Scenario = request.getfixturevalue(name.replace("-", "_"))
    dataset, sample = TEST_SETS[name]
    pool = example_pool(scenario)
    backend = OracleBackend(scenario)
    options = LoopOptions(prompt=PromptOptions(exclude_same_goal=True))
    records = load_dataset(dataset)[sample]
    assert len(records) >= 10
    for record in records:
        loop = run_hbtp(scenario, record.goal, backend, pool, options)
        assert loop.outcome.label == "NF", record.id
        assert len(loop.rounds) == 1
        (first,) = loop.rounds
        assert first.status is RoundStatus.SOLVED
        assert len(first.prompts) == len(first.replies) == 1
        if first.hints.path:
            assert first.hints.predicates
            assert first.hints.objects
            assert 0 < first.action_space < len(scenario.task.actions)
        else:  # the goal holds from the start: nothing to do, and the empty tree says so
            assert loop.result.goal.ids <= scenario.task.initial_state, record.id
            assert first.action_space == 0
        assert first.repairs == ()
        assert first.blacklist == ()
        assert first.error == ""
        assert first.explored == loop.result.stats.explored
        assert_round_records_complete(loop, len(scenario.task.actions))
        assert_reaches_goal(scenario, loop)
        # the oracle's plan is optimal and the pruned space holds it: the tree costs the optimum
        assert loop.result.cost == sum(scenario.task.actions[i].cost for i in backend.optimal(str(loop.result.goal)))


# ---------------------------------------------------------------------------------- outcome labels
@pytest.mark.parametrize(("wrong_rounds", "outcome"), [(0, "NF"), (1, "1F"), (2, "2F"), (3, "3F"), (4, "fallback")])
def test_outcome_label_counts_the_feedback_rounds(
    robothow_small: Scenario, small_pool: list[Any], wrong_rounds: int, outcome: str
) -> None:
    backend = Scripted(*([WRONG_ACTIONS] * wrong_rounds), RIGHT)
    loop = run_small(robothow_small, small_pool, backend, feedback_rounds=3)
    assert loop.outcome == Outcome.parse(outcome)
    assert loop.outcome.label == outcome == loop.to_dict()["outcome"]
    assert len(loop.rounds) == min(wrong_rounds + 1, 4)
    assert len(backend.requests) == min(wrong_rounds + 1, 4)
    assert [r.round for r in backend.requests] == list(range(len(backend.requests)))
    assert [r.status for r in loop.rounds[:wrong_rounds]] == [RoundStatus.UNSOLVABLE] * min(wrong_rounds, 4)
    assert_round_records_complete(loop, len(robothow_small.task.actions))
    assert_reaches_goal(robothow_small, loop)


def test_a_late_feedback_round_is_not_labelled_3f(robothow_small: Scenario, small_pool: list[Any]) -> None:
    backend = Scripted(*([WRONG_ACTIONS] * 5), RIGHT)
    loop = run_small(robothow_small, small_pool, backend, feedback_rounds=6)
    assert len(loop.rounds) == 6  # solved after five feedback rounds
    assert loop.solved
    assert loop.outcome.label == "5F"


@pytest.mark.parametrize(
    ("script", "requests"),
    [
        ((GARBAGE,), 12),  # unparsable: every round asks three times, then the fallback
        (("",), 12),  # nothing at all
        ((EMPTY,), 4),  # a clean but empty answer: one request per round
        ((UNKNOWN,), 12),  # names outside the domain
        ((WRONG_ACTIONS,), 4),  # real names, wrong plan
        ((MISSING_ACTION,), 4),  # one action short, every time
    ],
    ids=["garbage", "empty-text", "empty-lists", "unknown-names", "wrong-actions", "missing-action"],
)
def test_bad_answers_still_solve_through_the_fallback(
    robothow_small: Scenario, small_pool: list[Any], script: tuple[str, ...], requests: int
) -> None:
    backend = Scripted(*script)
    loop = run_small(robothow_small, small_pool, backend)
    assert loop.outcome.label == "fallback"
    assert len(loop.rounds) == 4
    assert len(backend.requests) == requests
    assert all(r.status is not RoundStatus.SOLVED for r in loop.rounds)
    assert_round_records_complete(loop, len(robothow_small.task.actions))
    assert_reaches_goal(robothow_small, loop)
    # the fallback plans in the full space: the tree is as cheap as the oracle's
    optimum = OracleBackend(robothow_small).optimal(GOAL)
    assert loop.result.cost == sum(robothow_small.task.actions[i].cost for i in optimum)


def test_a_missing_action_is_found_through_feedback(robothow_small: Scenario, small_pool: list[Any]) -> None:
    backend = Scripted(MISSING_ACTION, RIGHT)
    loop = run_small(robothow_small, small_pool, backend)
    assert loop.outcome.label == "1F"
    first, second = loop.rounds
    assert first.status is RoundStatus.UNSOLVABLE
    assert "PlugIn(fridge)" not in first.hints.path
    assert second.status is RoundStatus.SOLVED
    assert second.action_space > first.action_space  # the space only grows
    assert_reaches_goal(robothow_small, loop)


def test_without_fallback_an_unsolved_task_fails_quietly(robothow_small: Scenario, small_pool: list[Any]) -> None:
    for script in ((WRONG_ACTIONS,), (GARBAGE,), (BackendError("server down"),)):
        loop = run_small(robothow_small, small_pool, Scripted(*script), fallback=False)
        assert loop.outcome.label == "failed"
        assert not loop.solved
        assert not loop.result.solved
        assert loop.rounds


def test_no_feedback_rounds_and_no_fallback(robothow_small: Scenario, small_pool: list[Any]) -> None:
    backend = Scripted(WRONG_ACTIONS)
    loop = run_small(robothow_small, small_pool, backend, feedback_rounds=0, fallback=False)
    assert (loop.outcome.label, len(loop.rounds), len(backend.requests)) == ("failed", 1, 1)
    loop = run_small(robothow_small, small_pool, Scripted(WRONG_ACTIONS), feedback_rounds=0)
    assert loop.outcome.label == "fallback"
    assert_reaches_goal(robothow_small, loop)


# ---------------------------------------------------------------------------------- grammar in the loop
def test_grammar_retry_then_success(robothow_small: Scenario, small_pool: list[Any]) -> None:
    backend = Scripted(UNKNOWN, RIGHT)
    loop = run_small(robothow_small, small_pool, backend)
    assert loop.outcome.label == "NF"
    (record,) = loop.rounds
    assert len(backend.requests) == 2 == len(record.prompts) == len(record.replies)
    assert [(r.round, r.attempt) for r in backend.requests] == [(0, 0), (0, 1)]
    assert set(record.blacklist) == {"Teleport_cutlets_fridge", "Teleport", "unicorn"}
    retry = backend.requests[1]
    assert retry.messages[-2].content == UNKNOWN
    assert "Teleport_cutlets_fridge is not in the domain" in retry.messages[-1].content
    assert "Do not use (not in this domain): Teleport, Teleport_cutlets_fridge, unicorn" in retry.messages[-1].content
    assert "Do not use (not in this domain): Teleport, Teleport_cutlets_fridge, unicorn" in retry.completion_prompt
    assert record.hints.path == tuple(f"{a.split('_')[0]}({','.join(a.split('_')[1:])})" for a in PLAN)
    assert_reaches_goal(robothow_small, loop)


def test_repairs_are_recorded_without_a_retry(robothow_small: Scenario, small_pool: list[Any]) -> None:
    backend = Scripted(CASE_ERRORS)
    loop = run_small(robothow_small, small_pool, backend)
    assert loop.outcome.label == "NF"
    assert len(backend.requests) == 1
    assert set(loop.rounds[0].repairs) == {"walk_cutlets -> Walk_cutlets", "Cutlets -> cutlets"}
    assert loop.rounds[0].blacklist == ()
    assert "Walk(cutlets)" in loop.rounds[0].hints.path


def test_the_blacklist_accumulates_over_rounds(robothow_small: Scenario, small_pool: list[Any]) -> None:
    first = "Optimal Actions: Teleport_cutlets\nVital Action Predicates: Walk\nVital Objects: cutlets"
    second = "Optimal Actions: Fly_fridge\nVital Action Predicates: Walk\nVital Objects: fridge"
    backend = Scripted(first, first, first, second, second, second, RIGHT)
    loop = run_small(robothow_small, small_pool, backend, grammar_retries=2)
    assert loop.outcome.label == "2F"
    assert loop.rounds[0].blacklist == ("Teleport_cutlets",)
    assert loop.rounds[1].blacklist == ("Teleport_cutlets", "Fly_fridge")
    assert loop.rounds[2].blacklist == ("Teleport_cutlets", "Fly_fridge")
    assert len(backend.requests) == 7
    last_retry = backend.requests[5]
    assert (last_retry.round, last_retry.attempt) == (1, 2)
    assert "Do not use (not in this domain): Fly_fridge, Teleport_cutlets" in last_retry.messages[-1].content
    assert_reaches_goal(robothow_small, loop)


def test_grammar_retries_setting(robothow_small: Scenario, small_pool: list[Any]) -> None:
    backend = Scripted(UNKNOWN)
    run_small(robothow_small, small_pool, backend, grammar_retries=0, feedback_rounds=1)
    assert [(r.round, r.attempt) for r in backend.requests] == [(0, 0), (1, 0)]
    backend = Scripted(UNKNOWN)
    run_small(robothow_small, small_pool, backend, grammar_retries=4, feedback_rounds=0)
    assert [r.attempt for r in backend.requests] == [0, 1, 2, 3, 4]


def test_the_conversation_holds_only_what_was_really_said(robothow_small: Scenario, small_pool: list[Any]) -> None:
    """Each request's assistant turns are exactly the replies received before it, in order, and every
    user turn but the last was answered."""
    replies = [UNKNOWN, UNKNOWN.replace("unicorn", "dragon"), UNKNOWN.replace("unicorn", "moon"), WRONG_ACTIONS, RIGHT]
    backend = Scripted(*replies)
    loop = run_small(robothow_small, small_pool, backend, grammar_retries=2)
    assert loop.outcome.label == "2F"
    for number, request in enumerate(backend.requests):
        roles = [m.role for m in request.messages]
        assert roles[0] == "system"
        assert roles[1:] == ["user", "assistant"] * number + ["user"], (number, roles)
        assistant = [m.content for m in request.messages if m.role == "assistant"]
        assert assistant == replies[:number], number


def test_an_unanswered_retry_stays_out_of_the_conversation(robothow_small: Scenario, small_pool: list[Any]) -> None:
    backend = Scripted(UNKNOWN, BackendError("timed out once"), MISSING_ACTION, RIGHT)
    loop = run_small(robothow_small, small_pool, backend)
    assert [(r.round, r.attempt) for r in backend.requests] == [(0, 0), (0, 1), (1, 0), (2, 0)]
    assert loop.outcome.label == "2F"
    assert loop.rounds[0].error == "timed out once"
    feedback = backend.requests[2]
    assert [m.role for m in feedback.messages] == ["system", "user", "assistant", "user"]
    assert feedback.messages[2].content == UNKNOWN
    assert feedback.messages[3].content.startswith("The planner could not reach")
    assert_reaches_goal(robothow_small, loop)


# ---------------------------------------------------------------------------------- feedback content
def test_feedback_carries_the_longest_paths_and_what_was_left_out(
    robothow_small: Scenario, small_pool: list[Any]
) -> None:
    task = robothow_small.task
    backend = Scripted(MISSING_ACTION, RIGHT)
    loop = run_small(robothow_small, small_pool, backend, top_k=2)
    assert loop.outcome.label == "1F"
    feedback = backend.requests[1]
    assert (feedback.round, feedback.attempt) == (1, 0)
    assert feedback.messages[-2].content == MISSING_ACTION
    text = feedback.messages[-1].content
    lines = text.splitlines()
    numbered = [line for line in lines if line[:1].isdigit()]
    assert len(numbered) == 2  # top_k
    assert "longest partial plans" in text
    allowed = {"Walk", "RightGrab", "Open", "RightPutIn", "Close"}
    for line in numbered:
        actions = line.split(". ", 1)[1].split(", ")
        assert actions[-1] == "Close_fridge"  # the paths end at the goal
        assert {a.split("_")[0] for a in actions} <= allowed
    # the top path is the longest
    assert len(numbered[0].split(", ")) >= len(numbered[1].split(", "))
    # the same paths the search gives (recomputed independently of the loop)
    round0 = plan(  # as the loop's rounds plan: the paper's planner, no LLM-free heuristic
        task,
        GOAL,
        "hbtp-s",
        hints=loop.rounds[0].hints,
        space="pruned",
        mutexes=robothow_small.mutexes,
        heuristic="none",
    )
    names = [a.signature.underscored for a in task.actions]
    assert [line.split(". ", 1)[1] for line in numbered] == [", ".join(p) for p in longest_paths(round0, names, 2)]
    left_predicates = sorted(set(task.action_predicates) - allowed)
    left_objects = sorted(set(task.objects) - {"cutlets", "fridge"})
    assert f"Action predicates left out: {', '.join(left_predicates)}" in lines
    assert f"Objects left out: {', '.join(left_objects)}" in lines
    assert "PlugIn" in left_predicates


def test_longest_paths_lead_from_explored_conditions_to_the_goal(robothow_small: Scenario) -> None:
    task = robothow_small.task
    hinted = ("Walk(cutlets)", "RightGrab(cutlets)", "Open(fridge)", "RightPutIn(cutlets,fridge)", "Close(fridge)")
    hints = Hints(hinted, ("Walk",), ("cutlets", "fridge"))
    result = plan(task, GOAL, "hbtp-s", hints=hints, space="pruned", mutexes=robothow_small.mutexes, heuristic="none")
    assert not result.solved
    names = [a.signature.underscored for a in task.actions]
    paths = longest_paths(result, names, 3)
    assert 1 <= len(paths) <= 3
    assert [len(p) for p in paths] == sorted((len(p) for p in paths), reverse=True)
    goal = result.goal.ids
    for path in paths:
        steps = [task.action(name) for name in path]
        assert any(
            all(step.pre <= state for step, state in _states(e.condition, steps)) and goal <= _final(e.condition, steps)
            for e in result.expansions
        ), path
    assert longest_paths(result, names, 0) == []


def _states(condition: frozenset[int], steps: list[Any]) -> Iterator[tuple[Any, frozenset[int]]]:
    state = condition
    for step in steps:
        yield step, state
        state = step.progress(state)


def _final(condition: frozenset[int], steps: list[Any]) -> frozenset[int]:
    state = condition
    for step in steps:
        state = step.progress(state)
    return state


# ---------------------------------------------------------------------------------- the backend fails
def test_backend_down_stops_asking_and_falls_back(robothow_small: Scenario, small_pool: list[Any]) -> None:
    backend = Scripted(BackendError("cannot reach the LLM server: connection refused"))
    started = time.monotonic()
    loop = run_small(robothow_small, small_pool, backend)
    assert time.monotonic() - started < 10
    assert len(backend.requests) == 1
    assert loop.outcome.label == "fallback"
    (record,) = loop.rounds
    assert "connection refused" in record.error
    assert record.replies == ()
    assert record.hints == Hints()
    assert_reaches_goal(robothow_small, loop)


def test_backend_down_without_fallback_is_not_planned_not_unsolvable(
    robothow_small: Scenario, small_pool: list[Any]
) -> None:
    backend = Scripted(BackendError("cannot reach the LLM server: connection refused"))
    loop = run_small(robothow_small, small_pool, backend, fallback=False)
    assert loop.outcome.label == "failed"
    assert loop.result.status is Status.NOT_PLANNED  # no search ran: no verdict, certainly no proof
    assert "connection refused" in loop.result.message


def test_backend_lost_after_a_round(robothow_small: Scenario, small_pool: list[Any]) -> None:
    backend = Scripted(MISSING_ACTION, BackendError("HTTP 503"))
    loop = run_small(robothow_small, small_pool, backend)
    assert len(backend.requests) == 2
    assert loop.outcome.label == "fallback"
    assert [r.error for r in loop.rounds] == ["", "HTTP 503"]
    # the fallback keeps what the LLM said in round 0 (it only orders the search)
    assert_reaches_goal(robothow_small, loop)


def test_backend_lost_during_a_grammar_retry(robothow_small: Scenario, small_pool: list[Any]) -> None:
    backend = Scripted(UNKNOWN, BackendError("timed out"))
    loop = run_small(robothow_small, small_pool, backend)
    assert [(r.round, r.attempt) for r in backend.requests] == [(0, 0), (0, 1), (1, 0)]
    assert loop.outcome.label == "fallback"
    assert_reaches_goal(robothow_small, loop)


# ---------------------------------------------------------------------------------- determinism
def test_oracle_runs_are_identical(robothow: Scenario) -> None:
    pool = example_pool(robothow)
    goal = load_dataset("table2_robothow_50")[3].goal
    runs = [run_hbtp(robothow, goal, OracleBackend(robothow), pool) for _ in range(2)]
    assert runs[0].result.expansions == runs[1].result.expansions
    assert (runs[0].result.solution, runs[0].result.cost) == (runs[1].result.solution, runs[1].result.cost)
    assert without_timing(runs[0]) == without_timing(runs[1])
    assert runs[0].outcome == runs[1].outcome == Outcome.after(0)


def test_replayed_runs_are_identical(tmp_path: Path, robothow_small: Scenario, small_pool: list[Any]) -> None:
    path = tmp_path / "replies.jsonl"
    noisy = NoisyOracleBackend(robothow_small, drop=0.6, insert=0.6, seed=11)
    goals = [r.goal for r in load_dataset("table2_robothow_small_50")[:10]]
    first = [run_hbtp(robothow_small, g, RecordingBackend(noisy, path), small_pool) for g in goals]
    assert any(loop.outcome.label != "NF" for loop in first), "the noise never needed feedback"
    for _ in range(2):
        replay = ReplayBackend(path)
        again = [run_hbtp(robothow_small, g, replay, small_pool) for g in goals]
        for before, after in zip(first, again, strict=True):
            assert after.outcome == before.outcome
            assert after.result.expansions == before.result.expansions
            assert without_timing(after) == without_timing(before)
            assert_reaches_goal(robothow_small, after)


# ---------------------------------------------------------------------------------- the OpenAI backend over HTTP
class FakeOpenAI:
    """An OpenAI-compatible server on 127.0.0.1 that answers with ``respond(path, payload)``:
    a text (sent as a chat/completions choice), raw bytes (sent as is), or None (no answer)."""

    def __init__(self, respond: Callable[[str, dict[str, Any]], str | bytes | None]) -> None:
        self.requests: list[dict[str, Any]] = []
        self.release = threading.Event()
        fake = self

        class Handler(BaseHTTPRequestHandler):
            def log_message(self, format: str, *args: Any) -> None:
                pass

            def do_POST(self) -> None:
                length = int(self.headers.get("Content-Length") or 0)
                payload = json.loads(self.rfile.read(length) or b"{}")
                fake.requests.append({"path": self.path, "json": payload})
                answer = respond(self.path, payload)
                if answer is None:
                    fake.release.wait(10.0)
                    return
                if isinstance(answer, str):
                    choice: dict[str, Any] = {"index": 0, "finish_reason": "stop"}
                    if self.path.endswith("/chat/completions"):
                        choice["message"] = {"role": "assistant", "content": answer}
                        kind = "chat.completion"
                    else:
                        choice["text"] = answer
                        kind = "text_completion"
                    body = {"id": "x", "object": kind, "created": 0, "model": "fake", "choices": [choice]}
                    answer = json.dumps(body).encode()
                send_json_bytes(self, 200, answer)

        self.http = LoopbackHTTP(Handler)
        self.base_url = self.http.base_url

    def stop(self) -> None:
        self.release.set()
        self.http.close()


@pytest.fixture
def serve() -> Iterator[Callable[[Callable[[str, dict[str, Any]], str | bytes | None]], FakeOpenAI]]:
    servers: list[FakeOpenAI] = []

    def start(respond: Callable[[str, dict[str, Any]], str | bytes | None]) -> FakeOpenAI:
        servers.append(FakeOpenAI(respond))
        return servers[-1]

    yield start
    for server in servers:
        server.stop()


@pytest.fixture(autouse=True)
def _no_openai_environment(monkeypatch: pytest.MonkeyPatch) -> None:
    for name in ("OPENAI_API_KEY", "OPENAI_BASE_URL", "HBTP_LLM_MODEL"):
        monkeypatch.delenv(name, raising=False)


def openai_backend(base_url: str, **options: Any) -> Any:
    from hbtp.llm.backends.openai_backend import OpenAIBackend

    settings: dict[str, Any] = {"model": "fake", "timeout": 5.0, "max_retries": 1, "retry_delay": 0.01}
    settings.update(options)
    return OpenAIBackend(base_url=base_url, **settings)


@needs_openai
@pytest.mark.parametrize("completions", [False, True], ids=["chat", "completions"])
def test_openai_backend_normal_answers(
    serve: Any, robothow_small: Scenario, small_pool: list[Any], completions: bool
) -> None:
    oracle = OracleBackend(robothow_small)

    def respond(path: str, payload: dict[str, Any]) -> str:
        prompt = payload["prompt"] if completions else payload["messages"][-1]["content"]
        goal = prompt.rsplit("Goals: ", 1)[1].split("\n", 1)[0]
        text = oracle.complete(Request((), "", goal=goal)).text
        return text.removeprefix("Optimal Actions:") if completions else text  # a base model continues the prompt

    server = serve(respond)
    backend = openai_backend(server.base_url, use_completions=completions)
    style = "completion" if completions else "chat"
    for record in load_dataset("table2_robothow_small_50")[:5]:
        loop = run_hbtp(
            robothow_small, record.goal, backend, small_pool, LoopOptions(prompt=PromptOptions(style=style))
        )
        assert loop.outcome.label == "NF", record.id
        assert_reaches_goal(robothow_small, loop)
    assert len(server.requests) == 5
    assert {r["path"] for r in server.requests} == {"/v1/completions" if completions else "/v1/chat/completions"}
    backend.close()


def closed_port() -> int:
    with socket.socket() as probe:
        probe.bind(("127.0.0.1", 0))
        return int(probe.getsockname()[1])


@needs_openai
def test_openai_server_down_falls_back(robothow_small: Scenario, small_pool: list[Any]) -> None:
    backend = openai_backend(f"http://127.0.0.1:{closed_port()}/v1")
    started = time.monotonic()
    loop = run_small(robothow_small, small_pool, backend)
    assert time.monotonic() - started < 10
    assert loop.outcome.label == "fallback"
    assert len(loop.rounds) == 1
    assert "connection refused" in loop.rounds[0].error
    assert_reaches_goal(robothow_small, loop)


@needs_openai
def test_openai_timeout_falls_back_in_bounded_time(serve: Any, robothow_small: Scenario, small_pool: list[Any]) -> None:
    server = serve(lambda path, payload: None)  # never answers
    backend = openai_backend(server.base_url, timeout=1.0)
    started = time.monotonic()
    loop = run_small(robothow_small, small_pool, backend)
    elapsed = time.monotonic() - started
    assert elapsed < 1.0 + 5.0
    assert len(server.requests) == 1  # a timeout is not retried, and the loop stops asking
    assert loop.outcome.label == "fallback"
    assert "no answer from the LLM server" in loop.rounds[0].error
    assert_reaches_goal(robothow_small, loop)


@needs_openai
@pytest.mark.parametrize(
    ("answer", "requests"),
    [(b"{this is not json", 1), (b"<html>502</html>", 1), (GARBAGE, 12)],
    ids=["broken-json", "html", "garbage-text"],
)
def test_openai_garbage_falls_back(
    serve: Any, robothow_small: Scenario, small_pool: list[Any], answer: str | bytes, requests: int
) -> None:
    server = serve(lambda path, payload: answer)
    loop = run_small(robothow_small, small_pool, openai_backend(server.base_url))
    assert loop.outcome.label == "fallback"
    assert len(server.requests) == requests
    assert_reaches_goal(robothow_small, loop)


# ---------------------------------------------------------------------------------- the real local model
REAL_GOAL = "IsOpen_microwave"
MODEL_BUDGET_S = 60.0


@pytest.mark.llm
@pytest.mark.skipif(not HAVE_XLLAMACPP, reason="xllamacpp is not installed (the local extra)")
def test_real_model_behind_the_openai_backend_runs_the_loop(robothow_small: Scenario, small_pool: list[Any]) -> None:
    pytest.importorskip("openai")
    from hbtp.llm.backends.local_server import serve_local
    from hbtp.llm.backends.openai_backend import OpenAIBackend

    started = time.monotonic()
    with serve_local(threads=1) as url:
        backend = OpenAIBackend(base_url=url, use_completions=True, timeout=120)
        try:
            options = LoopOptions(prompt=PromptOptions(style="completion", examples=3), feedback_rounds=1)
            loop = run_hbtp(robothow_small, REAL_GOAL, backend, small_pool, options)
        finally:
            backend.close()
    elapsed = time.monotonic() - started
    assert loop.solved
    assert loop.outcome.label in ("NF", "1F", "fallback")
    assert loop.rounds[0].replies, "the model answered nothing"
    assert loop.rounds[0].prompts[0]["completion_prompt"].endswith(f"Goals: {REAL_GOAL}\nOptimal Actions:")
    assert loop.llm_seconds > 0
    assert_reaches_goal(robothow_small, loop)
    assert elapsed < MODEL_BUDGET_S


@pytest.mark.llm
@pytest.mark.skipif(not HAVE_XLLAMACPP, reason="xllamacpp is not installed (the local extra)")
def test_real_model_through_hbtp_plan(capsys: pytest.CaptureFixture[str]) -> None:
    from hbtp.cli import EXIT_OK, main

    started = time.monotonic()
    code = main(
        ["plan", "-s", "robothow-small", "-g", REAL_GOAL, "--llm", "local", "--threads", "1",
         "--examples", "3", "--feedback-rounds", "1", "--grammar-retries", "1", "--json"]
    )  # fmt: skip
    out, err = capsys.readouterr()
    assert code == EXIT_OK, err
    record = json.loads(out)
    assert record["status"] == "solved"
    assert record["llm"]["rounds"][0]["replies"]
    assert record["llm"]["rounds"][0]["prompts"][0]["completion_prompt"].endswith("Optimal Actions:")
    assert record["executed"][-1] == "Open(microwave)"
    assert time.monotonic() - started < MODEL_BUDGET_S


def test_the_fallback_does_not_trust_declared_mutexes(robothow_small: Scenario, small_pool: list[Any]) -> None:
    # The declared (unproved) hand rule says a hand cannot be empty and holding; the rag quirk
    # makes it reachable, and only the fallback, which prunes with proved mutexes, can find it.
    goal = "IsLeftHandEmpty_self & IsLeftHolding_self_rag"
    loop = run_hbtp(robothow_small, goal, Scripted(EMPTY), small_pool, LoopOptions(feedback_rounds=0))
    assert loop.outcome.label == "fallback"
    assert loop.solved
    run = execute_expansions(robothow_small.task, loop.result.expansions)
    assert run.reached(loop.result.goal.ids)
