"""A condition no plan reaches for want of a last action (hbtp.planning.regression), against search."""

from __future__ import annotations

import itertools

import pytest

from hbtp.domains import load_scenario
from hbtp.planning import Limits, plan
from hbtp.planning.regression import regressions, stuck
from hbtp.planning.result import Status


def test_holding_a_thing_and_its_place_together_is_stuck() -> None:
    scenario = load_scenario("robowaiter")
    task, proved = scenario.task, scenario.mutexes.proved_only()
    both = frozenset((task.atom_id("Holding_VacuumCup"), task.atom_id("On_VacuumCup_Table2")))
    assert proved.conflict(both) is None  # not a mutex the domain proves
    assert stuck(task, both, proved)
    assert not stuck(task, frozenset(list(both)[:1]), proved)
    assert plan(task, "Holding_VacuumCup & On_VacuumCup_Table2", "obtea").status is Status.UNSOLVABLE


def test_a_condition_that_holds_at_the_start_is_never_stuck() -> None:
    scenario = load_scenario("robowaiter")
    start = frozenset(sorted(scenario.task.initial_state)[:3])
    assert not stuck(scenario.task, start, scenario.mutexes.proved_only())


@pytest.mark.parametrize("name", ["robowaiter", "robothow-small"])
def test_every_stuck_pair_is_unsolvable_and_every_regression_is_one(name: str) -> None:
    """Soundness against the search: each pair of literals found stuck has no plan (a complete
    search proves it), and each regression found is the search's step (adds one, deletes none)."""
    scenario = load_scenario(name)
    task, proved = scenario.task, scenario.mutexes.proved_only()
    added = sorted({atom for action in task.actions for atom in action.add} - task.initial_state)
    pairs = [frozenset(p) for p in itertools.combinations(added, 2) if proved.conflict(p) is None]
    found = [pair for pair in pairs if stuck(task, pair, proved)]
    assert found  # both worlds have such pairs (a thing held and placed)
    for pair in found[:40]:
        goal = " & ".join(task.atoms[i].underscored for i in sorted(pair))
        assert plan(task, goal, "obtea", limits=Limits(max_expansions=50_000)).status is Status.UNSOLVABLE, goal
    for pair in pairs[:200]:
        for action, regressed in regressions(task, pair, proved):
            assert pair & action.add
            assert not pair & action.delete
            assert regressed == action.pre | (pair - action.add)
