"""The shipped instruction dataset (issue 11, item 5): well formed, faithful to the test sets, and
every goal it states solvable, with a tree that is verified and reaches it."""

from __future__ import annotations

import pytest

from hbtp.bt import full_tree
from hbtp.bt.simulate import simulate
from hbtp.bt.verify import verify
from hbtp.datasets import load_dataset
from hbtp.datasets.instructions import instruction_scenarios, load_instructions
from hbtp.domains import load_scenario
from hbtp.errors import InputError
from hbtp.logic.goals import parse_goal
from hbtp.planning import plan

SCENARIOS = ("robowaiter", "virtualhome", "robothow-small", "robothow")


def test_every_shipped_scenario_has_instructions() -> None:
    assert instruction_scenarios() == tuple(sorted(SCENARIOS))
    with pytest.raises(InputError, match="choose one of"):
        load_instructions("kitchen")


@pytest.mark.parametrize("scenario", SCENARIOS)
def test_the_dataset_covers_the_test_set_with_two_phrasings_and_adds_or_and_not(scenario: str) -> None:
    records = load_instructions(scenario)
    test_set = load_dataset(f"table2_{scenario.replace('-', '_')}_50")
    from_test = [r for r in records if r.task is not None]
    assert [r.task for r in from_test] == list(range(1, 51))
    for record in from_test:
        assert record.goal == test_set[record.task - 1].goal.strip()
    assert len({r.id for r in records}) == len(records)
    for record in records:
        assert len(set(record.instructions)) >= 2, record.id
        assert all("_" not in text for text in record.instructions), record.id
    own = [parse_goal(r.goal) for r in records if r.task is None]
    assert sum(len(terms) > 1 for terms in own) >= 6
    assert sum(any(a.negated for term in terms for a in term) for terms in own) >= 4


@pytest.mark.parametrize("scenario", SCENARIOS)
def test_every_written_goal_is_solvable_and_its_tree_reaches_it(scenario: str) -> None:
    loaded = load_scenario(scenario)
    for record in load_instructions(scenario):
        if record.task is not None:
            continue  # the test-set goals are planned by the dataset tests
        extended, goal = loaded.resolve_goal(record.goal)
        result = plan(extended.task, goal, "obtea", mutexes=extended.mutexes, heuristic="lm")
        assert result.solved, (record.id, result.message)
        tree = full_tree(result.expansions)
        assert verify(tree, extended.task, goal, from_initial_state=True).ok, record.id
        assert simulate(tree, extended.task).reached(goal), record.id
