"""The subset index of the search's closed list and the verifier's progress check, against a scan."""

from __future__ import annotations

import random

import pytest

from hbtp.logic.subsets import SubsetIndex


def test_finds_a_stored_subset_and_only_a_subset() -> None:
    index = SubsetIndex()
    index.add(frozenset({1, 2}), 5)
    assert index.has_subset(frozenset({1, 2, 3}))
    assert index.has_subset(frozenset({1, 2}))
    assert not index.has_subset(frozenset({1, 3}))
    assert not index.has_subset(frozenset())


def test_a_bound_on_the_value_only_counts_cheap_enough_subsets() -> None:
    index = SubsetIndex()
    index.add(frozenset({1}), 5)
    assert index.has_subset(frozenset({1, 2}), at_most=5)
    assert not index.has_subset(frozenset({1, 2}), at_most=4)
    index.add(frozenset({2}), 3)
    assert index.has_subset(frozenset({1, 2}), at_most=4)


def test_the_empty_set_is_a_subset_of_everything() -> None:
    index = SubsetIndex()
    index.add(frozenset(), 2)
    assert index.has_subset(frozenset())
    assert index.has_subset(frozenset({7}), at_most=2)
    assert not index.has_subset(frozenset({7}), at_most=1)
    index.add(frozenset(), 1)
    assert index.has_subset(frozenset({7}), at_most=1)


@pytest.mark.parametrize("seed", range(30))
def test_agrees_with_a_linear_scan(seed: int) -> None:
    rng = random.Random(seed)
    index = SubsetIndex()
    stored: list[tuple[frozenset[int], int]] = []
    for _ in range(60):
        items = frozenset(rng.sample(range(12), rng.randint(0 if seed % 3 == 0 else 1, 4)))
        value = rng.randint(0, 9)
        index.add(items, value)
        stored.append((items, value))
        query = frozenset(rng.sample(range(12), rng.randint(0, 8)))
        bound = rng.randint(0, 9)
        assert index.has_subset(query) == any(s <= query for s, _ in stored)
        assert index.has_subset(query, at_most=bound) == any(s <= query and v <= bound for s, v in stored)
