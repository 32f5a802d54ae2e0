"""The prompt: the scenario's vocabulary, few-shot retrieval, the chat and completion shapes, retries
and reflective feedback, and how large the prompts are."""

from __future__ import annotations

import dataclasses
import logging
import re
import statistics

import pytest

from hbtp.datasets import load_dataset
from hbtp.datasets.records import Record
from hbtp.domains import Scenario, load_scenario
from hbtp.llm.backend import Request
from hbtp.llm.pool import example_pool
from hbtp.llm.prompt import (
    COMPLETION_MAX_TOKENS,
    CONSTRAINED_MAX_TOKENS,
    Feedback,
    PromptOptions,
    build_request,
    estimate_tokens,
    feedback_request,
    retrieve_examples,
    retry_request,
)
from hbtp.llm.vocabulary import ANY, vocabulary_of
from hbtp.logic.names import names_of
from helpers import SCENARIOS

log = logging.getLogger(__name__)

TEST_SETS = {
    "robowaiter": "table2_robowaiter_50",
    "virtualhome": "table2_virtualhome_50",
    "robothow-small": "table2_robothow_small_50",
    "robothow": "table2_robothow_50",
}
COMPLETION_BOUND = 1500
CHAT_BOUND = 2500
GOAL = "IsIn_cutlets_fridge & IsClose_fridge"


def record(number: int, goal: str, actions: tuple[str, ...] = ("Walk_apple",)) -> Record:
    return Record(str(number), goal, actions, ("Walk",), ("apple",))


def label_set(entry: str) -> list[str]:
    return re.findall(r"<([A-Z_]+)>", entry)


# ---------------------------------------------------------------------------------- vocabulary
def test_vocabulary_lists_every_action_predicate_with_its_cost(scenario: Scenario) -> None:
    task = scenario.task
    vocabulary = vocabulary_of(task)
    assert len(vocabulary.action_predicates) == len(task.action_predicates)
    for predicate, entry in zip(task.action_predicates, vocabulary.action_predicates, strict=True):
        costs = {a.cost for a in task.actions if a.predicate == predicate}
        expected = f"{min(costs)}" if len(costs) == 1 else f"{min(costs)}-{max(costs)}"
        assert entry.startswith(predicate + "_") or entry.startswith(predicate + " "), entry
        assert entry.endswith(f" ({expected})"), (entry, costs)


def test_vocabulary_categories_cover_the_argument_values(scenario: Scenario) -> None:
    task = scenario.task
    vocabulary = vocabulary_of(task)
    categories = dict(vocabulary.categories)
    assert categories, "no category is used"
    # every label in an entry is listed with its members (ANY stands for "no single category")
    for entry in (*vocabulary.condition_predicates, *vocabulary.action_predicates):
        for label in label_set(entry):
            assert label == ANY or label in categories, (entry, label)
    for label, members in categories.items():
        assert members, label
        assert set(members) <= task.symbols, label
        assert list(members) == sorted(members), label
    # every value an action's argument takes is a member of the category shown for it
    for predicate, entry in zip(task.action_predicates, vocabulary.action_predicates, strict=True):
        parts = re.findall(r"<[A-Z_]+>|[^_<>]+", entry.rsplit(" (", 1)[0])[1:]
        for action in (a for a in task.actions if a.predicate == predicate):
            for part, value in zip(parts, action.objects, strict=True):
                if part.startswith("<") and part != f"<{ANY}>":
                    assert value in categories[part.strip("<>")], (action.name, part)
                elif not part.startswith("<"):
                    assert value == part, (action.name, part)
    # the names a reply may use (kept with the task's action names, which the checker reads)
    names = names_of(task)
    assert names.signatures == {a.signature for a in task.actions}
    assert set(names.action_predicates) == set(task.action_predicates)
    assert set(task.objects) <= names.symbols


def test_robothow_vocabulary_entries(robothow: Scenario) -> None:
    vocabulary = vocabulary_of(robothow.task)
    assert "IsOn_<GRABBABLE>_<SURFACE>" in vocabulary.condition_predicates
    assert "IsIn_<GRABBABLE>_<CONTAINER>" in vocabulary.condition_predicates
    assert "IsRightHandEmpty_self" in vocabulary.condition_predicates
    assert "Walk_<ALL_OBJECTS> (15)" in vocabulary.action_predicates
    assert "RightPutIn_<GRABBABLE>_<CONTAINER> (10)" in vocabulary.action_predicates
    categories = dict(vocabulary.categories)
    assert {"apple", "milk", "cutlets"} <= set(categories["GRABBABLE"])
    assert "fridge" in categories["CONTAINER"]
    assert "kitchentable" in categories["SURFACE"]
    assert len(categories["ALL_OBJECTS"]) == len(robothow.task.objects)


def test_robowaiter_vocabulary_entries(robowaiter: Scenario) -> None:
    vocabulary = vocabulary_of(robowaiter.task)
    assert "On_<ITEM>_<PLACE>" in vocabulary.condition_predicates
    assert "Make_<MAKEABLE> (5)" in vocabulary.action_predicates
    assert any(e.startswith("PutDown_") and e.endswith("(8-20)") for e in vocabulary.action_predicates)
    assert set(dict(vocabulary.categories)["MAKEABLE"]) == {"Coffee", "Dessert", "Water"}


# ---------------------------------------------------------------------------------- retrieval
def test_retrieval_uses_every_goal_literal() -> None:
    pool = [
        record(1, "IsClean_apple & IsOpen_fridge"),
        record(2, "IsClean_apple & IsOpen_microwave"),
        record(3, "IsOpen_window"),
        record(4, "IsSwitchedOn_tv"),  # shares only the second literal of the goal
        record(5, "IsOpen_door"),
    ]
    chosen = [r.id for r in retrieve_examples("IsClean_apple & IsSwitchedOn_tv", pool, 3)]
    assert "4" in chosen
    assert set(chosen) == {"1", "2", "4"}
    # the literal order of the goal does not matter
    assert [r.id for r in retrieve_examples("IsSwitchedOn_tv & IsClean_apple", pool, 3)] == chosen


def test_retrieval_prefers_the_same_literals_over_a_longer_mention() -> None:
    pool = [
        record(1, "IsOn_apple_kitchentable & IsOpen_fridge & IsSwitchedOn_tv"),
        record(2, "IsOpen_fridge"),
    ]
    assert [r.id for r in retrieve_examples("IsOpen_fridge", pool, 2)] == ["2", "1"]


def test_retrieval_is_deterministic_and_bounded(robothow_small: Scenario) -> None:
    pool = example_pool(robothow_small)
    first = retrieve_examples(GOAL, pool, 5)
    assert len(first) == 5
    assert first == retrieve_examples(GOAL, list(pool), 5)
    assert retrieve_examples(GOAL, pool, 0) == []
    assert retrieve_examples(GOAL, [], 5) == []
    assert len(retrieve_examples(GOAL, pool, 10_000)) == len(pool)
    # the best match shares both literals
    assert {"IsIn_cutlets_fridge", "IsClose_fridge"} <= {p.strip() for p in first[0].goal.split("&")}


def test_a_two_literal_test_goal_retrieves_the_second_literal_too(robothow_small: Scenario) -> None:
    pool = example_pool(robothow_small)
    chosen = retrieve_examples(GOAL, pool, 5, exclude_goal=True)
    assert any("IsClose_fridge" in r.goal for r in chosen)
    assert any("IsIn_cutlets" in r.goal or "cutlets" in r.goal for r in chosen)


def test_exclude_same_goal() -> None:
    pool = [record(1, "IsOpen_fridge & IsClean_apple"), record(2, "IsOpen_fridge"), record(3, "IsClean_apple")]
    assert retrieve_examples("IsClean_apple&IsOpen_fridge", pool, 1)[0].id == "1"
    chosen = retrieve_examples("IsClean_apple & IsOpen_fridge", pool, 3, exclude_goal=True)
    assert [r.id for r in chosen] == ["2", "3"]
    # the prompt honours it too
    options = PromptOptions(examples=3, exclude_same_goal=True)
    request = build_request(load_scenario("robothow-small").task, "IsOpen_fridge & IsClean_apple", pool, options)
    assert "Goals: IsOpen_fridge & IsClean_apple\nOptimal" not in request.messages[0].content
    assert request.completion_prompt.count("Goals:") == 3


# ---------------------------------------------------------------------------------- build_request
def test_chat_request(robothow_small: Scenario) -> None:
    pool = example_pool(robothow_small)
    request = build_request(robothow_small.task, GOAL, pool, PromptOptions(examples=4), scenario="robothow-small")
    system, user = request.messages
    assert (system.role, user.role) == ("system", "user")
    for section in ("[Condition Predicates]", "[Action Predicates]", "[Objects]", "[Few-shot Demonstrations]"):
        assert section in system.content
    assert "IsIn_<GRABBABLE>_<CONTAINER>" in system.content
    assert "Walk_<ALL_OBJECTS> (15)" in system.content
    assert "<CAN_OPEN> = [fridge, kitchencabinet, microwave, window]" in system.content
    assert system.content.count("Goals:") == 4
    assert system.content.count("Optimal Actions: ") == 4
    assert user.content == f"Goals: {GOAL}"
    assert (request.goal, request.scenario, request.round, request.attempt) == (GOAL, "robothow-small", 0, 0)
    assert request.max_tokens == PromptOptions().max_tokens
    assert "\n\n" in request.stop
    # the closest demonstration comes first in the system message
    closest = retrieve_examples(GOAL, pool, 4)[0]
    demos = system.content.split("[Few-shot Demonstrations]\n", 1)[1]
    assert demos.startswith(f"Goals: {closest.goal.strip()}")
    without_objects = build_request(robothow_small.task, GOAL, pool, PromptOptions(examples=4, include_objects=False))
    assert "[Objects]\n<" in system.content
    assert "[Objects]\n" not in without_objects.messages[0].content
    assert "<CAN_OPEN> = [" not in without_objects.messages[0].content


def test_completion_request_ends_with_the_question_after_the_closest_demonstration(robothow_small: Scenario) -> None:
    pool = example_pool(robothow_small)
    options = PromptOptions(examples=3, style="completion", exclude_same_goal=True)
    request = build_request(robothow_small.task, GOAL, pool, options)
    prompt = request.completion_prompt
    assert prompt.endswith(f"Goals: {GOAL}\nOptimal Actions:")
    assert prompt.count("Goals:") == 4
    assert "[Condition Predicates]" not in prompt  # a base model gets demonstrations only
    examples = retrieve_examples(GOAL, pool, 3, exclude_goal=True)
    blocks = prompt.split("\n\n")
    assert blocks[-2].startswith(f"Goals: {examples[0].goal.strip()}\nOptimal Actions: ")
    assert blocks[0].startswith(f"Goals: {examples[-1].goal.strip()}\n")
    assert request.max_tokens == CONSTRAINED_MAX_TOKENS  # the grammar ends the reply; this guards a runaway
    free = build_request(robothow_small.task, GOAL, pool, dataclasses.replace(options, constrain=False))
    assert free.max_tokens == COMPLETION_MAX_TOKENS


def test_zero_examples(robowaiter: Scenario) -> None:
    request = build_request(robowaiter.task, "On_Coffee_Table1", example_pool(robowaiter), PromptOptions(examples=0))
    assert request.completion_prompt == "Goals: On_Coffee_Table1\nOptimal Actions:"
    assert "Goals:" not in request.messages[0].content


def test_avoid_list_reaches_both_shapes(robowaiter: Scenario) -> None:
    request = build_request(robowaiter.task, "On_Coffee_Table1", [], avoid=["Fly_Coffee", "Teleport"])
    line = "Do not use (not in this domain): Fly_Coffee, Teleport"
    assert line in request.messages[1].content
    assert line in request.completion_prompt


# ---------------------------------------------------------------------------------- prompt sizes
def test_prompt_sizes(scenario: Scenario) -> None:
    """estimate_tokens of the chat (system + user) and completion prompts over the scenario's test set."""
    pool = example_pool(scenario)
    chat_sizes, completion_sizes = [], []
    for test in load_dataset(TEST_SETS[scenario.name]):
        chat = build_request(scenario.task, test.goal, pool, PromptOptions(exclude_same_goal=True))
        completion = build_request(
            scenario.task, test.goal, pool, PromptOptions(style="completion", examples=5, exclude_same_goal=True)
        )
        chat_sizes.append(sum(estimate_tokens(m.content) for m in chat.messages))
        completion_sizes.append(estimate_tokens(completion.completion_prompt))
    log.info(
        "prompt sizes %s: chat mean %.0f max %d; completion (5 examples) mean %.0f max %d",
        scenario.name,
        statistics.mean(chat_sizes),
        max(chat_sizes),
        statistics.mean(completion_sizes),
        max(completion_sizes),
    )
    assert max(completion_sizes) < COMPLETION_BOUND
    assert max(chat_sizes) < CHAT_BOUND
    assert min(completion_sizes) > 30  # five demonstrations are really there
    assert min(chat_sizes) > min(completion_sizes)  # the chat prompt adds the scenario


def test_estimate_tokens() -> None:
    assert estimate_tokens("") == 0
    assert estimate_tokens("Walk_apple, RightGrab_apple") == 7  # Walk _ apple , RightGrab _ apple
    assert estimate_tokens("cost 15") == 2


# ---------------------------------------------------------------------------------- retries and feedback
@pytest.fixture(scope="module")
def first_request() -> Request:
    scenario = load_scenario("robothow-small")
    return build_request(scenario.task, GOAL, example_pool(scenario), PromptOptions(examples=3, style="completion"))


def test_retry_request_carries_the_blacklist(first_request: Request) -> None:
    reply = "Optimal Actions: Teleport_cutlets_fridge"
    retry = retry_request(
        first_request, reply, ["Teleport_cutlets_fridge is not in the domain"], ["Teleport_cutlets_fridge"]
    )
    assert (retry.round, retry.attempt, retry.goal) == (0, 1, first_request.goal)
    assert retry.messages[: len(first_request.messages)] == first_request.messages
    assistant, user = retry.messages[-2:]
    assert (assistant.role, assistant.content) == ("assistant", reply)
    assert user.role == "user"
    assert "Teleport_cutlets_fridge is not in the domain" in user.content
    assert "Do not use (not in this domain): Teleport_cutlets_fridge" in user.content
    assert retry.completion_prompt.endswith(
        f"Do not use (not in this domain): Teleport_cutlets_fridge\nGoals: {GOAL}\nOptimal Actions:"
    )
    again = retry_request(retry, "Optimal Actions: Fly_fridge", ["Fly_fridge is not in the domain"],
                          ["Teleport_cutlets_fridge", "Fly_fridge"])  # fmt: skip
    assert again.attempt == 2
    assert again.completion_prompt.count("Do not use") == 1  # replaced, not repeated
    assert "Do not use (not in this domain): Fly_fridge, Teleport_cutlets_fridge\n" in again.completion_prompt
    assert again.completion_prompt.count("Goals:") == first_request.completion_prompt.count("Goals:")
    assert again.key() != retry.key() != first_request.key()


def test_feedback_request(first_request: Request) -> None:
    scenario = load_scenario("robothow-small")
    pool = example_pool(scenario)
    paths = [["Walk_fridge", "Open_fridge", "RightPutIn_cutlets_fridge", "Close_fridge"], ["Close_fridge"]]
    reply = "Optimal Actions: Walk_fridge, Close_fridge"
    missing = Feedback(tuple(map(tuple, paths)), ("PlugIn", "RightGrab"), ("cutlets",))
    feedback = feedback_request(first_request, reply, missing, pool, PromptOptions(examples=3))
    assert (feedback.round, feedback.attempt) == (first_request.round + 1, 0)
    assert feedback.messages[-2].content == reply
    text = feedback.messages[-1].content
    assert feedback.messages[-1].role == "user"
    assert "1. Walk_fridge, Open_fridge, RightPutIn_cutlets_fridge, Close_fridge" in text
    assert "2. Close_fridge" in text
    assert "Action predicates left out: PlugIn, RightGrab" in text
    assert "Objects left out: cutlets" in text
    assert feedback.completion_prompt.endswith(f"Goals: {GOAL}\nOptimal Actions:")
    assert feedback.completion_prompt.count("Goals:") == 6  # 3 + 2 more demonstrations for a base model
    second = feedback_request(feedback, reply, Feedback(), pool, PromptOptions(examples=3))
    assert second.round == 2
    assert second.completion_prompt.count("Goals:") == 8  # 3 + 2 per feedback round
    assert "left out" not in second.messages[-1].content
    assert "longest partial plans" not in second.messages[-1].content


@pytest.mark.parametrize("name", SCENARIOS)
def test_every_test_goal_gets_a_prompt(name: str) -> None:
    scenario = load_scenario(name)
    pool = example_pool(scenario)
    for test in load_dataset(TEST_SETS[name])[:10]:
        request = build_request(scenario.task, test.goal, pool, PromptOptions(examples=5, exclude_same_goal=True))
        assert request.messages[-1].content.startswith("Goals: ")
        assert request.completion_prompt.endswith("Optimal Actions:")
