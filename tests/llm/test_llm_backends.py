"""Backends without a model: the oracle and noisy oracle, record/replay, recorded first replies, and
the registry."""

from __future__ import annotations

import json
from collections import Counter
from pathlib import Path

import pytest

from hbtp.datasets import load_dataset
from hbtp.datasets.records import Record
from hbtp.datasets.reply import format_reply
from hbtp.domains import Scenario
from hbtp.errors import BackendError, InputError
from hbtp.llm.backend import Message, PromptStyle, Reply, Request
from hbtp.llm.backends.first_reply import FirstReplyBackend
from hbtp.llm.backends.oracle import NoisyOracleBackend, OracleBackend
from hbtp.llm.backends.registry import BackendOptions, make_backend
from hbtp.llm.backends.replay import RecordingBackend, ReplayBackend
from hbtp.llm.grammar import check_reply
from hbtp.llm.parse import parse_reply
from hbtp.llm.pool import example_pool
from hbtp.pipeline import LoopOptions, run_hbtp
from helpers import is_subsequence, plan_cost, reaches

GOALS = [r.goal.strip() for r in load_dataset("table2_robothow_small_50")[:20]]


def ask(goal: str, round_: int = 0, attempt: int = 0, content: str = "") -> Request:
    return Request(
        messages=(Message("user", content or f"Goals: {goal}"),),
        completion_prompt=f"Goals: {goal}\nOptimal Actions:",
        goal=goal,
        round=round_,
        attempt=attempt,
    )


def path_of(backend: OracleBackend, goal: str, round_: int = 0) -> list[int]:
    task = backend.scenario.task
    text = backend.complete(ask(goal, round_)).text
    hints = check_reply(parse_reply(text), task).hints
    return [task.action(name).index for name in hints.path]


class Counting:
    """A backend that answers from a function and counts its calls."""

    name = "counting"
    prompt_style = PromptStyle.CHAT

    def __init__(self, answer: str = "Optimal Actions: Walk_fridge") -> None:
        self.answer = answer
        self.calls = 0

    def complete(self, request: Request) -> Reply:
        self.calls += 1
        return Reply(f"{self.answer} #{self.calls}", 0.5)

    def close(self) -> None:
        pass


# ---------------------------------------------------------------------------------- oracle
@pytest.mark.parametrize(
    ("name", "dataset", "count"),
    [
        ("robowaiter", "table2_robowaiter_50", 10),
        ("virtualhome", "table2_virtualhome_50", 5),
        ("robothow-small", "table2_robothow_small_50", 10),
    ],
)
def test_oracle_reply_parses_back_to_an_optimal_plan(
    name: str, dataset: str, count: int, request: pytest.FixtureRequest
) -> None:
    scenario: Scenario = request.getfixturevalue(name.replace("-", "_"))
    task = scenario.task
    backend = OracleBackend(scenario)
    for record in load_dataset(dataset)[:count]:
        goal = task.resolve_goal(record.goal)
        reply = backend.complete(ask(str(goal)))
        parsed = parse_reply(reply.text)
        assert parsed.complete, reply.text
        result = check_reply(parsed, task)
        assert result.clean, reply.text
        assert result.repairs == (), reply.text
        path = [task.action(name).index for name in result.hints.path]
        assert path == backend.optimal(str(goal))
        assert reaches(task, path, goal.ids), record.id
        # Q̂ and Ô are exactly the plan's predicates and objects
        assert set(result.hints.predicates) == {task.actions[i].predicate for i in path}
        assert set(result.hints.objects) == {o for i in path for o in task.actions[i].objects}
        # no dearer than the dataset's own solution (when that one is valid here)
        try:
            given = [task.action(a).index for a in record.optimal_actions]
        except InputError:
            continue
        if reaches(task, given, goal.ids):
            assert plan_cost(task, path) <= plan_cost(task, given), record.id
    backend.close()


def test_oracle_without_a_plan_raises_a_backend_error(robowaiter: Scenario) -> None:
    with pytest.raises(BackendError, match="the oracle has no plan for 'Fly_Coffee'"):
        OracleBackend(robowaiter).complete(ask("Fly_Coffee"))


# ---------------------------------------------------------------------------------- noisy oracle
def test_noisy_oracle_is_deterministic_per_seed_goal_and_round(robothow_small: Scenario) -> None:
    one = NoisyOracleBackend(robothow_small, drop=0.4, insert=0.5, seed=3)
    two = NoisyOracleBackend(robothow_small, drop=0.4, insert=0.5, seed=3)
    other = NoisyOracleBackend(robothow_small, drop=0.4, insert=0.5, seed=4)
    differs_by_seed = differs_by_round = 0
    for goal in GOALS:
        first = one.complete(ask(goal)).text
        assert first == two.complete(ask(goal)).text == one.complete(ask(goal, attempt=1)).text
        differs_by_seed += first != other.complete(ask(goal)).text
        differs_by_round += first != one.complete(ask(goal, round_=1)).text
    assert differs_by_seed >= len(GOALS) // 2
    assert differs_by_round >= len(GOALS) // 2


def test_noisy_oracle_without_noise_is_the_oracle(robothow_small: Scenario) -> None:
    exact = OracleBackend(robothow_small)
    quiet = NoisyOracleBackend(robothow_small, drop=0.0, insert=0.0, seed=9)
    for goal in GOALS:
        for round_ in (0, 1, 2):
            assert quiet.complete(ask(goal, round_)).text == exact.complete(ask(goal, round_)).text


def test_drop_everything_gives_an_empty_path(robothow_small: Scenario) -> None:
    backend = NoisyOracleBackend(robothow_small, drop=1.0, insert=0.0)
    for goal in GOALS:
        text = backend.complete(ask(goal)).text
        assert text == format_reply([], [], [])
        parsed = parse_reply(text)
        assert parsed.complete
        assert parsed.hints.empty


def test_insert_adds_actions_outside_the_optimal_plan(robothow_small: Scenario) -> None:
    backend = NoisyOracleBackend(robothow_small, drop=0.0, insert=1.0, seed=1)
    for goal in GOALS:
        optimal = backend.optimal(goal)
        noisy = path_of(backend, goal)
        assert is_subsequence(optimal, noisy)  # nothing dropped, order kept
        extra = Counter(noisy) - Counter(optimal)
        assert sum(extra.values()) == len(optimal)  # one wrong action per optimal action
        assert not set(extra) & set(optimal)


def test_feedback_rounds_have_less_noise(robothow_small: Scenario) -> None:
    backend = NoisyOracleBackend(robothow_small, drop=0.5, insert=1.0, seed=0)
    dropped = [0, 0, 0]
    inserted = [0, 0, 0]
    for goal in GOALS:
        optimal = Counter(backend.optimal(goal))
        for round_ in (0, 1, 2):
            noisy = Counter(path_of(backend, goal, round_))
            dropped[round_] += sum((optimal - noisy).values())
            inserted[round_] += sum((noisy - optimal).values())
    assert inserted[0] > inserted[1] > inserted[2]
    assert dropped[0] > dropped[1] > dropped[2]


@pytest.mark.parametrize(("drop", "insert"), [(-0.1, 0.3), (1.5, 0.3), (0.3, 11.0), (0.3, -1.0)])
def test_noisy_oracle_rejects_bad_rates(robowaiter: Scenario, drop: float, insert: float) -> None:
    with pytest.raises(BackendError, match="noisy-oracle"):
        NoisyOracleBackend(robowaiter, drop=drop, insert=insert)


# ---------------------------------------------------------------------------------- record / replay
def test_recording_then_replaying_the_loop(tmp_path: Path, robothow_small: Scenario) -> None:
    pool = example_pool(robothow_small)
    record_file = tmp_path / "replies.jsonl"
    inner = NoisyOracleBackend(robothow_small, drop=0.5, insert=0.5, seed=2)
    recorder = RecordingBackend(inner, record_file)
    assert recorder.name == "record:noisy-oracle"
    options = LoopOptions(feedback_rounds=2)
    recorded = [run_hbtp(robothow_small, goal, recorder, pool, options) for goal in GOALS[:8]]
    lines = [json.loads(line) for line in record_file.read_text(encoding="utf-8").splitlines()]
    asked = [p for loop in recorded for r in loop.rounds for p in r.prompts]
    assert len(lines) == len({p["key"] for p in asked})  # each distinct request once
    assert {entry["key"] for entry in lines} == {p["key"] for p in asked}
    assert all(set(entry) == {"key", "goal", "round", "reply"} for entry in lines)
    assert any(entry["round"] > 0 for entry in lines), "no feedback round was recorded"

    replay = ReplayBackend(record_file)
    for goal, before in zip(GOALS[:8], recorded, strict=True):
        again = run_hbtp(robothow_small, goal, replay, pool, options)
        assert again.outcome == before.outcome
        assert [r.replies for r in again.rounds] == [r.replies for r in before.rounds]
        assert [[p["key"] for p in r.prompts] for r in again.rounds] == [
            [p["key"] for p in r.prompts] for r in before.rounds
        ]
        assert again.result.expansions == before.result.expansions
    # the same request gives the byte-identical reply
    for entry in lines[:5]:
        assert replay.table[entry["key"]] == entry["reply"]


def test_recording_asks_each_request_once(tmp_path: Path) -> None:
    inner = Counting()
    path = tmp_path / "r.jsonl"
    recorder = RecordingBackend(inner, path)
    first = recorder.complete(ask("IsOpen_fridge"))
    second = recorder.complete(ask("IsOpen_fridge"))
    assert inner.calls == 1
    assert first.text == second.text == "Optimal Actions: Walk_fridge #1"
    assert second.meta == {"replayed": True}
    recorder.complete(ask("IsOpen_fridge", content="something else"))
    assert inner.calls == 2
    assert len(path.read_text(encoding="utf-8").splitlines()) == 2
    # a new recorder over the same file continues it without asking again
    again = RecordingBackend(Counting(), path)
    assert again.complete(ask("IsOpen_fridge")).text == first.text
    assert len(path.read_text(encoding="utf-8").splitlines()) == 2


def test_replay_of_an_unrecorded_request_names_goal_and_round(tmp_path: Path) -> None:
    path = tmp_path / "r.jsonl"
    RecordingBackend(Counting(), path).complete(ask("IsOpen_fridge"))
    replay = ReplayBackend(path)
    assert replay.complete(ask("IsOpen_fridge")).meta == {"replayed": True}
    with pytest.raises(BackendError, match=r"no reply for this prompt .*goal 'IsClose_fridge', round 2"):
        replay.complete(ask("IsClose_fridge", round_=2))


def test_corrupt_replay_file_names_the_line(tmp_path: Path) -> None:
    path = tmp_path / "r.jsonl"
    good = json.dumps({"key": "abc", "reply": "Optimal Actions: Walk_fridge"})
    for bad in ("{not json", json.dumps({"key": "abc"}), json.dumps(["key", "reply"])):
        path.write_text(f"{good}\n\n{bad}\n", encoding="utf-8")
        with pytest.raises(BackendError, match=rf"{path.name}:3: not a replay line"):
            ReplayBackend(path)
        with pytest.raises(BackendError, match=rf"{path.name}:3: not a replay line"):
            RecordingBackend(Counting(), path)


def test_replay_file_missing(tmp_path: Path) -> None:
    with pytest.raises(BackendError, match="does not exist"):
        ReplayBackend(tmp_path / "absent.jsonl")


# ---------------------------------------------------------------------------------- registry
def test_make_backend(robowaiter: Scenario, tmp_path: Path) -> None:
    assert isinstance(make_backend("oracle", robowaiter), OracleBackend)
    noisy = make_backend("noisy-oracle", robowaiter, BackendOptions(drop=0.1, insert=0.2, seed=5))
    assert isinstance(noisy, NoisyOracleBackend)
    assert (noisy.drop, noisy.insert, noisy.seed) == (0.1, 0.2, 5)
    recorded = make_backend("oracle", robowaiter, BackendOptions(record=str(tmp_path / "rec.jsonl")))
    assert isinstance(recorded, RecordingBackend)
    recorded.complete(ask("On_Coffee_Table1"))
    replay = make_backend(f"replay:{tmp_path / 'rec.jsonl'}", robowaiter)
    assert isinstance(replay, ReplayBackend)
    assert "Make_Coffee" in replay.complete(ask("On_Coffee_Table1")).text


@pytest.mark.parametrize("spec", ["gpt", "", "oracles", "Oracle", "local:x"])
def test_make_backend_rejects_unknown_specs(robowaiter: Scenario, spec: str) -> None:
    with pytest.raises(InputError, match="unknown LLM backend"):
        make_backend(spec, robowaiter)


def test_make_backend_replay_needs_a_file(robowaiter: Scenario, tmp_path: Path) -> None:
    with pytest.raises(InputError, match="replay needs a file"):
        make_backend("replay", robowaiter)
    with pytest.raises(BackendError, match="does not exist"):
        make_backend(f"replay:{tmp_path / 'none.jsonl'}", robowaiter)


# ---------------------------------------------------------------------------------- first replies
RECORDS = [
    Record("1", "IsOpen_fridge & IsClean_apple ", ("Walk_fridge", "Open_fridge"), ("Walk", "Open"), ("fridge",)),
    Record("2", "IsOpen_fridge & IsClean_apple", ("Walk_apple",), ("Walk",), ("apple",)),  # a later duplicate
]


def test_first_reply_answers_round_zero_from_the_records() -> None:
    backend = FirstReplyBackend(RECORDS)
    assert backend.name == "hints-from"
    reply = backend.complete(ask("IsClean_apple&IsOpen_fridge"))  # literal order and spacing do not matter
    assert reply.text == format_reply(["Walk_fridge", "Open_fridge"], ["Walk", "Open"], ["fridge"])
    assert reply.meta == {"replayed": True}
    with pytest.raises(BackendError, match="no recorded reply for goal 'IsOpen_window'"):
        backend.complete(ask("IsOpen_window"))
    for later in (ask("IsOpen_fridge & IsClean_apple", round_=1), ask("IsOpen_fridge & IsClean_apple", attempt=1)):
        with pytest.raises(BackendError, match="first round only"):
            backend.complete(later)


def test_first_reply_hands_later_rounds_on() -> None:
    then = Counting("Optimal Actions: Walk_apple")
    backend = FirstReplyBackend(RECORDS, then)
    assert backend.name == "hints-from+counting"
    assert "Walk_fridge" in backend.complete(ask("IsOpen_fridge & IsClean_apple")).text
    assert then.calls == 0
    reply = backend.complete(ask("IsOpen_fridge & IsClean_apple", round_=1))
    assert reply.text == "Optimal Actions: Walk_apple #1"
    assert reply.seconds == 0.5
    backend.complete(ask("IsOpen_fridge & IsClean_apple", attempt=1))
    assert then.calls == 2
