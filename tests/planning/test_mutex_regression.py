"""The mutex check of a regression, atom by atom, is the set definition it replaced: the condition
regressed through an action is pruned when an atom it keeps is mutex with a precondition, or when
two preconditions are mutex."""

from __future__ import annotations

import random
from types import SimpleNamespace

import pytest

from hbtp.domains import load_scenario
from hbtp.planning.search_state import SearchState


def by_sets(
    partners: tuple[frozenset[int], ...], condition: frozenset[int], pre: frozenset[int], add: frozenset[int]
) -> bool:
    clashing: frozenset[int] = frozenset().union(*(partners[p] for p in pre))
    if not clashing.isdisjoint(pre):  # two preconditions mutex: every atom clashes
        return bool(condition)
    return not clashing.isdisjoint(condition) and not clashing & condition <= add


@pytest.mark.parametrize("scenario", ["robowaiter", "robothow-small"])
def test_the_check_atom_by_atom_is_the_set_definition(scenario: str) -> None:
    task, mutexes = load_scenario(scenario).task, load_scenario(scenario).mutexes
    partners = mutexes.partners
    rng = random.Random(7)
    state = SimpleNamespace(partners=partners, self_clashing={})
    grouped = sorted({a for group in mutexes.groups for a in group.atoms})
    pruned = 0
    for _ in range(3000):
        action = rng.choice(task.actions)
        kept = rng.sample(grouped, min(len(grouped), rng.randint(1, 4)))
        condition = frozenset(kept + rng.sample(sorted(action.add), min(1, len(action.add))))
        expected = by_sets(partners, condition, action.pre, action.add)
        assert SearchState.clashes(state, condition, action) == expected  # type: ignore[arg-type]
        pruned += expected
    assert 0 < pruned < 3000  # both answers were asked
