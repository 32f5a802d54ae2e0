"""The state equation's dual simplex in C (hbtp.planning._simplex), checked against HiGHS.

* on random programs of the state equation's form (columns of -1, 0 and +1, costs >= 0 with zeros
  among them, rows bounded below, above or both), one program asked many bounds in turn (each solve
  starting from the last basis) gives HiGHS's status and value for each, infeasible ones included;
  its proof of infeasibility names a row;
* the state equation gives the same value with the C simplex as with HiGHS alone (to 1e-9 with
  fractional costs, whose estimates are not rounded), on random tasks (with random costs, zero and
  fractional among them) and on conditions of shipped IPC instances,
  and a search with it gives the same tree and counts;
* a solve the simplex gives up on is asked of HiGHS, and bounds asked again need no pivot;
* the program refuses arrays that do not match, bounds of the wrong size and a ray before a proof.
"""

from __future__ import annotations

import functools
import math
import random
from pathlib import Path
from typing import Any

import pytest

from hbtp import compiled
from hbtp.domains import load_pddl_scenario
from hbtp.logic.task import GroundTask
from hbtp.planning import flow, heuristics, plan
from hbtp.planning.flow import StateEquation
from hbtp.planning.limits import Limits
from hbtp.planning.pairs import pair_costs
from hbtp.planning.planners import planner_config
from helpers import random_case

np = pytest.importorskip("numpy")
highspy = pytest.importorskip("highspy")
pytestmark = pytest.mark.skipif(not flow.COMPILED, reason="the C extension hbtp.planning._simplex is not built")

IPC = Path(__file__).resolve().parents[3] / "shared" / "benchmarks" / "ipc"
_KERNEL: Any = compiled.extension(compiled.SIMPLEX)


def _random_program(rng: random.Random) -> tuple[int, int, list[list[tuple[int, float]]], list[float]]:
    rows, cols = rng.randint(1, 12), rng.randint(1, 16)
    columns = []
    for _ in range(cols):
        chosen = rng.sample(range(rows), rng.randint(0, min(3, rows)))
        columns.append([(r, float(rng.choice((-1, 1)))) for r in sorted(chosen)])
    costs = [float(rng.choice((0, 1, 1, 2, 3, 0.5))) for _ in range(cols)]
    return rows, cols, columns, costs


def _bounds(rng: random.Random, columns: list[list[tuple[int, float]]], rows: int) -> tuple[Any, Any]:
    """Row bounds like the state equation's: each row bounded below, above, or both (or fixed). Most
    are built around ``A Y`` for a random whole ``Y >= 0`` (so feasible), the others at random."""
    counts = [rng.randint(0, 2) for _ in columns]
    reached = [0.0] * rows
    for column, count in zip(columns, counts, strict=True):
        for r, v in column:
            reached[r] += v * count
    around = rng.random() < 0.7
    crossed = rng.random() < 0.05  # a row whose bounds cross (a mutex lowers an atom's upper bound)
    lower, upper = np.empty(rows), np.empty(rows)
    for r in range(rows):
        low = reached[r] - rng.randint(0, 1) if around else float(rng.randint(-2, 2))
        kind = rng.choice(("lower", "upper", "both", "fixed"))
        if kind == "fixed" and around:
            low = reached[r]
        lower[r] = -math.inf if kind == "upper" else low
        upper[r] = math.inf if kind == "lower" else low + (0 if kind == "fixed" else rng.randint(1, 2))
    if crossed:
        r = rng.randrange(rows)
        lower[r], upper[r] = 1.0, 0.0
    return lower, upper


def _highs(rows: int, cols: int, columns: list[list[tuple[int, float]]], costs: list[float]) -> Any:
    solver = highspy.Highs()
    solver.setOptionValue("output_flag", False)
    lp = highspy.HighsLp()
    lp.num_col_, lp.num_row_ = cols, rows
    lp.col_cost_ = np.array(costs)
    lp.col_lower_, lp.col_upper_ = np.zeros(cols), np.full(cols, highspy.kHighsInf)
    lp.row_lower_, lp.row_upper_ = np.full(rows, -highspy.kHighsInf), np.full(rows, highspy.kHighsInf)
    lp.a_matrix_.format_ = highspy.MatrixFormat.kColwise
    lp.a_matrix_.start_ = np.cumsum([0, *map(len, columns)]).astype(np.int32)
    lp.a_matrix_.index_ = np.array([r for c in columns for r, _ in c], dtype=np.int32)
    lp.a_matrix_.value_ = np.array([v for c in columns for _, v in c], dtype=float)
    solver.passModel(lp)
    return solver


def _program(rows: int, cols: int, columns: list[list[tuple[int, float]]], costs: list[float]) -> Any:
    start = np.cumsum([0, *map(len, columns)]).astype(np.int32)
    index = np.array([r for c in columns for r, _ in c], dtype=np.int32)
    value = np.array([v for c in columns for _, v in c], dtype=float)
    return _KERNEL.Program(cols, rows, start.tobytes(), index.tobytes(), value.tobytes(), np.array(costs).tobytes())


def test_a_warm_program_gives_highs_value_for_every_bound() -> None:
    """80 random programs, each asked 25 bounds in turn (each solve starts from the last basis)."""
    seen = {"optimal": 0, "infeasible": 0}
    for seed in range(80):
        rng = random.Random(seed)
        shape = _random_program(rng)
        rows, columns = shape[0], shape[2]
        program, solver = _program(*shape), _highs(*shape)
        for _ in range(25):
            lower, upper = _bounds(rng, columns, rows)
            solver.changeRowsBounds(rows, np.arange(rows, dtype=np.int32), lower, upper)
            solver.run()
            expected = solver.getModelStatus()
            status, value = program.solve(lower, upper)
            if expected == highspy.HighsModelStatus.kInfeasible:
                seen["infeasible"] += 1
                assert (status, value) == (1, math.inf), seed
                ray = np.frombuffer(program.ray(), dtype=float)
                assert ray.shape == (rows,)
                assert np.abs(ray).max() > 0
            else:
                assert expected == highspy.HighsModelStatus.kOptimal, (seed, expected)
                seen["optimal"] += 1
                assert status == 0, seed
                assert value == pytest.approx(solver.getObjectiveValue(), abs=1e-9), seed
    assert min(seen.values()) > 300, seen


def _equations(task: GroundTask, costs: dict[int, float] | None) -> tuple[StateEquation, StateEquation]:
    pairs = pair_costs(task, task.actions, costs)
    made = [StateEquation(task, task.actions, pairs, costs, compiled=c) for c in (True, False)]
    assert made[0].program is not None
    assert made[1].program is None
    return made[0], made[1]


@pytest.mark.parametrize("seed", range(60))
def test_the_state_equation_gives_the_same_values_with_the_c_simplex(seed: int) -> None:
    task = random_case(seed).task
    rng = random.Random(seed)
    atoms = range(len(task.atoms))
    for costs in (None, {a.index: float(rng.choice((0, 1, 2.5, 4))) for a in task.actions}):
        c, highs = _equations(task, costs)
        for _ in range(30):
            condition = frozenset(rng.sample(atoms, rng.randint(1, min(6, len(atoms)))))
            value, expected = c(condition), highs(condition)
            # Whole costs: rounded up, equal. Fractional: not rounded, equal to the solvers' precision.
            assert value == expected if costs is None else math.isclose(value, expected, abs_tol=1e-9), (seed, value)


@pytest.mark.skipif(not (IPC / "depot").is_dir(), reason="the shipped IPC benchmarks are not here")
@pytest.mark.parametrize(("domain", "problem"), [("depot", "p02"), ("elevators-opt08-strips", "p02")])
def test_shipped_instances_get_the_same_values_and_searches(domain: str, problem: str) -> None:
    """Every condition a search asks gets HiGHS's value from the C simplex; the search with it gives
    the same tree and counts as one with HiGHS alone."""
    scenario = load_pddl_scenario(IPC / domain / "domain.pddl", IPC / domain / f"{problem}.pddl")
    scenario, goal = scenario.resolve_goal(scenario.problem_goal())
    task = scenario.task
    c, highs = _equations(task, None)
    asked: list[frozenset[int]] = []
    original = StateEquation.__call__

    def record(self: StateEquation, condition: Any) -> float:
        asked.append(frozenset(condition))
        return original(self, condition)

    runs = []
    for compiled_simplex in (True, False):
        with pytest.MonkeyPatch.context() as patch:
            patch.setattr(StateEquation, "__call__", record)
            patch.setattr(heuristics, "StateEquation", functools.partial(StateEquation, compiled=compiled_simplex))
            result = plan(task, goal, planner_config("obtea", heuristic="seq"), mutexes=scenario.mutexes,
                          limits=Limits(time_s=120))  # fmt: skip
        runs.append((result.status, result.cost, result.stats.explored, result.stats.generated, result.expansions))
    assert runs[0] == runs[1]
    assert runs[0][1] == {"depot": 15, "elevators-opt08-strips": 26}[domain]  # Fast Downward's optima
    assert len(asked) > 50
    for condition in asked[:1500]:
        assert c(condition) == highs(condition), sorted(condition)


def test_a_solve_the_simplex_gives_up_is_asked_of_highs() -> None:
    class GivesUp:
        def solve(self, lower: Any, upper: Any) -> tuple[int, float]:
            return 2, 0.0

    task = random_case(4).task
    c, highs = _equations(task, None)
    c.program = GivesUp()
    for atom in range(len(task.atoms)):
        assert c({atom}) == highs({atom})


def test_bounds_asked_again_are_answered_from_the_kept_basis_without_a_pivot() -> None:
    rng = random.Random(7)
    shape = _random_program(rng)
    program = _program(*shape)
    for _ in range(20):
        lower, upper = _bounds(rng, shape[2], shape[0])
        first = program.solve(lower, upper)
        if first[0] == 0:
            made = program.pivots()
            assert program.solve(lower, upper) == first
            assert program.pivots() == made


def test_the_program_refuses_what_does_not_match() -> None:
    shape = (2, 1, [[(0, 1.0), (1, -1.0)]], [1.0])
    program = _program(*shape)
    with pytest.raises(RuntimeError, match="the last solve was not infeasible"):
        program.ray()
    with pytest.raises(ValueError, match="the bounds must be 2 doubles each"):
        program.solve(np.zeros(3), np.zeros(3))
    assert program.solve(np.array([1.0, -math.inf]), np.array([math.inf, -1.0])) == (0, 1.0)
    assert program.solve(np.array([1.0, -math.inf]), np.array([math.inf, -2.0])) == (0, 2.0)
    assert program.solve(np.array([-math.inf, -math.inf]), np.array([-1.0, math.inf])) == (1, math.inf)
    assert np.frombuffer(program.ray(), dtype=float)[0] != 0
    start, index = np.array([0, 2], dtype=np.int32).tobytes(), np.array([0, 5], dtype=np.int32).tobytes()
    with pytest.raises(ValueError, match="a row index is out of range"):
        _KERNEL.Program(1, 2, start, index, np.ones(2).tobytes(), np.ones(1).tobytes())
    with pytest.raises(ValueError, match="costs must be finite and >= 0"):
        _KERNEL.Program(1, 2, start, np.zeros(2, dtype=np.int32).tobytes(), np.ones(2).tobytes(),
                        np.array([-1.0]).tobytes())  # fmt: skip
    with pytest.raises(ValueError, match="the program's arrays do not match"):
        _KERNEL.Program(2, 2, start, index, np.ones(2).tobytes(), np.ones(1).tobytes())
