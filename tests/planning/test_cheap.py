"""The cheap estimates in C (hbtp.planning._cheap): h² and the landmark sum give Python's values.

* on random tasks (random action costs, zero and fractional among them, so that landmark shares are
  fractions), every condition made of the task's atoms gets the same h² and the same landmark sum,
  with and without the h_max table, as the Python reference;
* a search switches to C after the warm-up and gives the same tree, cost and counts as one that
  stays in Python (random tasks, and a shipped IPC instance);
* the kernel refuses tables that do not match and atoms out of range, and its scratch marks survive
  wrapping around.
"""

from __future__ import annotations

import itertools
import math
import random
from pathlib import Path

import pytest

from hbtp import compiled
from hbtp.domains import load_pddl_scenario
from hbtp.logic.task import GroundTask
from hbtp.planning import pairs
from hbtp.planning.heuristics import LandmarkSum, analyse_space, landmark_costs
from hbtp.planning.limits import Limits
from hbtp.planning.pairs import PairCosts, pair_costs
from hbtp.planning.planners import plan, planner_config
from helpers import random_case

pytestmark = pytest.mark.skipif(not pairs.COMPILED, reason="the C extension hbtp.planning._cheap is not built")

IPC = Path(__file__).resolve().parents[3] / "shared" / "benchmarks" / "ipc"


def _conditions(task: GroundTask, seed: int, count: int = 40) -> list[frozenset[int]]:
    """Random conditions over every atom of ``task`` (the empty one and single atoms among them)."""
    rng = random.Random(seed)
    atoms = range(len(task.atoms))
    found = [frozenset(), *(frozenset({a}) for a in atoms)]
    found += [frozenset(rng.sample(atoms, rng.randint(2, len(atoms)))) for _ in range(count)]
    return found


def _costs(task: GroundTask, seed: int) -> dict[int, float]:
    rng = random.Random(seed)
    return {a.index: float(rng.choice((0, 1, 2, 5, 7))) for a in task.actions}


@pytest.mark.parametrize("seed", range(60))
def test_h2_in_c_equals_python(seed: int) -> None:
    task = random_case(seed).task
    for costs in (None, _costs(task, seed)):
        python = pair_costs(task, task.actions, costs)
        assert python is not None
        c = PairCosts(python.history, compiled=True)
        c.table = c.pair_table()
        for condition in _conditions(task, seed):
            assert c(condition) == python(condition), (seed, sorted(condition))
            assert c(sorted(condition)) == python(condition)


@pytest.mark.parametrize("seed", range(60))
def test_the_landmark_sum_in_c_equals_python(seed: int) -> None:
    task = random_case(seed).task
    analysis = analyse_space(task, task.actions)
    costs = _costs(task, seed)
    for shares, hmax in itertools.product((analysis.shares, landmark_costs(task, task.actions, range(99), costs)),
                                          (None, analysis.hmax)):  # fmt: skip
        share = _finite(shares)
        made = [LandmarkSum(analysis.landmarks, share, task.initial_state, analysis.pre_landmarks, hmax, compiled=c)
                for c in (False, True)]  # fmt: skip
        python, c = made
        assert c.kernel is not None
        c.tables = c.compiled_tables()
        for condition in _conditions(task, seed):
            expected = python(condition)
            assert c(condition) == expected, (seed, sorted(condition))
            if condition and not math.isinf(expected):
                assert expected == math.ceil(expected)


def _finite(shares: list[float]) -> list[float]:
    """Shares with the atoms no precondition needs given one (a search patches those of its goal):
    every condition of :func:`_conditions` then has a finite sum."""
    return [1.5 if math.isinf(share) else share for share in shares]


def test_the_landmark_sum_in_c_reads_landmarks_given_as_sets() -> None:
    task = random_case(3).task
    analysis = analyse_space(task, task.actions)
    as_sets = [analysis.landmarks[a] for a in range(len(task.atoms))]
    share = _finite(analysis.shares)
    python = LandmarkSum(as_sets, share, task.initial_state, analysis.pre_landmarks, compiled=False)
    c = LandmarkSum(as_sets, share, task.initial_state, analysis.pre_landmarks, compiled=True)
    assert c.kernel is not None
    c.tables = c.compiled_tables()
    for condition in _conditions(task, 3):
        assert c(condition) == python(condition)


def _search_record(task: GroundTask, goal: object, mutexes: object = None) -> tuple[object, ...]:
    result = plan(task, goal, planner_config("obtea", heuristic="seq"), mutexes=mutexes, limits=Limits(time_s=60))  # type: ignore[arg-type]
    return result.status, result.cost, result.stats.explored, result.stats.generated, result.expansions


@pytest.mark.parametrize("seed", range(40))
def test_a_search_with_the_c_estimates_equals_one_in_python(seed: int, monkeypatch: pytest.MonkeyPatch) -> None:
    case = random_case(seed)
    monkeypatch.setattr(compiled, "WARM_UP", 10**9)
    python = _search_record(case.task, case.goal)
    monkeypatch.setattr(compiled, "WARM_UP", 0)
    c = _search_record(case.task, case.goal)
    assert c == python
    if case.optimum is not None:
        assert c[1] == case.optimum


@pytest.mark.skipif(not (IPC / "depot").is_dir(), reason="the shipped IPC benchmarks are not here")
def test_a_shipped_instance_searches_the_same_with_the_c_estimates(monkeypatch: pytest.MonkeyPatch) -> None:
    runs = []
    for warm_up in (10**9, 0):
        monkeypatch.setattr(compiled, "WARM_UP", warm_up)
        scenario = load_pddl_scenario(IPC / "depot" / "domain.pddl", IPC / "depot" / "p01.pddl")
        scenario, goal = scenario.resolve_goal(scenario.problem_goal())
        runs.append(_search_record(scenario.task, goal, scenario.mutexes))
    assert runs[0] == runs[1]
    assert runs[0][1] == 10  # Fast Downward's optimum (fd_optimal_costs.json)


def test_the_kernel_refuses_tables_that_do_not_match() -> None:
    kernel = compiled.extension(compiled.CHEAP)
    assert kernel is not None
    table = kernel.pair_table(2, [([0.0], b"\x03"), ([1.0], b"\x03")])
    assert [kernel.pair_cost(table, 2, c) for c in ([], [0], [1], [0, 1])] == [0.0, 0.0, 1.0, 1.0]
    one_sided = kernel.pair_table(2, [([0.0], b"\x03"), ([1.0], b"\x02")])  # the larger order counts
    assert kernel.pair_cost(one_sided, 2, {1, 0}) == math.inf
    with pytest.raises(IndexError, match="atom 2 out of range"):
        kernel.pair_cost(table, 2, [0, 2])
    with pytest.raises(ValueError, match="does not hold 3 atoms"):
        kernel.pair_cost(table, 3, [0])
    with pytest.raises(ValueError, match="masks do not match"):
        kernel.pair_table(2, [([0.0, 1.0], b"\x03")])
    with pytest.raises(ValueError, match="fewer masks than atoms"):
        kernel.bit_lists(3, [None])
    spans, atoms = kernel.bit_lists(2, [b"\x02", None])
    share = bytes(16)
    with pytest.raises(ValueError, match="landmark tables do not match"):
        kernel.landmark_sum((spans, atoms, share, bytearray(4), None), [0])


def test_the_scratch_marks_survive_wrapping_around() -> None:
    task = random_case(5).task
    analysis = analyse_space(task, task.actions)
    share = _finite(analysis.shares)
    python = LandmarkSum(analysis.landmarks, share, task.initial_state, analysis.pre_landmarks, compiled=False)
    c = LandmarkSum(analysis.landmarks, share, task.initial_state, analysis.pre_landmarks, compiled=True)
    assert c.kernel is not None
    c.tables = c.compiled_tables()
    stamps = c.tables[3]
    count = len(task.atoms)
    for condition in _conditions(task, 5):
        stamps[4 * count : 4 * (count + 1)] = (2**32 - 1).to_bytes(4, "little")
        assert c(condition) == python(condition)
