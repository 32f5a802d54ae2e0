"""Constrained decoding and no wasted calls: the reply's grammar and schema come from the task, a
request already answered at temperature 0 is never sent again, and every call is counted."""

from __future__ import annotations

import importlib.util
import json
import re
from dataclasses import dataclass, field, replace
from typing import Any

import pytest

from hbtp.domains import Scenario
from hbtp.errors import BackendError
from hbtp.llm.backend import PromptStyle, Reply, Request
from hbtp.llm.constrain import MAX_ACTIONS, SLACK, Bounds, constraint_of, reply_from_json, response_format
from hbtp.llm.pool import example_pool
from hbtp.llm.prompt import PromptOptions, build_request
from hbtp.pipeline import LoopOptions, RoundStatus, run_hbtp
from hbtp.pipeline import loop as loop_module
from hbtp.pipeline.results import REPEATED

GOAL = "IsIn_cutlets_fridge & IsClose_fridge"


def test_the_schema_pattern_admits_exactly_the_grounded_actions(scenario: Scenario) -> None:
    task = scenario.task
    schema = constraint_of(task).schema
    pattern = re.compile(schema["properties"]["optimal_actions"]["items"]["pattern"])
    names = {a.signature.underscored for a in task.actions}
    assert all(pattern.match(name) for name in names)
    objects = sorted(task.symbols)
    wrong = {f"{p}_{o}_{o}" for p in task.action_predicates for o in objects[:5]} | {"Fly_apple", "Walk_nowhere"}
    assert not any(pattern.match(name) for name in wrong - names)


def test_the_grammar_is_small_composed_and_bounded(robothow: Scenario) -> None:
    constraint = constraint_of(robothow.task, Bounds(5, 3, 4))
    assert len(constraint.gbnf) < 20_000  # 7,329 action names are not listed one by one
    root = constraint.gbnf.splitlines()[0]
    assert '(", " action){0,4}' in root
    assert '(", " predicate){0,2}' in root
    assert '(", " object){0,3}' in root
    defined = {line.split(" ::= ")[0] for line in constraint.gbnf.splitlines()}
    without_literals = re.sub(r'"(?:[^"\\]|\\.)*"', "", constraint.gbnf)
    used = set(re.findall(r"(?<![\"\w-])([a-z][a-z0-9-]*)(?![\"\w-])", without_literals))
    assert used <= defined
    assert constraint.schema["properties"]["optimal_actions"]["maxItems"] == 5


def test_a_taught_reply_is_constrained_to_the_plan_line(robothow_small: Scenario) -> None:
    """A taught model owes the plan alone: its grammar has the action list and the end, no other line,
    and a taught request carries that grammar."""
    full = constraint_of(robothow_small.task).gbnf.splitlines()[0]
    plan_only = constraint_of(robothow_small.task, path_only=True).gbnf.splitlines()[0]
    assert "Vital" in full
    assert not {"Vital", "predicate", "object"} & set(re.findall(r"\w+", plan_only))
    assert plan_only.startswith('root ::= " " action (", " action)')
    assert plan_only.endswith(" end")
    taught = build_request(robothow_small.task, GOAL, [], PromptOptions(style=PromptStyle.COMPLETION, taught=True))
    assert taught.taught
    assert taught.completion_prompt == f"Goals: {GOAL}\nOptimal Actions:"
    assert taught.constraint is not None
    assert taught.constraint.gbnf.splitlines()[0] == plan_only
    # no system message: the vocabulary, demonstrations and rules are a base model's
    assert [m.role for m in taught.messages] == ["user"]
    base = build_request(robothow_small.task, GOAL, [], PromptOptions(style=PromptStyle.COMPLETION))
    assert [m.role for m in base.messages] == ["system", "user"]
    assert "[Condition Predicates]" in base.messages[0].content


def test_bounds_follow_the_demonstrations_shown() -> None:
    assert Bounds.after([(3, 2, 2), (6, 4, 1)]) == Bounds(6 + SLACK, 4 + SLACK, 2 + SLACK)
    assert Bounds.after([(40, 1, 1)]).actions == MAX_ACTIONS
    assert Bounds.after([]) == Bounds()


def test_a_json_answer_becomes_the_three_lines() -> None:
    text = json.dumps({"optimal_actions": ["Walk_a"], "vital_action_predicates": ["Walk"], "vital_objects": ["a"]})
    assert reply_from_json(text) == "Optimal Actions: Walk_a\nVital Action Predicates: Walk\nVital Objects: a"
    assert reply_from_json("Optimal Actions: Walk_a") is None
    assert reply_from_json('{"optimal_actions": 3}') is None
    assert response_format(constraint_of_small())["json_schema"]["strict"] is True


def constraint_of_small() -> object:
    from hbtp.domains.scenarios import load_scenario

    return constraint_of(load_scenario("robothow-small").task)


def test_the_constraint_does_not_change_the_replay_key(robothow_small: Scenario) -> None:
    pool = example_pool(robothow_small)
    free = build_request(robothow_small.task, GOAL, pool, PromptOptions(constrain=False))
    constrained = build_request(robothow_small.task, GOAL, pool, PromptOptions())
    assert free.constraint is None
    assert constrained.constraint is not None
    assert free.key() == constrained.key()
    assert free.sent_key(PromptStyle.COMPLETION) != constrained.sent_key(PromptStyle.COMPLETION)
    chat_only = replace(constrained, messages=())
    assert chat_only.sent_key(PromptStyle.COMPLETION) == constrained.sent_key(PromptStyle.COMPLETION)
    assert chat_only.sent_key(PromptStyle.CHAT) != constrained.sent_key(PromptStyle.CHAT)


@dataclass
class Scripted:
    """A completion backend that answers from a script and records what it was sent."""

    answers: list[str]
    name: str = "scripted"
    sent: list[Request] = field(default_factory=list)

    @property
    def prompt_style(self) -> PromptStyle:
        return PromptStyle.COMPLETION

    def complete(self, request: Request) -> Reply:
        self.sent.append(request)
        text = self.answers[min(len(self.sent), len(self.answers)) - 1]
        return Reply(text, seconds=0.5, completion_tokens=10, meta={"constrained": request.constraint is not None})

    def close(self) -> None:
        pass


def test_a_retry_with_an_unchanged_prompt_is_not_sent(robothow_small: Scenario) -> None:
    # A reply with a missing line but no unknown name: the retry prompt would be the same text.
    backend = Scripted([" Walk_cutlets, RightGrab_cutlets"])
    loop = run_hbtp(robothow_small, GOAL, backend, example_pool(robothow_small), LoopOptions(feedback_rounds=0))
    assert len(backend.sent) == 1
    first = loop.rounds[0]
    assert len(first.calls) == 1
    assert first.calls[0]["seconds"] == 0.5
    assert first.calls[0]["constrained"]
    assert loop.to_dict()["llm_calls"] == 1


def test_a_round_asking_what_was_answered_is_skipped(robothow_small: Scenario) -> None:
    # No pool: a feedback round shows no more demonstrations, so it would ask the very same thing.
    backend = Scripted([" Walk_cutlets\nVital Action Predicates: Walk\nVital Objects: cutlets"])
    loop = run_hbtp(robothow_small, GOAL, backend, (), LoopOptions(feedback_rounds=3))
    assert len(backend.sent) == 1
    assert [str(r.status) for r in loop.rounds] == ["unsolvable", "skipped"]
    assert loop.rounds[1].error == REPEATED
    assert loop.solved
    assert str(loop.outcome) == "fallback"


def test_a_new_blacklist_entry_makes_a_new_prompt(robothow_small: Scenario) -> None:
    backend = Scripted([" Walk_nowhere\nVital Action Predicates: Walk\nVital Objects: cutlets"])
    loop = run_hbtp(robothow_small, GOAL, backend, (), LoopOptions(feedback_rounds=0, grammar_retries=2))
    assert len(backend.sent) == 2  # the second has the blacklist; the third would repeat the second
    assert "Walk_nowhere" in backend.sent[1].completion_prompt
    assert loop.rounds[0].calls[0]["unknown"] == 1


def test_progress_says_what_is_happening(robothow_small: Scenario) -> None:
    said: list[str] = []
    backend = Scripted([" Walk_cutlets\nVital Action Predicates: Walk\nVital Objects: cutlets"])
    run_hbtp(robothow_small, GOAL, backend, (), LoopOptions(feedback_rounds=1, progress=said.append))
    assert said[0] == "round 1 of 2"
    assert said[1] == "asking scripted"
    assert said[2].startswith("answered: 10 tokens in 0.50 s, 20.0 tokens/s")
    assert any(s.startswith("planning in ") for s in said)
    assert said[-1].startswith("fallback")


HAVE_XLLAMACPP = importlib.util.find_spec("xllamacpp") is not None


@pytest.mark.llm
@pytest.mark.skipif(not HAVE_XLLAMACPP, reason="xllamacpp is not installed")
def test_the_local_model_answers_within_the_grammar(robothow_small: Scenario) -> None:
    from hbtp.llm.backends.local import LocalBackend
    from hbtp.llm.grammar import check_reply
    from hbtp.llm.parse import parse_reply

    options = PromptOptions(style="completion", examples=2)
    request = build_request(robothow_small.task, GOAL, example_pool(robothow_small), options)
    assert request.constraint is not None
    broken = replace(request, constraint=replace(request.constraint, gbnf="root ::= ("), max_tokens=8)
    with LocalBackend(threads=1) as backend:
        reply = backend.complete(request)
        refused = backend.complete(broken)
    check = check_reply(parse_reply("Optimal Actions:" + reply.text), robothow_small.task)
    assert reply.meta["constrained"]
    assert check.clean
    assert reply.meta["finish_reason"] == "stop"
    assert not refused.meta["constrained"]  # refused: answered as free text, and not sent again
    assert not backend.constrain


def test_a_json_answer_cut_off_by_the_token_limit_keeps_what_it_gave() -> None:
    text = '{\n  "optimal_actions": [\n    "Walk_fridge",\n    "Open_fridge",\n    "Pl'
    assert (
        reply_from_json(text) == "Optimal Actions: Walk_fridge, Open_fridge\nVital Action Predicates: \nVital Objects: "
    )


# A failed feedback round does not search its space again.
WAITER_GOAL = "On_Coffee_Table1"  # the full-space fallback solves it in milliseconds
MISSING = "Optimal Actions: Walk_Coffee\nVital Action Predicates: Walk\nVital Objects: Coffee"


def test_a_failed_feedback_round_does_not_search_again(robowaiter: Scenario, monkeypatch: pytest.MonkeyPatch) -> None:
    searches: list[int] = []
    search = getattr(loop_module, "search")  # noqa: B009 (not re-exported: mypy)

    def counting(*args: Any, **kwargs: Any) -> Any:
        searches.append(1)
        return search(*args, **kwargs)

    monkeypatch.setattr(loop_module, "search", counting)

    class Failing:
        name = "failing"
        prompt_style = PromptStyle.CHAT

        def __init__(self) -> None:
            self.calls = 0

        def complete(self, request: Request) -> Reply:
            self.calls += 1
            if self.calls == 1:
                return Reply(MISSING)
            raise BackendError("HTTP 503")

        def close(self) -> None:
            pass

    loop = run_hbtp(robowaiter, WAITER_GOAL, Failing(), example_pool(robowaiter), LoopOptions(grammar_retries=0))
    assert len(searches) == 1  # round 0 only: round 1 got no answer, so its space is round 0's
    assert loop.outcome.label == "fallback"
    assert [r.status for r in loop.rounds][1] is RoundStatus.SKIPPED
    assert loop.to_dict()["rounds"][1]["status"] == "skipped"
    assert loop.rounds[1].error == "HTTP 503"
