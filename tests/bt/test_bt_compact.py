"""Compaction: the compacted tree ticks exactly like the original, from every explored state and more."""

from __future__ import annotations

import random

from hbtp.bt import Action, Condition, Fallback, Node, Sequence, size, tick, tree_of
from hbtp.bt.compact import compact, compact_with_report
from hbtp.bt.verify import verify
from hbtp.datasets import load_dataset
from hbtp.domains import Scenario
from hbtp.llm.parse import hints_from_record
from hbtp.logic.task import GroundTask
from hbtp.planning import plan
from helpers import random_task


def _same_ticks(original: Node, compacted: Node, task: GroundTask, states: list[frozenset[int]]) -> None:
    for state in states:
        assert tick(compacted, state, task) == tick(original, state, task), sorted(task.names(state))


def _supersets(task: GroundTask, base: frozenset[int], rng: random.Random, count: int) -> list[frozenset[int]]:
    atoms = range(len(task.atoms))
    return [base | frozenset(rng.sample(atoms, rng.randint(1, min(30, len(task.atoms))))) for _ in range(count)]


def test_compacted_planned_trees_act_the_same_from_every_explored_state(scenario: Scenario) -> None:
    """Many planned trees (HBTP-S and OBTEA, full and path): every expanded condition as a state,
    and random supersets of it drawn from the task's atoms."""
    task = scenario.task
    assert scenario.test_set is not None
    rng = random.Random(7)
    trees = 0
    total_before = total_after = 0
    for record in load_dataset(scenario.test_set)[:8]:
        hints = hints_from_record(record)
        goal = task.resolve_goal(record.goal).ids
        for planner in ("hbtp-s", "obtea"):
            result = plan(
                task, record.goal, planner, hints=hints, space="pruned", mutexes=scenario.mutexes, heuristic="lm"
            )
            assert result.solved
            states = [e.condition for e in result.expansions] + [task.initial_state]
            states += [s for e in result.expansions for s in _supersets(task, e.condition, rng, 3)]
            for kind in ("full", "path"):
                tree = tree_of(result, kind)
                compacted, report = compact_with_report(tree)
                trees += 1
                _same_ticks(tree, compacted, task, states)
                assert report.before == size(tree)
                assert report.after == size(compacted)
                assert report.after.literals <= report.before.literals
                assert report.after.nodes + report.after.literals <= report.before.nodes + report.before.literals
                total_before += report.before.literals
                total_after += report.after.literals
                assert verify(compacted, task, goal).proved_goal_reaching
    assert trees == 32
    assert total_after < total_before  # it does factor something


def test_a_run_of_branches_sharing_literals_is_factored() -> None:
    walk, grab, put = Action(0), Action(1), Action(2)
    tree = Fallback(
        (
            Condition(frozenset({9})),
            Sequence((Condition(frozenset({1, 2, 3, 4})), walk)),
            Sequence((Condition(frozenset({1, 2, 3, 5})), grab)),
            Sequence((Condition(frozenset({1, 2, 3})), put)),
            Sequence((Condition(frozenset({7})), walk)),
        )
    )
    compacted, report = compact_with_report(tree)
    assert compacted == Fallback(
        (
            Condition(frozenset({9})),
            Sequence(
                (
                    Condition(frozenset({1, 2, 3})),
                    Fallback(
                        (
                            Sequence((Condition(frozenset({4})), walk)),
                            Sequence((Condition(frozenset({5})), grab)),
                            put,  # its condition was the shared part: no Condition, no Sequence left
                        )
                    ),
                )
            ),
            Sequence((Condition(frozenset({7})), walk)),
        )
    )
    assert report.merges == 1
    assert (report.before.nodes, report.after.nodes) == (14, 15)  # +3 new nodes, -2 for put's branch
    assert (report.before.depth, report.after.depth) == (3, 5)
    assert (report.before.literals, report.after.literals) == (13, 7)
    assert "literals 13 -> 7" in str(report)
    assert report.to_dict()["after"] == {"nodes": 15, "depth": 5, "literals": 7}


def test_only_adjacent_branches_are_merged() -> None:
    """Branches 1 and 3 share {1, 2, 3} but branch 2 lies between: merging them would change the order."""
    tree = Fallback(
        (
            Sequence((Condition(frozenset({1, 2, 3, 4})), Action(0))),
            Sequence((Condition(frozenset({8})), Action(1))),
            Sequence((Condition(frozenset({1, 2, 3, 5})), Action(2))),
        )
    )
    assert compact(tree) == tree


def test_normalisation_keeps_behaviour() -> None:
    a, b = Action(0), Action(1)
    tree = Sequence(
        (Condition(frozenset({1})), Sequence((Condition(frozenset({2})), Condition(frozenset()))), Fallback((a,)))
    )
    assert compact(tree) == Sequence((Condition(frozenset({1, 2})), a))
    assert compact(Fallback((Fallback((a,)), Fallback((b,))))) == Fallback((a, b))
    assert compact(Fallback(())) == Fallback(())
    assert compact(Sequence(())) == Sequence(())


def _random_tree(task: GroundTask, rng: random.Random, depth: int = 4) -> Node:
    atoms = range(len(task.atoms))
    roll = rng.random()
    if depth == 0 or roll < 0.3:
        if rng.random() < 0.5:
            return Condition(frozenset(rng.sample(atoms, rng.randint(0, min(3, len(task.atoms))))))
        return Action(rng.randrange(len(task.actions)))
    if roll < 0.55:
        return Sequence(tuple(_random_tree(task, rng, depth - 1) for _ in range(rng.randint(0, 4))))
    # Fallbacks of guarded branches with overlapping guards, so that there is something to factor.
    shared = frozenset(rng.sample(atoms, min(2, len(task.atoms))))
    children: list[Node] = []
    for _ in range(rng.randint(0, 6)):
        if rng.random() < 0.7:
            guard = shared | frozenset(rng.sample(atoms, rng.randint(0, 2)))
            children.append(Sequence((Condition(guard), _random_tree(task, rng, depth - 1))))
        else:
            children.append(_random_tree(task, rng, depth - 1))
    return Fallback(tuple(children))


def test_compaction_keeps_behaviour_on_random_trees() -> None:
    merged = 0
    for seed in range(200):
        task, _ = random_task(seed)
        rng = random.Random(seed)
        tree = _random_tree(task, rng)
        compacted, report = compact_with_report(tree)
        merged += report.merges
        for _ in range(30):
            state = frozenset(i for i in range(len(task.atoms)) if rng.random() < 0.6)
            assert tick(compacted, state, task) == tick(tree, state, task), (seed, tree, compacted)
        again = compact(compacted)  # a second pass may find more to factor; it keeps behaviour too
        for _ in range(10):
            state = frozenset(i for i in range(len(task.atoms)) if rng.random() < 0.6)
            assert tick(again, state, task) == tick(tree, state, task)
    assert merged > 20
