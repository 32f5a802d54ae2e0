"""Abridged labels (hbtp.train.abridge): the check gives back the optimal plan, action for action,
and a world that is not grounded still prunes to a space that holds it."""

from __future__ import annotations

import pytest

from hbtp.domains.pruned import PrunedWorld
from hbtp.domains.scenarios import Scenario, ScenarioOptions
from hbtp.llm.backend import PromptStyle, Reply, Request
from hbtp.llm.checked import checked_answer
from hbtp.llm.prompt import PromptOptions, build_request, taught_reply
from hbtp.llm.spelling import Spelling
from hbtp.llm.vocabulary import as_names
from hbtp.logic.execution import apply_actions
from hbtp.pipeline.loop import run_hbtp
from hbtp.pipeline.results import Outcome
from hbtp.train.abridge import abridged
from hbtp.train.example_set import make_examples
from hbtp.train.examples import ExampleKind, sample_records


class _Taught:
    """A taught model that always gives ``reply``; its adapter leaves ``filled`` predicates to the check."""

    name = "scripted"
    prompt_style = PromptStyle.COMPLETION
    taught = True

    def __init__(self, reply: str, filled: tuple[str, ...] = ()) -> None:
        self.reply, self.filled_predicates = reply, filled
        self.asked: list[Request] = []

    def complete(self, request: Request) -> Reply:
        self.asked.append(request)
        return Reply(self.reply, seconds=0.01, completion_tokens=5)

    def close(self) -> None:
        pass


def _plans(world: Scenario, count: int) -> list[tuple[str, list[int]]]:
    records, _ = sample_records(world, count, seed=4, max_expansions=20_000)
    return [(r.goal, [world.task.action(name).index for name in r.optimal_actions]) for r in records]


@pytest.mark.parametrize("name", ["robowaiter", "virtualhome"])
def test_the_check_of_an_abridged_label_gives_back_the_optimal_plan(name: str, request: pytest.FixtureRequest) -> None:
    world: Scenario = request.getfixturevalue(name)
    task = world.task
    said_in_all = planned_in_all = 0
    for goal, indices in _plans(world, 30):
        plan = [task.actions[i] for i in indices]
        said = abridged(task, task.resolve_goal(goal), plan)
        said_in_all, planned_in_all = said_in_all + len(said), planned_in_all + len(plan)
        assert [a.index for a in said] == [a.index for a in plan if a in said]  # a subsequence, in order
        assert {o for a in said for o in a.objects} == {o for a in plan for o in a.objects}
        reply = taught_reply((a.signature for a in said), Spelling.UNDERSCORED)
        question = build_request(as_names(task), goal, [], PromptOptions(style=PromptStyle.COMPLETION, taught=True))
        answer = checked_answer(_Taught(reply).complete, question, task, task.resolve_goal(goal))
        assert answer.reached
        assert answer.plan == tuple(a.signature.underscored for a in plan)
        state, applied = apply_actions(task, plan)
        assert applied == len(plan)
        assert task.resolve_goal(goal).holds(state)
    assert said_in_all < 0.8 * planned_in_all  # the walks to things, at least, are left to the check


def test_abridged_examples_are_shorter_and_record_the_predicates_left_out(virtualhome: Scenario) -> None:
    full = make_examples(virtualhome, 30, seed=2, instructions=False)
    short = make_examples(virtualhome, 30, seed=2, instructions=False, abridge=True)
    assert full.filled == ()
    assert "Walk" in short.filled
    assert set(short.filled) <= set(virtualhome.task.action_predicates)
    assert [e.goal for e in short.train] == [e.goal for e in full.train]
    assert all(e.kind is ExampleKind.HINTS for e in short.train)
    assert sum(map(len, (e.reply for e in short.train))) < 0.8 * sum(map(len, (e.reply for e in full.train)))


def test_a_world_not_grounded_prunes_an_abridged_reply_with_the_predicates_left_out(virtualhome: Scenario) -> None:
    goal = "IsIn_chicken_microwave"
    world = PrunedWorld.load(virtualhome.domain_file, virtualhome.problem_file, ScenarioOptions.shipped("virtualhome"))
    plan = [virtualhome.task.action(n) for n in ("Walk_chicken", "RightGrab_chicken", "Walk_microwave",
                                                 "Open_microwave", "RightPutIn_chicken_microwave")]  # fmt: skip
    said = abridged(virtualhome.task, virtualhome.task.resolve_goal(goal), plan)
    assert [a.predicate for a in said] == ["RightGrab", "RightPutIn"]
    reply = taught_reply((a.signature for a in said), Spelling.UNDERSCORED)
    filled = ("Open", "Walk")
    solved = run_hbtp(world, goal, _Taught(reply, filled))
    assert solved.outcome == Outcome.after(0)
    tree_actions = [solved.scenario.task.actions[i] for i in solved.result.solution]
    state, applied = apply_actions(solved.scenario.task, tree_actions)
    assert applied == len(tree_actions)
    assert solved.scenario.task.resolve_goal(goal).holds(state)
    # without them, the reply's space holds no plan: the first round fails
    assert run_hbtp(world, goal, _Taught(reply, ())).outcome != Outcome.after(0)
    # a grounded world checks the reply instead (the gaps are filled): solved at once either way
    assert run_hbtp(virtualhome, goal, _Taught(reply, ())).outcome == Outcome.after(0)


def test_a_request_for_a_grounded_world_is_checked_not_widened(virtualhome: Scenario) -> None:
    backend = _Taught(" RightGrab_chicken, RightPutIn_chicken_microwave\n\n", ("Walk", "Open"))
    result = run_hbtp(virtualhome, "IsIn_chicken_microwave", backend)
    assert result.outcome == Outcome.after(0)
    assert isinstance(backend.asked[0], Request)
    assert result.rounds[0].replies[-1].startswith(" Walk_chicken, RightGrab_chicken")
