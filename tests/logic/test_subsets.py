"""The subset index of the search's closed list and the verifier's progress check, against a scan."""

from __future__ import annotations

import random
from fractions import Fraction

import pytest

from hbtp.errors import PlanningError
from hbtp.logic import subsets as subsets_module
from hbtp.logic.subsets import SubsetIndex

needs_c = pytest.mark.skipif(not subsets_module.COMPILED, reason="the subset index's C extension is not built")
#: Each test runs with the trie in Python and, where the extension is built, in C.
KERNELS = [pytest.param(False, id="python"), pytest.param(True, id="c", marks=needs_c)]


@pytest.mark.parametrize("compiled", KERNELS)
def test_finds_a_stored_subset_and_only_a_subset(compiled: bool) -> None:
    index = SubsetIndex(compiled)
    index.add(frozenset({1, 2}), 5)
    assert index.has_subset(frozenset({1, 2, 3}))
    assert index.has_subset(frozenset({1, 2}))
    assert not index.has_subset(frozenset({1, 3}))
    assert not index.has_subset(frozenset())


@pytest.mark.parametrize("compiled", KERNELS)
def test_a_bound_on_the_value_only_counts_cheap_enough_subsets(compiled: bool) -> None:
    index = SubsetIndex(compiled)
    index.add(frozenset({1}), 5)
    assert index.has_subset(frozenset({1, 2}), at_most=5)
    assert not index.has_subset(frozenset({1, 2}), at_most=4)
    index.add(frozenset({2}), 3)
    assert index.has_subset(frozenset({1, 2}), at_most=4)


@pytest.mark.parametrize("compiled", KERNELS)
def test_the_empty_set_is_a_subset_of_everything(compiled: bool) -> None:
    index = SubsetIndex(compiled)
    index.add(frozenset(), 2)
    assert index.has_subset(frozenset())
    assert index.has_subset(frozenset({7}), at_most=2)
    assert not index.has_subset(frozenset({7}), at_most=1)
    index.add(frozenset(), 1)
    assert index.has_subset(frozenset({7}), at_most=1)


@pytest.mark.parametrize("compiled", KERNELS)
@pytest.mark.parametrize("seed", range(30))
def test_agrees_with_a_linear_scan(seed: int, compiled: bool) -> None:
    rng = random.Random(seed)
    index = SubsetIndex(compiled)
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


@pytest.mark.parametrize("compiled", KERNELS)
@pytest.mark.parametrize("seed", range(8))
def test_values_compare_as_python_numbers_do(seed: int, compiled: bool) -> None:
    """Ints, floats and fractions, mixed and beyond 64 bits, bound the answers exactly as in Python."""
    rng = random.Random(seed)
    pool = [Fraction(rng.randint(0, 40), rng.randint(1, 7)) for _ in range(6)]
    pool += [2**70 + rng.randint(-2, 2), 2**70 + Fraction(1, 3), 0.1 + 0.2, 0.3, 3, 3.0, -1]
    index = SubsetIndex(compiled)
    stored: list[tuple[frozenset[int], object]] = []
    for _ in range(80):
        items = frozenset(rng.sample(range(10), rng.randint(0, 4)))
        value = rng.choice(pool)
        index.add(items, value)  # type: ignore[arg-type]
        stored.append((items, value))
        query = frozenset(rng.sample(range(10), rng.randint(0, 7)))
        bound = rng.choice(pool)
        expected = any(s <= query and v <= bound for s, v in stored)  # type: ignore[operator]
        assert index.has_subset(query, at_most=bound) == expected  # type: ignore[arg-type]


@needs_c
@pytest.mark.parametrize("seed", range(6))
def test_c_and_python_tries_agree_on_many_large_sets(seed: int) -> None:
    """Sets of up to 40 atoms out of 3,000, queried with sets of up to 200: both tries answer alike."""
    rng = random.Random(seed)
    tries = SubsetIndex(compiled=False), SubsetIndex(compiled=True)
    base = rng.sample(range(3000), 300)
    answers = [0, 0]
    for step in range(3000):
        items = frozenset(rng.sample(base, rng.randint(1, 40 if step % 2 else 6)))
        value = rng.randint(0, 50)
        for trie in tries:
            trie.add(items, value)
        query = frozenset(rng.sample(base, rng.randint(0, 200)))
        bound = rng.choice([None, rng.randint(0, 50)])
        python, c = (trie.has_subset(query, at_most=bound) for trie in tries)
        assert python == c
        answers[python] += 1
    assert min(answers) > 100  # both answers were asked for, many times


@needs_c
def test_the_c_trie_refuses_atoms_it_cannot_hold() -> None:
    index = SubsetIndex(compiled=True)
    with pytest.raises(ValueError, match=r"atom ids in \[0, 2\*\*31\)"):
        index.add(frozenset({-1}), 0)
    with pytest.raises(TypeError):
        index.add(frozenset({"p"}), 0)  # type: ignore[arg-type]
    index.add(frozenset({1}), 2)
    with pytest.raises(ValueError, match=r"atom ids in \[0, 2\*\*31\)"):
        index.has_subset(frozenset({2**31}))
    assert index.has_subset(frozenset({1}), at_most=2)  # a refused call leaves the trie as it was
    index.add(frozenset({2**31 - 1}), 1)  # the largest id it holds (no table the size of the ids)
    assert index.has_subset(frozenset({5, 2**31 - 1}), at_most=1)


def test_asked_for_c_without_the_extension_says_so(monkeypatch: pytest.MonkeyPatch) -> None:
    monkeypatch.setattr(subsets_module, "_compiled", None)
    with pytest.raises(PlanningError, match=r"hbtp\.logic\._subsets is not built"):
        SubsetIndex(compiled=True)
    index = SubsetIndex(compiled=False)
    index.add(frozenset({1}), 1)
    assert index.has_subset(frozenset({1, 2}))


@needs_c
def test_the_c_trie_refuses_a_second_call_while_one_is_under_way() -> None:
    """A value compared by Python may run code that uses the same index (or let another thread in):
    the C trie refuses that call rather than move the arrays the first call is reading."""
    index = SubsetIndex(compiled=True)

    class Meddling(int):  # compared by Python, not as a C integer
        armed = True

        def __lt__(self, other: object) -> bool:
            if Meddling.armed:
                Meddling.armed = False
                index.add(frozenset({7}), 0)
            return int(self) < other  # type: ignore[operator]

    index.add(frozenset({1}), Meddling(5))
    with pytest.raises(RuntimeError, match="used by two calls at once"):
        index.add(frozenset({1}), Meddling(5))
    index.add(frozenset({2}), 3)  # the refused call left the index usable
    assert index.has_subset(frozenset({2, 5}), at_most=3)
    assert not index.has_subset(frozenset({7}))
