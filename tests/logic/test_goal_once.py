"""One goal value per command: the goal text is read once, resolved once per task it is planned in,
and the world is loaded once (issue: renovate the seams, item 1)."""

from __future__ import annotations

import collections
import pickle
from typing import Any

import pytest

from hbtp.cli import main
from hbtp.cli.options import ScenarioSource
from hbtp.domains import Scenario
from hbtp.logic import goals, resolve
from hbtp.logic import task as task_module

GOAL = "IsIn_milk_fridge & IsClose_fridge"


@pytest.fixture
def counted(monkeypatch: pytest.MonkeyPatch) -> dict[str, Any]:
    counts: dict[str, Any] = {"parses": 0, "resolved": collections.Counter(), "loads": 0}
    infix, pddl = goals._InfixReader.read, goals._PddlReader.read

    def read_infix(self: Any) -> Any:
        counts["parses"] += "milk_fridge & IsClose_fridge" in self.tokens.text
        return infix(self)

    def read_pddl(self: Any) -> Any:
        counts["parses"] += "milk fridge" in self.tokens.text
        return pddl(self)

    real_resolve = resolve.resolve_goal

    def resolving(task: Any, goal: Any) -> Any:
        result = real_resolve(task, goal)
        if "milk" in str(goal) and "Close" in str(goal):
            counts["resolved"][id(task)] += 0 if goal is result else 1  # a resolved goal handed back: free
        return result

    real_load = ScenarioSource.load

    def loading(self: ScenarioSource, *args: Any, **kwargs: Any) -> Scenario:
        counts["loads"] += 1
        return real_load(self, *args, **kwargs)

    monkeypatch.setattr(goals._InfixReader, "read", read_infix)
    monkeypatch.setattr(goals._PddlReader, "read", read_pddl)
    monkeypatch.setattr(task_module, "resolve_goal", resolving)
    monkeypatch.setattr(ScenarioSource, "load", loading)
    return counts


@pytest.mark.parametrize(
    "extra",
    [[], ["--llm", "oracle"], ["--llm", "auto:oracle"], ["--hints", "oracle"], ["--llm", "noisy-oracle"]],
    ids=["plain", "loop", "auto", "hints", "noisy"],
)
def test_a_plan_reads_the_goal_once_resolves_it_once_per_task_and_loads_once(
    extra: list[str], counted: dict[str, Any], capsys: pytest.CaptureFixture[str]
) -> None:
    assert main(["plan", "-s", "robothow", "-g", GOAL, "--json", *extra]) == 0, capsys.readouterr().err
    assert counted["parses"] == 1
    assert counted["loads"] == 1
    assert set(counted["resolved"].values()) == {1}, counted["resolved"]


def test_a_resolved_goal_knows_its_task_and_forgets_it_when_pickled(robothow: Scenario) -> None:
    goal = robothow.task.resolve_goal(GOAL)
    assert goal.resolved_in(robothow.task)
    assert robothow.task.resolve_goal(goal) is goal
    copy = pickle.loads(pickle.dumps(goal))
    assert copy == goal
    assert not copy.resolved_in(robothow.task)
    assert robothow.task.resolve_goal(copy) == goal  # resolved again, the same value


def test_a_goal_resolved_again_from_another_state_is_the_goal_read_anew(robothow_small: Scenario) -> None:
    """Re-planning resolves the goal in the task from the observed state: what depends on s0 (which
    literals can never hold) is worked out again, the literals are not checked and spelled again."""
    from hbtp.logic.negation import with_negations

    task = robothow_small.task
    text = "IsIn_apple_fridge & IsClose_fridge | IsOn_apple_kitchentable"
    goal = task.resolve_goal(text)
    plugged = task.atom_ids[task.spelled(goals.parse_atom("IsPlugged_fridge"))]
    for state in (task.initial_state, task.initial_state - {plugged}, frozenset()):
        world = task.from_state(state)
        again, anew = world.resolve_goal(goal), world.resolve_goal(text)
        assert (again.terms, again.disjuncts, again.unreachable, again.reachable) == (
            anew.terms, anew.disjuncts, anew.unreachable, anew.reachable,
        )  # fmt: skip
        assert again.resolved_in(world)
    other = with_negations(task, [plugged])  # other atoms: read anew, not taken over
    assert other.resolve_goal(goal).resolved_in(other)
