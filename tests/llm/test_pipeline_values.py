"""The typed values around the HBTP loop: outcomes, round statuses, prompt styles, the reply block,
hints from a plan, the growing action space and the one noise model."""

from __future__ import annotations

import random

import pytest

from hbtp.datasets import load_dataset, read_text, write_text
from hbtp.datasets.reply import TITLES, format_reply
from hbtp.domains import Scenario
from hbtp.errors import InputError
from hbtp.llm import grammar
from hbtp.llm.backend import PromptStyle, Reply, Request
from hbtp.llm.backends.first_reply import FirstReplyBackend
from hbtp.llm.backends.local import LocalBackend
from hbtp.llm.backends.oracle import OracleBackend
from hbtp.llm.backends.replay import RecordingBackend, ReplayBackend
from hbtp.llm.parse import hints_from_record, hints_reply, parse_reply
from hbtp.llm.prompt import COMPLETION_MAX_TOKENS, PromptOptions
from hbtp.llm.vocabulary import vocabulary_of
from hbtp.logic.names import names_of
from hbtp.pipeline import LoopOptions, Outcome, RoundStatus, run_hbtp
from hbtp.pipeline.results import Ending
from hbtp.planning import Hints, resolve_hints
from hbtp.planning.hints import PathNoise, pruned_action_space, seeded_random
from hbtp.planning.oracle import oracle_hints
from hbtp.planning.result import Status


# ---------------------------------------------------------------------------------- outcomes
@pytest.mark.parametrize("label", ["NF", "1F", "2F", "12F", "fallback", "failed"])
def test_outcome_labels_round_trip(label: str) -> None:
    outcome = Outcome.parse(label)
    assert outcome.label == str(outcome) == label
    assert (outcome.feedback_rounds is not None) == (outcome.ending is Ending.ROUND)


def test_outcome_values() -> None:
    assert Outcome.after(0).label == "NF"
    assert Outcome.after(3) == Outcome.parse("3F") != Outcome.after(2)
    assert Outcome.FALLBACK.feedback_rounds is None
    assert Outcome.FAILED.ending is Ending.FAILED
    with pytest.raises(InputError, match="unknown loop outcome"):
        Outcome.parse("solved")
    with pytest.raises(ValueError, match="exactly when an LLM round solved"):
        Outcome(Ending.FALLBACK, 1)


@pytest.mark.parametrize("status", list(Status))
def test_every_search_status_is_a_round_status(status: Status) -> None:
    assert RoundStatus.of(status).value == str(RoundStatus.of(status)) == status.value


# ---------------------------------------------------------------------------------- prompt styles
def test_each_backend_declares_its_prompt_style(robowaiter: Scenario, tmp_path: object) -> None:
    assert LocalBackend.prompt_style is PromptStyle.COMPLETION
    oracle = OracleBackend(robowaiter)
    assert oracle.prompt_style is PromptStyle.CHAT
    assert FirstReplyBackend([]).prompt_style is PromptStyle.CHAT
    assert ReplayBackend.prompt_style is PromptStyle.CHAT

    class Base:
        name = "base"
        prompt_style = PromptStyle.COMPLETION

        def complete(self, request: Request) -> Reply:
            return Reply("Optimal Actions: Make_Coffee\nVital Action Predicates: Make\nVital Objects: Coffee")

        def close(self) -> None:
            pass

    assert FirstReplyBackend([], Base()).prompt_style is PromptStyle.COMPLETION
    assert RecordingBackend(Base(), f"{tmp_path}/r.jsonl").prompt_style is PromptStyle.COMPLETION


def test_the_loop_uses_the_backends_style_unless_one_is_chosen(robowaiter: Scenario) -> None:
    asked: list[Request] = []

    class Base:
        name = "base"
        prompt_style = PromptStyle.COMPLETION

        def complete(self, request: Request) -> Reply:
            asked.append(request)
            return Reply(" Make_Coffee\nVital Action Predicates: Make\nVital Objects: Coffee")

        def close(self) -> None:
            pass

    # Free text (no constraint), so the completion style shows in its own token budget.
    free = LoopOptions(prompt=PromptOptions(constrain=False))
    assert str(run_hbtp(robowaiter, "Exists_Coffee", Base(), (), free).outcome) == "NF"
    assert asked[-1].max_tokens == COMPLETION_MAX_TOKENS
    chat = LoopOptions(prompt=PromptOptions(style="chat", constrain=False))
    assert run_hbtp(robowaiter, "Exists_Coffee", Base(), (), chat).solved
    assert asked[-1].max_tokens == PromptOptions().max_tokens
    assert PromptOptions(style="completion").style is PromptStyle.COMPLETION
    with pytest.raises(InputError, match="unknown prompt style"):
        PromptOptions(style="poem")


# ---------------------------------------------------------------------------------- the reply block
def test_one_reply_block_for_records_prompts_oracles_and_the_grammar_checker(robowaiter: Scenario) -> None:
    record = load_dataset("table2_robowaiter_50")[1]
    block = record.reply_block()
    assert block == format_reply(record.optimal_actions, record.vital_predicates, record.vital_objects)
    assert [line.split(":")[0] for line in block.splitlines()] == list(TITLES.values())
    assert block in write_text([record])
    assert read_text(write_text([record])) == [record]
    assert parse_reply(block).hints == hints_from_record(record)
    oracle = OracleBackend(robowaiter).complete(Request((), "", goal=record.goal)).text
    assert parse_reply(oracle).hints == hints_from_record(record)
    missing = grammar.check_reply(parse_reply("Optimal Actions: Make_Water"), robowaiter.task).missing_sections
    assert missing == (TITLES["predicates"], TITLES["objects"])


def test_hints_from_a_plan(robowaiter: Scenario) -> None:
    task = robowaiter.task
    goal = task.resolve_goal("On_Water_Table1")
    hints = oracle_hints(task, goal)
    plan = [task.action(name).index for name in hints.path]
    assert Hints.from_plan(task, plan) == hints
    assert hints.predicates == ("Make", "MoveTo", "PickUp", "PutDown")
    assert hints.objects == ("Water", "Table1")
    assert parse_reply(hints_reply(hints)).hints == hints


def test_the_space_of_several_rounds_only_grows(robowaiter: Scenario) -> None:
    task = robowaiter.task
    names = names_of(task)
    first = Hints().grown_by(Hints(("Make(Coffee)",), (), ()), names)
    second = Hints(("MoveTo(Bar)", "Fly(Moon)"), ("PickUp", "Teleport"), ("Water", "Moon"))
    grown = first.grown_by(second, names)
    assert grown.path == ("MoveTo(Bar)",)  # names the world does not know are left out
    assert set(grown.predicates) == {"Make", "MoveTo", "PickUp"}
    assert set(grown.objects) == {"Coffee", "Bar", "Water"}
    spaces = [pruned_action_space(task, resolve_hints(task, h)) for h in (first, second, grown)]
    assert set(spaces[0]) | set(spaces[1]) <= set(spaces[2])


# ---------------------------------------------------------------------------------- noise and caches
def test_path_noise() -> None:
    path, wrong = list(range(10)), [100, 101]
    assert PathNoise().apply(path, wrong, random.Random(0)) == path
    assert PathNoise(0.0, 0.0).apply(path, wrong, random.Random(0)) == []
    noisy = PathNoise(1.0, 0.5).apply(path, wrong, random.Random(0))
    assert [a for a in noisy if a < 100] == path
    assert len(noisy) == 15
    assert PathNoise(1.0, 0.5).apply(path, [], random.Random(0)) == path
    assert PathNoise(0.5, 1.0).scaled(0.5) == PathNoise(0.75, 0.5)
    assert seeded_random("a", 1).random() == seeded_random("a", 1).random() != seeded_random("a", 2).random()


def test_per_task_tables_live_with_the_task(robowaiter: Scenario) -> None:
    from hbtp.logic.tables import TaskTable

    assert vocabulary_of(robowaiter.task) is vocabulary_of(robowaiter.task)
    # the module declares the table's kind; the values live with the task, not in the module
    assert isinstance(grammar._MATCHERS, TaskTable)
    assert getattr(vocabulary_of, "cache_info", None) is None
