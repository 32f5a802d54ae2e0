"""Instruction in, checked goal out (issue 11, item 1): the prompt and grammar, the checks, the
feedback rounds, the instruction oracle, ``hbtp plan --instruction`` and ``hbtp bench instructions``."""

from __future__ import annotations

import importlib.util
import json
import re
import time
from collections.abc import Sequence
from dataclasses import replace
from pathlib import Path
from typing import Any

import pytest

from hbtp.bench.instructions import InstructionsBench, holds_by_name, normal_form, run_instructions
from hbtp.cli import main
from hbtp.datasets.instructions import load_instructions
from hbtp.domains import Scenario, load_scenario
from hbtp.domains.words import words_for
from hbtp.errors import BackendError, InputError
from hbtp.llm.backend import PromptStyle, Reply, Request
from hbtp.llm.backends.oracle import InstructionOracle
from hbtp.llm.backends.registry import make_goal_backend
from hbtp.llm.goal_prompt import (
    Connectives,
    Example,
    goal_constraint,
    goal_reply,
    goal_request,
    mentioned_objects,
    similar_examples,
)
from hbtp.logic.goals import parse_goal
from hbtp.pipeline.instruct import InstructOptions, check_goal, false_refusal, goal_from_instruction, instruction_pool


@pytest.fixture(scope="module")
def virtualhome() -> Scenario:
    return load_scenario("virtualhome")


class Scripted:
    """A backend that answers with the given replies in turn and keeps the requests."""

    name = "scripted"
    prompt_style = PromptStyle.COMPLETION

    def __init__(self, replies: Sequence[str]) -> None:
        self.replies = list(replies)
        self.requests: list[Request] = []

    def complete(self, request: Request) -> Reply:
        self.requests.append(request)
        return Reply(self.replies[min(len(self.requests), len(self.replies)) - 1], seconds=0.5)

    def close(self) -> None:
        return None


# --------------------------------------------------------------------------------- the checks
@pytest.mark.parametrize(
    ("goal", "objection"),
    [
        ("IsOpen_fridge & ~IsOpen_fridge", "asks for a literal and its negation"),
        ("IsOpen_fridge & IsClose_fridge", "IsClose_fridge and IsOpen_fridge cannot hold together"),
        ("IsIn_milk_fridge & IsOpen_frige", "not a goal: unknown object 'frige'"),
        ("IsIn_milk_fridge &", "not a goal: malformed goal"),
        ("~IsStanding_self", "never true: ~IsStanding_self"),
    ],
)
def test_impossible_goals_are_refused_with_the_reason(virtualhome: Scenario, goal: str, objection: str) -> None:
    verdict = check_goal(virtualhome, goal)
    assert any(objection in o for o in verdict.objections), verdict
    assert not verdict.doubtful


def test_a_goal_no_plan_reaches_is_refused_and_asked_again() -> None:
    """Holding the vacuum cup and having it on table 2: each can be made true, never both (putting
    it down ends the holding); the answer asked again is chosen."""
    robowaiter = load_scenario("robowaiter")
    stuck = "Holding_VacuumCup & On_VacuumCup_Table2"
    assert check_goal(robowaiter, stuck).objections == (
        "no plan makes Holding_VacuumCup and On_VacuumCup_Table2 hold together",
    )
    assert check_goal(robowaiter, f"{stuck} | On_Coffee_Table1").objections == ()  # one way is enough
    backend = Scripted([stuck, "On_VacuumCup_Table2"])
    choice = goal_from_instruction(robowaiter, "Carry the vacuum cup over to table 2.", backend)
    assert choice.goal == "On_VacuumCup_Table2"
    assert len(backend.requests) == 2


def test_a_goal_that_already_holds_is_doubtful_and_a_good_one_passes(virtualhome: Scenario) -> None:
    holding = check_goal(virtualhome, "IsClose_fridge")
    assert holding.doubtful
    assert holding.objections == ("it already holds at the start",)
    assert check_goal(virtualhome, "IsIn_milk_fridge & ~IsOpen_fridge | IsOn_milk_kitchentable").objections == ()


# ---------------------------------------------------------------------- prompt and grammar
def test_objects_are_recognised_in_plain_words(virtualhome: Scenario) -> None:
    found = mentioned_objects(virtualhome.task, ["Put two apples on the kitchen table, then turn on the TV."])
    assert {"kitchentable", "tv"} <= found
    robowaiter = load_scenario("robowaiter").task
    assert "Table1" in mentioned_objects(robowaiter, ["Bring a coffee to table 1"])


def test_connectives_need_words_for_them() -> None:
    assert Connectives.licensed_by("Put the apple in the fridge or on the table") == Connectives(
        True, False, False, False
    )
    assert Connectives.licensed_by("Close the fridge and don't leave the TV on") == Connectives(
        False, True, False, True
    )
    assert Connectives.licensed_by("Put the milk in the fridge") == Connectives(False, False, False, False)
    assert Connectives.licensed_by("Turn off the TV, then the lamp", required=True) == Connectives(
        False, False, True, True
    )


def test_two_object_literals_pair_each_object_with_the_nearest_one_named_after_it(virtualhome: Scenario) -> None:
    from hbtp.llm.goal_prompt import nearest_pairs, object_positions

    task = virtualhome.task
    text = "Put the plate on the nightstand and the book on the desk."
    positions = object_positions(task, text)
    offered = nearest_pairs([a for a in task.atoms if a.args and all(x in positions for x in a.args)], positions)
    pairs = {a.args for a in offered if len(a.args) == 2}
    assert ("plate", "nightstand") in pairs
    assert ("book", "desk") in pairs
    assert ("book", "nightstand") not in pairs
    assert ("plate", "desk") not in pairs


def test_the_schema_accepts_every_goal_of_the_dataset_and_nothing_else() -> None:
    for name in ("robowaiter", "virtualhome"):
        task = load_scenario(name).task
        atoms = [a for a in task.atoms if a.predicate in task.predicates]
        pattern = re.compile(goal_constraint(atoms, task.categories).schema["properties"]["goal"]["pattern"])
        for record in load_instructions(name):
            assert pattern.fullmatch(record.goal), record.goal
        assert not pattern.fullmatch("IsOpen_fridge & IsOpen_unicorn")
        assert not pattern.fullmatch("IsOpen_fridge |")


def test_the_request_shows_similar_examples_last_and_the_rejected_goals(virtualhome: Scenario) -> None:
    pool = [Example("Switch on the TV.", "IsSwitchedOn_tv"), Example("Put the milk in the fridge.", "IsIn_milk_fridge")]
    assert similar_examples("put milk into the fridge please", pool, 2)[-1].goal == "IsIn_milk_fridge"
    request = goal_request(virtualhome.task, "Put the milk in the fridge", pool)
    assert request.completion_prompt.endswith("Instruction: Put the milk in the fridge\nGoals:")
    assert request.temperature == 0.0
    assert request.constraint is not None
    assert '"|"' not in request.constraint.gbnf
    assert '"~"' not in request.constraint.gbnf  # no word for "or" or "not" in the instruction
    assert goal_reply(" IsIn_milk_fridge\n\nInstruction: x") == "IsIn_milk_fridge"
    assert goal_reply('{"goal": "IsIn_milk_fridge | IsOn_milk_sofa"}') == "IsIn_milk_fridge | IsOn_milk_sofa"


# --------------------------------------------------------------------- the feedback rounds
def test_a_refused_goal_is_fed_back_and_the_next_one_chosen(virtualhome: Scenario) -> None:
    backend = Scripted(["IsOpen_fridge & IsClose_fridge", "IsIn_milk_fridge & IsClose_fridge"])
    choice = goal_from_instruction(virtualhome, "Put the milk in the fridge and close it", backend)
    assert choice.goal == "IsIn_milk_fridge & IsClose_fridge"
    assert len(choice.attempts) == 2
    assert choice.llm_seconds == 1.0
    again = backend.requests[1]
    assert "Not: IsOpen_fridge & IsClose_fridge (IsClose_fridge and IsOpen_fridge cannot hold together)" in (
        again.completion_prompt
    )
    assert again.temperature > 0
    assert "cannot hold together" in again.messages[-1].content


def test_a_model_that_keeps_proposing_impossible_goals_gives_up_with_the_reasons(virtualhome: Scenario) -> None:
    backend = Scripted(["IsOpen_fridge & ~IsOpen_fridge"])
    choice = goal_from_instruction(virtualhome, "open the fridge", backend, options=InstructOptions(rounds=2))
    assert choice.goal is None
    assert len(backend.requests) == 3
    assert "no acceptable goal after 3 answer(s)" in choice.message
    assert "asks for a literal and its negation" in choice.message
    garbage = goal_from_instruction(virtualhome, "open the fridge", Scripted(["", "%%%"]), options=InstructOptions(1))
    assert garbage.goal is None
    assert "no goal in the reply" in garbage.message


def test_an_already_true_goal_is_refused_not_used(virtualhome: Scenario) -> None:
    backend = Scripted(["IsClose_fridge", "IsOpen_fridge"])
    choice = goal_from_instruction(virtualhome, "make sure the fridge is closed", backend)
    assert choice.goal is None
    assert choice.holding == "IsClose_fridge"
    assert len(backend.requests) == 1  # the asking ends: a goal asked for again would drift from the meaning
    assert choice.message == (
        "the instruction asks for IsClose_fridge, which already holds at the start: there is nothing to do"
    )


def test_empty_and_unrelated_instructions_are_refused_before_asking(virtualhome: Scenario) -> None:
    backend = Scripted(["IsIn_milk_fridge"])
    with pytest.raises(InputError, match="empty instruction"):
        goal_from_instruction(virtualhome, "   ", backend)
    with pytest.raises(InputError, match="names no object of 'virtualhome' and is like no known one"):
        goal_from_instruction(virtualhome, "sing me a song about the moon", backend, instruction_pool(virtualhome))
    assert not backend.requests


def test_the_instruction_oracle_answers_the_dataset_and_nothing_else(virtualhome: Scenario) -> None:
    record = load_instructions("virtualhome")[0]
    oracle = InstructionOracle(virtualhome)
    assert oracle.complete(Request((), "", instruction=record.instructions[1].upper())).text == record.goal
    with pytest.raises(BackendError, match="knows only the instructions"):
        oracle.complete(Request((), "", instruction="do a backflip"))
    with pytest.raises(InputError, match="answers plans, not goals"):
        make_goal_backend("noisy-oracle", virtualhome)


# ------------------------------------------------------------------------------- the CLI
def _run(capsys: pytest.CaptureFixture[str], *argv: str) -> tuple[int, str, str]:
    code = main(list(argv))
    captured = capsys.readouterr()
    return code, captured.out, captured.err


def test_plan_from_an_instruction_prints_and_records_the_goal(
    capsys: pytest.CaptureFixture[str], tmp_path: Path
) -> None:
    text = "Put the milk in the fridge and don't leave the fridge open."
    code, out, err = _run(capsys, "plan", "-s", "virtualhome", "-i", text, "--llm", "oracle", "-p", "obtea", "--json")
    assert code == 0, err
    record = json.loads(out)
    assert record["goal"] == "IsIn_milk_fridge & ~IsOpen_fridge"
    assert record["instruction"]["goal"] == "IsIn_milk_fridge & ~IsOpen_fridge"
    assert record["instruction"]["attempts"][0]["objections"] == []
    code, out, _ = _run(
        capsys, "plan", "-s", "virtualhome", "-i", text, "--llm", "oracle", "-o", str(tmp_path / "t.json")
    )
    assert code == 0
    assert out.startswith("goal: IsIn_milk_fridge & ~IsOpen_fridge  (from the instruction: 1 answer(s)")
    assert _run(capsys, "run", str(tmp_path / "t.json"))[0] == 0


def test_plan_instruction_errors_are_one_line_with_exit_2(capsys: pytest.CaptureFixture[str]) -> None:
    code, _, err = _run(capsys, "plan", "-s", "virtualhome", "-i", "x", "-g", "IsOpen_fridge")
    assert code == 2
    assert "not both" in err
    code, _, err = _run(capsys, "plan", "-s", "virtualhome", "-i", "Juggle three pineapples.", "--llm", "oracle")
    assert code == 2
    assert "names no object of 'virtualhome' and is like no known one" in err
    assert len(err.strip().splitlines()) == 1
    code, _, err = _run(capsys, "plan", "-s", "virtualhome", "-i", "Put the milk on the TV.", "--llm", "oracle")
    assert code == 2
    assert "knows only the instructions" in err
    assert len(err.strip().splitlines()) == 1


def test_the_attempts_are_in_the_json_when_no_goal_is_acceptable(
    capsys: pytest.CaptureFixture[str], monkeypatch: pytest.MonkeyPatch
) -> None:
    from hbtp.cli import plan_run

    monkeypatch.setattr(plan_run, "make_goal_backend", lambda *_: Scripted(["IsOpen_fridge & ~IsOpen_fridge"]))
    code, out, err = _run(capsys, "plan", "-s", "virtualhome", "-i", "Open the fridge.", "--json")
    assert code == 2
    record = json.loads(out)
    assert record["status"] == "no-goal"
    assert len(record["instruction"]["attempts"]) == 4
    assert record["instruction"]["attempts"][0]["objections"] == [
        "IsOpen_fridge & ~IsOpen_fridge asks for a literal and its negation"
    ]
    assert "no acceptable goal after 4 answer(s)" in err


def test_recorded_instruction_exchanges_replay(capsys: pytest.CaptureFixture[str], tmp_path: Path) -> None:
    replies = tmp_path / "replies.jsonl"
    text = "Put the milk in the fridge and don't leave the fridge open."
    code, _, err = _run(capsys, "plan", "-s", "virtualhome", "-i", text, "--llm", "oracle", "--record", str(replies))
    assert code == 0, err
    assert replies.read_text(encoding="utf-8").strip()
    code, out, err = _run(capsys, "plan", "-s", "virtualhome", "-i", text, "--llm", f"replay:{replies}", "--json")
    assert code == 0, err
    assert json.loads(out)["goal"] == "IsIn_milk_fridge & ~IsOpen_fridge"


def test_bench_instructions_with_the_oracle(capsys: pytest.CaptureFixture[str], tmp_path: Path) -> None:
    code, out, _ = _run(
        capsys, "bench", "instructions", "--llm", "oracle", "-s", "robowaiter", "--limit", "3", "--no-lacking",
        "-o", str(tmp_path),
    )  # fmt: skip
    assert code == 0
    rows = [json.loads(line) for line in (tmp_path / "results.jsonl").read_text(encoding="utf-8").splitlines()]
    assert len(rows) == 6
    assert all(r["exact"] and r["equivalent"] and r["reached"] for r in rows)
    assert "| robowaiter | all | 6 | 100.0% |" in out
    assert (tmp_path / "report.md").exists()


def test_scoring_counts_mutex_equivalent_goals_separately(virtualhome: Scenario) -> None:
    closed, not_open = parse_goal("IsClose_fridge"), parse_goal("~IsOpen_fridge")
    assert normal_form(virtualhome, closed, False) != normal_form(virtualhome, not_open, False)
    assert normal_form(virtualhome, closed, True) == normal_form(virtualhome, not_open, True)
    task = virtualhome.task
    assert holds_by_name(task, not_open, task.initial_state)
    assert not holds_by_name(task, parse_goal("IsOpen_fridge"), task.initial_state)


def test_bench_records_a_backend_failure_and_goes_on(tmp_path: Path) -> None:
    class Refusing(Scripted):
        def complete(self, request: Request) -> Reply:
            raise BackendError("server down")

    bench = InstructionsBench(("robowaiter",), "refusing", limit=2, phrasings=1, lacking=False)
    summary = run_instructions(bench, lambda scenario: Refusing([]), tmp_path)
    rows = [json.loads(line) for line in (tmp_path / "results.jsonl").read_text(encoding="utf-8").splitlines()]
    assert [r["message"] for r in rows] == ["server down", "server down"]
    assert summary["scenarios"]["robowaiter"]["all"]["well_formed_pct"] == 0.0


HAVE_XLLAMACPP = importlib.util.find_spec("xllamacpp") is not None


@pytest.mark.llm
@pytest.mark.skipif(not HAVE_XLLAMACPP, reason="xllamacpp is not installed (the local extra)")
def test_the_local_model_reads_a_plain_instruction(virtualhome: Scenario) -> None:
    backend: Any = make_goal_backend("local", virtualhome)
    try:
        choice = goal_from_instruction(virtualhome, "Switch on the TV.", backend, instruction_pool(virtualhome))
    finally:
        backend.close()
    assert choice.goal == "IsSwitchedOn_tv"


def test_an_openai_compatible_server_gets_the_goal_schema_and_its_json_is_read(virtualhome: Scenario) -> None:
    pytest.importorskip("openai")
    from test_pipeline import FakeOpenAI

    from hbtp.llm.backends.openai_backend import OpenAIBackend

    server = FakeOpenAI(lambda path, payload: '{"goal": "IsIn_milk_fridge & ~IsOpen_fridge"}')
    backend = OpenAIBackend(model="fake", base_url=server.base_url, api_key="test", timeout=5)
    try:
        text = "Put the milk in the fridge and don't leave the fridge open."
        choice = goal_from_instruction(virtualhome, text, backend, instruction_pool(virtualhome))
    finally:
        backend.close()
        server.stop()
    assert choice.goal == "IsIn_milk_fridge & ~IsOpen_fridge"
    sent = server.requests[0]["json"]
    assert sent["response_format"]["json_schema"]["name"] == "goal"
    pattern = re.compile(sent["response_format"]["json_schema"]["schema"]["properties"]["goal"]["pattern"])
    assert pattern.fullmatch("IsIn_milk_fridge & ~IsOpen_fridge")
    assert sent["messages"][-1]["content"] == text


@pytest.mark.llm
def test_one_model_load_serves_the_instruction_and_the_hints_and_t_bounds_it(
    capsys: pytest.CaptureFixture[str], monkeypatch: pytest.MonkeyPatch
) -> None:
    pytest.importorskip("xllamacpp")
    from hbtp.llm.backends import local

    starts: list[object] = []
    start_server = local.start_server

    def counted(*args: Any, **kwargs: Any) -> Any:
        starts.append(args)
        return start_server(*args, **kwargs)

    monkeypatch.setattr(local, "start_server", counted)
    code, out, err = _run(
        capsys, "plan", "-s", "virtualhome", "-i", "Put the chicken in the microwave.", "--llm", "local", "--json"
    )
    assert code == 0, err
    record = json.loads(out)
    assert record["instruction"]["goal"] == "IsIn_chicken_microwave"
    assert record["auto"]["asked_llm"] is False  # an easy task: hints would not pay, the model is not asked again
    assert len(starts) == 1
    # -t bounds the instruction step too: too little time is a time limit (exit 1), in one line.
    started = time.perf_counter()
    code, _, err = _run(capsys, "plan", "-s", "virtualhome", "-i", "Put the chicken in the microwave.", "-t", "0.5")
    assert time.perf_counter() - started < 0.5 + 4.0  # (loading the model and its adapter is not interrupted)
    assert code == 1
    assert err.startswith("hbtp: error: time limit of 0.5 s reached while")
    assert err.count("\n") == 1


# --------------------------------------------------------------------------------- a taught model
class Taught(Scripted):
    """A scripted model that was taught the world: it is asked the instruction alone."""

    taught = True


def test_a_taught_model_is_asked_the_instruction_alone_with_every_literal_offered(virtualhome: Scenario) -> None:
    backend = Taught(["IsIn_milk_fridge & IsClose_fridge"])
    text = "Store the carton of milk in the refrigerator and shut it."
    choice = goal_from_instruction(virtualhome, text, backend, instruction_pool(virtualhome))
    assert choice.goal == "IsIn_milk_fridge & IsClose_fridge"
    request = backend.requests[0]
    assert request.taught
    assert request.completion_prompt == f"Instruction: {text}\nGoals:"
    assert request.constraint is not None
    grammar = request.constraint.gbnf
    assert '"Unknown: "' in grammar  # a refusal is allowed
    assert '" | " term' in grammar  # so are alternatives and negations, whatever the words
    assert "natom" in grammar


def test_a_taught_refusal_is_the_error(virtualhome: Scenario) -> None:
    backend = Taught(["Unknown: piano"])
    choice = goal_from_instruction(virtualhome, "put the piano in the fridge", backend)
    assert choice.goal is None
    assert choice.message == "the instruction names piano, which 'virtualhome' does not have"
    assert len(backend.requests) == 1


@pytest.mark.parametrize(
    ("instruction", "refused", "why"),
    [
        ("put the carton of milk in the fridge", "milk", "which 'virtualhome' has (milk)"),  # a name of the world's
        ("put the chips on the desk", "chips", "which 'virtualhome' has (chips)"),
        ("store the milk in the refrigerator", "fridge", "which the instruction does not say"),
        ("put the milk in the piano", "grand piano", "which the instruction does not say"),
    ],
)
def test_a_taught_refusal_that_cannot_stand_is_overruled(
    virtualhome: Scenario, instruction: str, refused: str, why: str
) -> None:
    """A refusal must name what the instruction says and the world lacks: otherwise the model is
    asked again, refusals no longer offered, and its goal is used (here even where that goal stands
    in for the piano the world lacks, which the next test refuses)."""
    backend = Taught([f"Unknown: {refused}", "IsIn_milk_fridge"])
    choice = goal_from_instruction(virtualhome, instruction, backend, options=InstructOptions(refuse_lacking=False))
    assert choice.goal == "IsIn_milk_fridge"
    assert choice.attempts[0].objections == (f"refused {refused!r}, {why}",)
    first, second = backend.requests
    assert first.constraint is not None
    assert second.constraint is not None
    assert '"Unknown: "' in first.constraint.gbnf
    assert '"Unknown: "' not in second.constraint.gbnf


def test_false_refusal_knows_the_last_word_of_a_name(virtualhome: Scenario) -> None:
    """The syrup is the chocolate syrup; a thing the instruction says and no name of the world ends
    with may be refused ("milk piano" is no name, though each of its words is said)."""
    assert false_refusal(virtualhome, "put the syrup in the fridge", "syrup") is not None
    assert false_refusal(virtualhome, "put the piano in the fridge", "piano") is None
    assert false_refusal(virtualhome, "put the grand piano in the fridge", "grand piano") is None
    assert false_refusal(virtualhome, "put the milk in the piano", "milk piano") is None


@pytest.mark.parametrize(
    ("instruction", "answer", "goal"),
    [
        # a literal about what the instruction never names is left out
        ("It's stuffy in here, could you get the AC running?", "Active_AC & IsClean_Chairs", "Active_AC"),
        ("Could you brew a fresh cup of coffee?", "Exists_Coffee & On_NFCJuice_CoffeeStation", "Exists_Coffee"),
        # a literal about a named object and one the instruction never names
        ("Wipe table 1, please.", "IsClean_Table1 & On_Coffee_Table1", "IsClean_Table1"),
        # in each conjunction of a disjunction
        (
            "Hold the milk, or else turn the temperature down.",
            "Holding_Milk | Low_ACTemperature & Holding_VacuumCup",
            "Holding_Milk | Low_ACTemperature",
        ),
        # a literal repeating another but for an object not named where the other's is
        ("Table 2 would like the NFC juice.", "On_NFCJuice_Table2 & On_NFCJuice_Table1", "On_NFCJuice_Table2"),
        (
            "Leave a yogurt at bright table 6 and switch on the AC.",
            "Active_AC & On_Yogurt_Table1 & On_Yogurt_BrightTable6",
            "Active_AC & On_Yogurt_BrightTable6",
        ),
        # named by a synonym, a number or in the plural: kept
        (
            "Switch on the air conditioning and wipe table 1.",
            "Active_AC & IsClean_Table1",
            "Active_AC & IsClean_Table1",
        ),
        (
            "A coffee on tables 1 and 2, please.",
            "On_Coffee_Table1 & On_Coffee_Table2",
            "On_Coffee_Table1 & On_Coffee_Table2",
        ),
        # nothing named at all: nothing to judge by, the answer stands
        ("Make it cooler in here.", "Active_AC & Low_ACTemperature", "Active_AC & Low_ACTemperature"),
    ],
)
def test_a_taught_models_literals_about_what_the_instruction_never_names_are_left_out(
    robowaiter: Scenario, instruction: str, answer: str, goal: str
) -> None:
    choice = goal_from_instruction(robowaiter, instruction, Taught([answer]))
    assert choice.goal == goal
    assert choice.attempts[0].reply == answer  # the model's own answer is kept in the record
    kept = goal_from_instruction(robowaiter, instruction, Taught([answer]), options=InstructOptions(drop_unsaid=False))
    assert kept.goal == answer


def test_the_words_of_a_world_tell_which_objects_a_text_names(robowaiter: Scenario) -> None:
    words = words_for(robowaiter)
    assert words.named_in("Turn on the air conditioner") >= {"AC"}
    assert words.named_in("the AC, please") >= {"AC"}
    assert words.named_in("Switch on the AC") >= {"AC"}  # "on" + "ac" is not a plural of "on"
    assert words.named_in("the AD calcium milk and the milky drink") == {"ADMilk", "MilkDrink"}  # not Milk
    # a numbered name goes on with a list of numbers, not with a count of the thing named next
    assert words.named_in("the tables 1 and 2") >= {"Table1", "Table2"}
    assert words.named_in("tables 1, 2 and 3") == {"Table1", "Table2", "Table3"}
    assert words.named_in("bright table 3 or 6") == {"BrightTable3", "BrightTable6"}
    assert words.named_in("table one or two") == {"Table1", "Table2"}
    assert "Table2" not in words.named_in("table 1 and 2 yogurts")
    assert "Table1" in words.named_in("wipe the first table")
    assert "Table1" not in words.named_in("put it on their table")
    assert "NFCJuice" in words.named_in("the not-from-concentrate juice")
    assert "self" not in words.named_in("you")  # the robot is never named


def test_a_taught_conjunction_that_leaves_out_a_named_object_is_continued(robowaiter: Scenario) -> None:
    """ "the first table" names Table1 by the world's words only (not by its spelling): a taught model's
    goal without it is asked to go on with a literal over it, in the same taught prompt."""
    backend = Taught(["Active_AC", "IsClean_Table1"])
    choice = goal_from_instruction(robowaiter, "Switch on the AC and wipe the first table.", backend)
    assert set((choice.goal or "").split(" & ")) == {"Active_AC", "IsClean_Table1"}
    first, second = backend.requests
    assert second.taught
    assert second.completion_prompt == first.completion_prompt + " Active_AC &"
    assert second.constraint is not None
    assert "Table1" in second.constraint.gbnf
    assert "IsClean_Floor" not in second.constraint.gbnf  # only literals over the missing object
    # nothing is missing: nothing more is asked
    done = Taught(["Active_AC & IsClean_Table1"])
    goal = goal_from_instruction(robowaiter, "Switch on the AC and wipe the first table.", done).goal
    assert set((goal or "").split(" & ")) == {"Active_AC", "IsClean_Table1"}
    assert len(done.requests) == 1


@pytest.mark.parametrize(
    ("instruction", "answer", "refused"),
    [
        ("put the guitar on the desk", "IsOn_chips_desk", "guitar"),  # the chips stand in for the guitar
        # the chips stand in for the guitar beside the book: their literal is kept to be refused
        ("put the book and the guitar on the desk", "IsOn_book_desk & IsOn_chips_desk", "guitar"),
        ("leave the guitars on the kitchen table", "IsOn_chips_kitchentable", "guitars"),
        ("Store the milk in the fridge and shut the door", "IsIn_milk_fridge & IsClose_fridge", None),
        ("set the dish bowl on the kitchen table for my cereal", "IsOn_dishbowl_kitchentable", None),
        ("fan the stove and put the chips on the desk", "IsOn_chips_desk", None),  # "fan": no thing
        ("put the milk in the piano", "IsIn_milk_fridge", "piano"),
        # a twin of a named literal is kept to be judged: the chips stand in for the guitar
        ("put the milk and the guitar in the fridge", "IsIn_milk_fridge & IsIn_chips_fridge", "guitar"),
    ],
)
def test_a_goal_standing_in_for_a_thing_the_world_lacks_is_refused(
    virtualhome: Scenario, instruction: str, answer: str, refused: str | None
) -> None:
    """A thing of the words file the world lacks, said as a thing, and a goal about an object the
    instruction never names in its place: refused with what it lacks; said beside a goal about what
    the instruction names (the fridge's door, the cereal a bowl is for): the goal stands."""
    for backend in (Taught([answer]), Scripted([answer])):
        choice = goal_from_instruction(virtualhome, instruction, backend, instruction_pool(virtualhome))
        if refused is None:
            assert choice.goal == answer, choice.message
            assert choice.lacking is None
        else:
            assert choice.goal is None
            assert choice.lacking == refused
            assert choice.message == f"the instruction names {refused}, which 'virtualhome' does not have"
    off = goal_from_instruction(
        virtualhome, instruction, Taught([answer]), options=InstructOptions(refuse_lacking=False)
    )
    assert off.goal == answer


class Refuser(Taught):
    """A taught model that refuses what the instruction names and the world lacks, else answers
    the dataset's goal."""

    def __init__(self, scenario: Scenario) -> None:
        super().__init__([])
        self.words, self.oracle = words_for(scenario), InstructionOracle(scenario)

    def complete(self, request: Request) -> Reply:
        self.requests.append(request)
        lacking = self.words.lacking_in(request.instruction)
        return Reply(f"Unknown: {lacking[0]}") if lacking else self.oracle.complete(request)


def test_bench_instructions_asks_about_things_the_world_lacks(tmp_path: Path) -> None:
    """One instruction per record about a thing the world lacks: refused for it is exact; a goal
    or a failure is not; they are a kind of their own, not in ``all``; the same every run."""
    robowaiter = load_scenario("robowaiter")
    bench = InstructionsBench(("robowaiter",), "refuser", limit=4, phrasings=1)
    summary = run_instructions(bench, lambda scenario: Refuser(scenario), tmp_path / "a")
    rows = [json.loads(line) for line in (tmp_path / "a" / "results.jsonl").read_text(encoding="utf-8").splitlines()]
    lacking = [r for r in rows if r["kind"] == "lacking"]
    assert len(lacking) == 4
    words = words_for(robowaiter)
    for row in lacking:
        thing = row["intended"].removeprefix("Unknown: ")
        assert words.lacking_in(row["instruction"]), row
        assert thing.split()[-1] in row["instruction"].lower()
        assert row["exact"], row
        assert row["reached"], row
        assert row["produced"] is None, row
    assert summary["scenarios"]["robowaiter"]["all"]["instructions"] == 4
    assert summary["scenarios"]["robowaiter"]["lacking"]["exact_pct"] == 100.0

    class Failing(Scripted):
        def complete(self, request: Request) -> Reply:
            raise BackendError("server down")

    run_instructions(bench, lambda scenario: Failing([]), tmp_path / "b")
    failed = [json.loads(line) for line in (tmp_path / "b" / "results.jsonl").read_text(encoding="utf-8").splitlines()]
    assert [r["instruction"] for r in failed if r["kind"] == "lacking"] == [r["instruction"] for r in lacking]
    # An instruction about nothing the world has is refused before the model is asked.
    for row in failed:
        before = row["message"].startswith("the instruction names ")
        assert row["message"] == "server down" or before, row
        assert row["exact"] == (row["kind"] == "lacking" and before), row
    assert sum(row["message"] == "server down" for row in failed if row["kind"] == "lacking") >= 2
    none = run_instructions(replace(bench, lacking=False), lambda scenario: Refuser(scenario), tmp_path / "c")
    assert "lacking" not in none["scenarios"]["robowaiter"]


def test_an_instruction_about_only_what_the_world_lacks_is_refused_for_it_before_asking() -> None:
    robowaiter = load_scenario("robowaiter")
    backend = Scripted(["On_Coffee_Table1"])
    choice = goal_from_instruction(
        robowaiter, "The electric fan should be prepared.", backend, instruction_pool(robowaiter)
    )
    assert choice.goal is None
    assert choice.lacking == "electric fan"
    assert choice.message == "the instruction names electric fan, which 'robowaiter' does not have"
    assert not backend.requests
    with pytest.raises(InputError, match="names no object of 'robowaiter'"):
        goal_from_instruction(robowaiter, "Juggle three pineapples.", backend, instruction_pool(robowaiter))


def test_no_row_shows_the_model_its_own_records_phrasings(tmp_path: Path) -> None:
    """A base model's demonstrations leave the asked record out, for its own rows and for the row
    about a thing the world lacks built on it."""
    bench = InstructionsBench(("robowaiter",), "scripted", limit=3, phrasings=1)
    backends: list[Scripted] = []

    def backend(scenario: Scenario) -> Scripted:
        backends.append(Scripted(["Goals: Active_AC"]))
        return backends[-1]

    run_instructions(bench, backend, tmp_path)
    rows = [json.loads(line) for line in (tmp_path / "results.jsonl").read_text(encoding="utf-8").splitlines()]
    records = {record.id: record for record in load_instructions("robowaiter")}
    asked = {row["instruction"]: records[row["id"].removesuffix("/lacking")] for row in rows}
    requests = [request for made in backends for request in made.requests]
    assert {request.instruction for request in requests} <= set(asked)  # some are refused before asking
    lacking = {row["instruction"] for row in rows if row["kind"] == "lacking"}
    assert lacking & {request.instruction for request in requests}
    for request in requests:
        shown = request.completion_prompt + "".join(message.content for message in request.messages)
        own = asked[request.instruction]
        assert not [text for text in own.instructions if text in shown.replace(request.instruction, "")], own.id
        assert "Instruction:" in shown  # demonstrations are shown at all
