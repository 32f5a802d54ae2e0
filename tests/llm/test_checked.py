"""A taught model's plan made to run before it prunes (hbtp.llm.checked), alone and in the loop."""

from __future__ import annotations

import re
import time
from collections.abc import Callable
from pathlib import Path

from hbtp.deadline import Deadline
from hbtp.domains import Scenario
from hbtp.errors import BackendError
from hbtp.llm.backend import PromptStyle, Reply, Request
from hbtp.llm.backends.replay import RecordingBackend, ReplayBackend
from hbtp.llm.checked import MAX_STEPS, CheckedAnswer, checked_answer
from hbtp.llm.prompt import PromptOptions, build_request
from hbtp.llm.vocabulary import as_names
from hbtp.logic.execution import apply_actions
from hbtp.pipeline.loop import run_hbtp
from hbtp.pipeline.results import Outcome

Script = Callable[[Request], str]


class Taught:
    """A taught local model that answers by a script (and remembers what it was asked)."""

    name = "scripted"
    prompt_style = PromptStyle.COMPLETION
    taught = True

    def __init__(self, script: Script) -> None:
        self.script = script
        self.asked: list[Request] = []

    def complete(self, request: Request) -> Reply:
        self.asked.append(request)
        return Reply(self.script(request), seconds=0.01, completion_tokens=5)

    def close(self) -> None:
        pass


def _question(world: Scenario, goal: str) -> Request:
    options = PromptOptions(style=PromptStyle.COMPLETION, taught=True)
    return build_request(as_names(world.task), goal, [], options)


def _answer(world: Scenario, goal: str, backend: Taught) -> CheckedAnswer:
    return checked_answer(backend.complete, _question(world, goal), world.task, world.task.resolve_goal(goal))


def _runs_to_goal(world: Scenario, plan: tuple[str, ...], goal: str) -> bool:
    actions = [world.task.action(name) for name in plan]
    state, applied = apply_actions(world.task, actions)
    return applied == len(actions) and world.task.resolve_goal(goal).holds(state)


def test_an_action_that_cannot_run_yet_is_preceded_by_a_plan_to_its_preconditions(robowaiter: Scenario) -> None:
    goal = "On_Water_Table1"
    backend = Taught(lambda _: " MoveTo_Water, PickUp_Water, MoveTo_Table1, PutDown_Water_Table1\n\n")
    answer = _answer(robowaiter, goal, backend)
    assert answer.reached
    assert len(answer.calls) == 1
    assert answer.plan[0] == "Make_Water"  # the water must exist before the robot can go to it
    assert answer.plan[-4:] == ("MoveTo_Water", "PickUp_Water", "MoveTo_Table1", "PutDown_Water_Table1")
    assert _runs_to_goal(robowaiter, answer.plan, goal)
    assert answer.text == " " + ", ".join(answer.plan) + "\n\n"


def test_a_plan_that_stops_short_is_continued_with_only_actions_that_apply_offered_first(robowaiter: Scenario) -> None:
    goal = "On_Coffee_Table3"
    rest = " MoveTo_Coffee, PickUp_Coffee, MoveTo_Table3, PutDown_Coffee_Table3\n\n"
    backend = Taught(lambda request: rest if request.completion_prompt.endswith("Make_Coffee,") else " Make_Coffee\n\n")
    answer = _answer(robowaiter, goal, backend)
    assert answer.reached
    assert len(backend.asked) == 2
    first, second = backend.asked
    assert second.completion_prompt == first.completion_prompt + " Make_Coffee,"
    assert second.constraint is not None
    offered = re.search(r"^first ::= (.*)$", second.constraint.gbnf, re.M)
    assert offered is not None
    state, _ = apply_actions(robowaiter.task, [robowaiter.task.action("Make_Coffee")])
    applicable = {a.signature.underscored for a in robowaiter.task.actions if a.applicable(state)}
    assert set(re.findall(r'"([^"]+)"', offered.group(1))) == applicable
    assert _runs_to_goal(robowaiter, answer.plan, goal)


def test_an_answer_is_bounded_and_what_cannot_run_is_not_kept(robowaiter: Scenario) -> None:
    goal = "On_Coffee_Table3"
    for text in (" Fly_Moon\n\n", " Turn_AC_On\n\n", "", " MoveTo_Bar\n\n"):
        backend = Taught(lambda _, text=text: text)
        answer = _answer(robowaiter, goal, backend)
        assert len(backend.asked) <= MAX_STEPS
        assert not answer.reached
        assert _runs_to_goal(robowaiter, answer.plan, "On_Coffee_Table3") is False
        actions = [robowaiter.task.action(name) for name in answer.plan]
        assert apply_actions(robowaiter.task, actions)[1] == len(actions)  # what is kept runs


def test_the_loop_solves_without_feedback_when_the_checked_plan_reaches_the_goal(robowaiter: Scenario) -> None:
    goal = "On_Water_Table1"
    backend = Taught(lambda _: " MoveTo_Water, PickUp_Water, MoveTo_Table1, PutDown_Water_Table1\n\n")
    result = run_hbtp(robowaiter, goal, backend)
    assert result.outcome == Outcome.after(0)
    assert result.solved
    (first,) = result.rounds
    assert first.replies[-1].startswith(" Make_Water, MoveTo_Water")
    assert len(first.calls) == 1
    tree_actions = [robowaiter.task.actions[i] for i in result.result.solution]
    state, applied = apply_actions(robowaiter.task, tree_actions)
    assert applied == len(tree_actions)
    assert robowaiter.task.resolve_goal(goal).holds(state)


def test_a_backend_failure_while_checking_ends_the_asking_and_the_fallback_solves(robowaiter: Scenario) -> None:
    def failing(_: Request) -> str:
        raise BackendError("the model went away")

    result = run_hbtp(robowaiter, "On_Coffee_Table3", Taught(failing))
    assert result.outcome == Outcome.FALLBACK
    assert result.solved
    assert "went away" in result.rounds[0].error


def test_no_gap_is_searched_and_no_call_made_after_the_deadline(robowaiter: Scenario) -> None:
    """The first call is made (the loop checks the deadline before asking); after the deadline the
    reply's actions that need a gap are not kept and the model is not asked again."""
    deadline = Deadline(0.05)

    def late(_: Request) -> str:
        time.sleep(0.1)  # the call uses up the time
        return " MoveTo_Water, PickUp_Water, MoveTo_Table1, PutDown_Water_Table1\n\n"

    backend = Taught(late)
    world, goal = robowaiter, "On_Water_Table1"
    answer = checked_answer(
        backend.complete, _question(world, goal), world.task, world.task.resolve_goal(goal), deadline
    )
    assert len(backend.asked) == 1
    assert answer.plan == ()  # MoveTo_Water needs Make_Water first: no gap is searched any more
    assert not answer.reached


def test_a_recorded_taught_run_is_asked_as_taught_and_replays_to_the_same_tree(
    robowaiter: Scenario, tmp_path: Path
) -> None:
    """Recording keeps a taught model taught (its short prompt, its checked plan), and a replay of the
    file asks the same questions: every call is found and the tree is the same."""
    goal, record = "On_Coffee_Table3", tmp_path / "taught.jsonl"
    rest = " MoveTo_Coffee, PickUp_Coffee, MoveTo_Table3, PutDown_Coffee_Table3\n\n"
    inner = Taught(lambda request: rest if request.completion_prompt.endswith("Make_Coffee,") else " Make_Coffee\n\n")
    recorded = run_hbtp(robowaiter, goal, RecordingBackend(inner, record))
    assert all(request.taught for request in inner.asked)
    assert len(inner.asked) == 2  # the checked plan's continuation was recorded too
    replayer = ReplayBackend(record)
    assert replayer.taught
    replayed = run_hbtp(robowaiter, goal, replayer)
    assert replayed.outcome == recorded.outcome == Outcome.after(0)
    assert replayed.result.solution == recorded.result.solution
    assert replayed.rounds[0].replies == recorded.rounds[0].replies
