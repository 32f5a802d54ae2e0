"""The static verifier: planned trees are proved, trees broken on purpose are caught at the right node."""

from __future__ import annotations

import random

import pytest

from hbtp.bt import Action, Condition, Fallback, Node, Sequence, tick, tree_of
from hbtp.bt.compact import compact
from hbtp.bt.verify import Branch, flatten, path_text, verify
from hbtp.datasets import load_dataset
from hbtp.domains import Scenario
from hbtp.llm.parse import hints_from_record
from hbtp.logic.task import GroundTask
from hbtp.planning import plan
from helpers import kitchen_builder


@pytest.fixture(scope="module")
def kitchen() -> GroundTask:
    return kitchen_builder().action("Sing(self)", pre=["IsStanding(self)"], add=["IsHappy(self)"]).build()


def _ids(task: GroundTask, *names: str) -> frozenset[int]:
    return frozenset(task.atom_id(n) for n in names)


def _branch(task: GroundTask, action: str, *condition: str) -> Sequence:
    return Sequence((Condition(_ids(task, *condition)), Action(task.action(action).index)))


GOAL = "IsIn(milk,fridge)"


def _good_tree(task: GroundTask) -> Fallback:
    """The planned tree, written out: goal, PutIn, Open, Walk."""
    return Fallback(
        (
            Condition(_ids(task, GOAL)),
            _branch(task, "PutIn(milk,fridge)", "IsHolding(self,milk)", "IsNear(self,fridge)", "IsOpen(fridge)"),
            _branch(task, "Open(fridge)", "IsHolding(self,milk)", "IsNear(self,fridge)", "IsClose(fridge)"),
            _branch(task, "Walk(fridge)", "IsHolding(self,milk)", "IsStanding(self)", "IsClose(fridge)"),
        )
    )


def test_a_planned_tree_is_proved(kitchen: GroundTask) -> None:
    goal = _ids(kitchen, GOAL)
    result = plan(kitchen, "IsIn_milk_fridge", "obtea")
    for tree in (tree_of(result, "full"), tree_of(result, "path"), _good_tree(kitchen)):
        verdict = verify(tree, kitchen, goal)
        assert verdict.ok, verdict.summary()
        assert verdict.problems == ()
        assert verdict.first is None
        assert verdict.proved_goal_reaching
        assert verdict.covers_initial_state
        assert verdict.reaches_goal_from_initial_state
        assert verdict.branches == len(tree.children)
    assert verify(_good_tree(kitchen), kitchen, goal).to_dict()["ok"] is True


def test_an_action_whose_precondition_is_not_checked_is_named(kitchen: GroundTask) -> None:
    tree = _good_tree(kitchen)
    broken = Fallback(
        (
            *tree.children[:2],
            _branch(kitchen, "Open(fridge)", "IsHolding(self,milk)", "IsClose(fridge)"),
            tree.children[3],
        )
    )
    verdict = verify(broken, kitchen, _ids(kitchen, GOAL))
    assert not verdict.ok
    first = verdict.first
    assert first is not None
    assert first.kind == "precondition"
    assert first.path == "root.children[2].children[1]"
    assert first.missing == ("IsNear(self,fridge)",)
    assert "Open(fridge)" in first.message
    assert "IsNear(self,fridge)" in first.message
    # The tick semantics still guard the action (it fails when its precondition does not hold), so
    # goal reaching is still proved; the problem is that no Condition checks it.
    assert verdict.proved_goal_reaching


def test_a_branch_leading_nowhere_is_named(kitchen: GroundTask) -> None:
    tree = _good_tree(kitchen)
    broken = Fallback((*tree.children, _branch(kitchen, "Sing(self)", "IsStanding(self)", "IsHolding(self,milk)")))
    verdict = verify(broken, kitchen, _ids(kitchen, GOAL))
    assert not verdict.ok
    assert not verdict.proved_goal_reaching
    assert [p.kind for p in verdict.problems] == ["no-progress"]
    first = verdict.first
    assert first is not None
    assert first.path == "root.children[4].children[1]"
    assert "Sing(self)" in first.message
    # The closest earlier branch (fewest missing literals, then first) and what it misses.
    assert "the closest, root.children[0], misses IsIn(milk,fridge)" in first.message
    assert first.missing == ("IsIn(milk,fridge)",)
    assert str(first).startswith("root.children[4].children[1]: ")


def test_branches_in_the_wrong_order_do_not_prove_progress(kitchen: GroundTask) -> None:
    tree = _good_tree(kitchen)
    swapped = Fallback((tree.children[0], tree.children[2], tree.children[1], tree.children[3]))
    verdict = verify(swapped, kitchen, _ids(kitchen, GOAL))
    assert not verdict.proved_goal_reaching
    assert verdict.first is not None
    assert verdict.first.kind == "no-progress"
    assert verdict.first.path == "root.children[1].children[1]"
    assert verdict.first.missing == ("IsIn(milk,fridge)",)  # Open leads to PutIn's condition, now later


def test_the_goal_must_be_checked_first_and_exactly(kitchen: GroundTask) -> None:
    tree = _good_tree(kitchen)
    goal = _ids(kitchen, GOAL)
    no_goal = Fallback(tree.children[1:])
    verdict = verify(no_goal, kitchen, goal)
    assert verdict.first is not None
    assert verdict.first.kind == "goal-check"
    assert verdict.first.path == "root.children[0].children[1]"
    weaker = Fallback((Condition(_ids(kitchen, "IsOpen(fridge)")), *tree.children[1:]))
    verdict = verify(weaker, kitchen, goal)
    assert verdict.first is not None
    assert verdict.first.kind == "success-without-goal"
    assert verdict.first.path == "root.children[0]"
    assert verdict.first.missing == (GOAL,)
    stronger = Fallback((Condition(goal | _ids(kitchen, "IsHappy(self)")), *tree.children[1:]))
    verdict = verify(stronger, kitchen, goal)
    assert verdict.first is not None
    assert verdict.first.kind == "goal-check"
    assert verdict.first.missing == ("IsHappy(self)",)
    shortcut = Fallback((*tree.children, Condition(_ids(kitchen, "IsHappy(self)"))))
    verdict = verify(shortcut, kitchen, goal)
    assert [(p.kind, p.path) for p in verdict.problems] == [("success-without-goal", "root.children[4]")]


def test_nested_trees_are_flattened_and_proved(kitchen: GroundTask) -> None:
    tree = _good_tree(kitchen)
    goal = _ids(kitchen, GOAL)
    holding = _ids(kitchen, "IsHolding(self,milk)")
    nested = Fallback(
        (
            tree.children[0],
            Sequence(
                (
                    Condition(holding),
                    Fallback(
                        tuple(
                            Sequence((Condition(branch.children[0].literals - holding), branch.children[1]))
                            for branch in tree.children[1:]
                            if isinstance(branch, Sequence) and isinstance(branch.children[0], Condition)
                        )
                    ),
                )
            ),
        )
    )
    verdict = verify(nested, kitchen, goal)
    assert verdict.ok, verdict.summary()
    assert verdict.proved_goal_reaching
    assert verdict.branches == 4
    # Deeply nested, with a Condition after the branches of an inner Fallback that cannot succeed.
    inner = Fallback((tree.children[1], tree.children[2]))
    odd = Fallback(
        (
            tree.children[0],
            Sequence((Condition(_ids(kitchen, "IsHolding(self,milk)")), inner)),
            Fallback((Sequence((tree.children[3],)),)),
        )
    )
    verdict = verify(odd, kitchen, goal)
    assert verdict.ok, verdict.summary()
    assert verdict.proved_goal_reaching


def test_a_tree_without_first_match_form_is_checked_but_not_proved(kitchen: GroundTask) -> None:
    goal = _ids(kitchen, GOAL)
    either = Fallback((Condition(_ids(kitchen, "IsOpen(fridge)")), Condition(_ids(kitchen, "IsNear(self,fridge)"))))
    tree = Fallback(
        (
            Condition(goal),
            Sequence((either, Condition(_ids(kitchen, "IsClose(fridge)")), _branch(kitchen, "Sing(self)"))),
        )
    )
    assert flatten(tree) is None
    verdict = verify(tree, kitchen, goal)
    assert not verdict.proved_goal_reaching
    assert verdict.branches is None
    assert verdict.notes
    assert [(p.kind, p.path) for p in verdict.problems] == [
        ("precondition", "root.children[1].children[2].children[1]")
    ]


def test_unknown_ids_and_never_ticked_nodes(kitchen: GroundTask) -> None:
    goal = _ids(kitchen, GOAL)
    verdict = verify(Fallback((Condition(goal), Action(999))), kitchen, goal)
    assert [(p.kind, p.path) for p in verdict.problems] == [("unknown-symbol", "root.children[1]")]
    walk = kitchen.action("Walk(fridge)").index
    after = Sequence((Condition(_ids(kitchen, "IsStanding(self)")), Action(walk), Condition(goal)))
    verdict = verify(Fallback((Condition(goal), after)), kitchen, goal)
    assert [w.path for w in verdict.warnings] == ["root.children[1].children[2]"]


def test_flatten_matches_tick_on_random_states(kitchen: GroundTask) -> None:
    tree = compact(_good_tree(kitchen))
    branches = flatten(tree)
    assert branches is not None
    assert all(isinstance(b, Branch) for b in branches)
    rng = random.Random(3)
    for _ in range(200):
        state = frozenset(i for i in range(len(kitchen.atoms)) if rng.random() < 0.5)
        first = next((b for b in branches if b.condition(kitchen) <= state), None)
        status, running = tick(tree, state, kitchen)
        if first is None:
            assert status.value == "failure"
        else:
            assert running == first.action


def test_path_text() -> None:
    assert path_text(()) == "root"
    assert path_text((3, 1)) == "root.children[3].children[1]"


# ---------------------------------------------------------------- every record
def _planned_trees(scenario: Scenario, dataset: str) -> list[tuple[str, str, Node, frozenset[int]]]:
    trees = []
    for record in load_dataset(dataset):
        hints = hints_from_record(record)
        result = plan(
            scenario.task, record.goal, "hbtp-s", hints=hints, space="pruned", mutexes=scenario.mutexes, heuristic="lm"
        )
        if not result.solved:
            result = plan(scenario.task, record.goal, "obtea", mutexes=scenario.mutexes, heuristic="lm")
        assert result.solved, record.id
        goal = scenario.task.resolve_goal(record.goal).ids
        for kind in ("full", "path"):
            trees.append((record.id, kind, tree_of(result, kind), goal))
    return trees


@pytest.mark.parametrize("dataset", ["table2_robothow_small_50", "table2_robowaiter_50"])
def test_every_planned_tree_of_a_test_set_is_proved(
    dataset: str, robothow_small: Scenario, robowaiter: Scenario
) -> None:
    scenario = robothow_small if "robothow" in dataset else robowaiter
    trees = _planned_trees(scenario, dataset)
    assert len(trees) == 100
    for record_id, kind, tree, goal in trees:
        for candidate in (tree, compact(tree)):
            verdict = verify(candidate, scenario.task, goal)
            assert verdict.ok, f"{record_id} ({kind}): {verdict.summary()}"
            assert verdict.proved_goal_reaching, record_id
            assert verdict.reaches_goal_from_initial_state, record_id
            assert not verdict.warnings
