"""h² from s0 (hbtp.planning.pairs), checked against its definition and against the true cost.

* the level-by-level fixpoint equals a plain Bellman-Ford iteration of h²'s equations over every
  pair, on random tasks (with zero-cost actions and actions without precondition among them);
* it is admissible: on random conditions it never exceeds the cheapest cost of reaching a state that
  holds the condition (brute force), and it is ``inf`` when no state holding the condition is reachable
  only if the pair is truly never reached;
* it is consistent for regression: ``h²(c) <= cost(a) + h²(regress(c, a))`` for every action that
  regresses ``c``;
* a task with more atoms than MAX_ATOMS gets no table.
"""

from __future__ import annotations

import itertools
import math
import random

import pytest

from hbtp.logic.task import GroundAction, GroundTask
from hbtp.planning import pairs
from hbtp.planning.pairs import pair_costs
from helpers import brute_force, random_case, relevant_conditions


def reference_h2(task: GroundTask, actions: list[GroundAction], costs: dict[int, float]) -> dict[frozenset[int], float]:
    """h² of every atom and pair by iterating its equations to the fixpoint (no cleverness)."""
    atoms = range(len(task.atoms))
    value: dict[frozenset[int], float] = {}
    for p, q in itertools.combinations_with_replacement(atoms, 2):
        value[frozenset((p, q))] = 0.0 if {p, q} <= task.initial_state else math.inf

    def of(condition: frozenset[int]) -> float:
        return max(
            (value[frozenset(pair)] for pair in itertools.combinations_with_replacement(condition, 2)), default=0.0
        )

    changed = True
    while changed:
        changed = False
        for action in actions:
            before = of(action.pre)
            if math.isinf(before):
                continue
            cost = costs[action.index]
            for p, q in itertools.combinations_with_replacement(action.add, 2):
                if before + cost < value[frozenset((p, q))]:
                    value[frozenset((p, q))] = before + cost
                    changed = True
            for p in action.add:
                for q in atoms:
                    if q in action.add or q in action.delete:
                        continue
                    candidate = of(action.pre | {q}) + cost
                    if candidate < value[frozenset((p, q))]:
                        value[frozenset((p, q))] = candidate
                        changed = True
    return value


def _with_costs(seed: int, task: GroundTask) -> dict[int, float]:
    """Random action costs, zero for some actions (HBTP-S's owed actions cost 0)."""
    rng = random.Random(seed)
    return {a.index: float(rng.choice((0, 1, 1, 2, 5))) for a in task.actions}


@pytest.mark.parametrize("seed", range(120))
def test_the_level_fixpoint_equals_the_equations(seed: int) -> None:
    task = random_case(seed).task
    costs = _with_costs(seed, task) if seed % 2 else {a.index: float(a.cost) for a in task.actions}
    table = pair_costs(task, task.actions, costs if seed % 2 else None)
    assert table is not None
    expected = reference_h2(task, list(task.actions), costs)
    for pair, value in expected.items():
        assert table(pair) == value, (seed, sorted(pair))


@pytest.mark.parametrize("seed", range(120))
def test_h2_is_admissible_and_consistent_for_regression(seed: int) -> None:
    task = random_case(seed).task
    table = pair_costs(task, task.actions)
    assert table is not None
    rng = random.Random(seed)
    atoms = range(len(task.atoms))
    for _ in range(6):
        condition = frozenset(rng.sample(atoms, rng.randint(1, min(4, len(atoms)))))
        optimum, _ = brute_force(task, condition)
        value = table(condition)
        if optimum is None:
            continue
        assert value <= optimum, (seed, sorted(condition))
        for action in task.actions:
            if action.add & condition and not action.delete & condition:
                regressed = action.pre | (condition - action.add)
                assert value <= action.cost + table(regressed), (seed, sorted(condition), action.name)
    unreachable = [pair for pair in itertools.combinations(atoms, 2) if math.isinf(table(pair))]
    for pair in unreachable[:5]:
        assert brute_force(task, frozenset(pair))[0] is None, (seed, pair)


def test_a_task_past_the_atom_limit_gets_no_table(monkeypatch: pytest.MonkeyPatch) -> None:
    task = random_case(0).task
    monkeypatch.setattr(pairs, "MAX_ATOMS", len(task.atoms) - 1)
    assert pair_costs(task, task.actions) is None
    monkeypatch.setattr(pairs, "MAX_ATOMS", len(task.atoms))
    assert pair_costs(task, task.actions) is not None


@pytest.mark.parametrize("seed", range(150))
def test_h2_over_the_actions_relevant_to_a_goal_equals_h2_over_all(seed: int) -> None:
    """With discounted step costs the search computes h² over the goal's relevant actions only: on
    conditions made of the goal's atoms and the preconditions of relevant actions it gives the whole
    space's value."""
    task = random_case(seed).task
    relevant, conditions = relevant_conditions(task, seed)
    whole, part = pair_costs(task, task.actions), pair_costs(task, task.restricted(relevant))
    assert whole is not None
    assert part is not None
    for condition in conditions:
        assert part(condition) == whole(condition), (seed, sorted(condition))
