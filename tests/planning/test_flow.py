"""The state equation from s0 (hbtp.planning.flow), checked against the true cost.

* it is admissible: on random conditions of random tasks (with zero-cost actions, and on the compiled
  tasks of negative preconditions through the optimality tests of every heuristic) it never exceeds
  the cheapest cost of reaching a state that holds the condition (brute force), and it is ``inf`` only
  when no reachable state holds the condition;
* over the actions relevant to a goal it is still a lower bound on the conditions a search of that
  goal regresses;
* it counts: a condition whose counter disagrees with the tokens put away is ``inf``, where h², LM-cut
  and landmarks see nothing wrong;
* OBTEA with ``seq`` finds Fast Downward's optimal cost on shipped IPC instances (elevators, transport)
  with less than half the conditions ``lmcut`` explores, and its tree reaches the goal;
* the same instance gives the same tree every time;
* it still answers when another part of the process started HiGHS with more threads;
* without HiGHS the heuristic is refused in one line that says how to install it (``bench pddl``:
  before any run, nothing written), and the CLI prints no solver banner.
"""

from __future__ import annotations

import json
import math
import random
import subprocess
import sys
from pathlib import Path

import pytest

from hbtp.bt import full_tree
from hbtp.bt.simulate import simulate
from hbtp.cli import main
from hbtp.cli.exit_codes import ExitCode
from hbtp.domains import DomainBuilder, load_pddl_scenario
from hbtp.errors import InputError
from hbtp.logic.task import GroundTask
from hbtp.planning import plan
from hbtp.planning.flow import StateEquation
from hbtp.planning.lmcut import LmCut
from hbtp.planning.pairs import pair_costs
from hbtp.planning.planners import planner_config
from helpers import brute_force, cheapest, random_case, relevant_conditions

IPC = Path(__file__).resolve().parents[3] / "shared" / "benchmarks" / "ipc"


def equation(task: GroundTask, costs: dict[int, float] | None = None) -> StateEquation:
    return StateEquation(task, task.actions, pair_costs(task, task.actions, costs), costs)


@pytest.mark.parametrize("seed", range(150))
def test_the_state_equation_is_admissible(seed: int) -> None:
    task = random_case(seed).task
    rng = random.Random(seed)
    costs = {a.index: float(rng.choice((0, 1, 2, 5))) if seed % 3 == 0 else float(a.cost) for a in task.actions}
    seq = equation(task, costs if seed % 3 == 0 else None)

    def successors(state: frozenset[int]) -> list[tuple[float, frozenset[int]]]:
        return [(costs[a.index], (state - a.delete) | a.add) for a in task.actions if a.pre <= state]

    atoms = range(len(task.atoms))
    for _ in range(8):
        condition = frozenset(rng.sample(atoms, rng.randint(1, min(4, len(atoms)))))
        optimum = cheapest(task.initial_state, condition.issubset, successors)
        value = seq(condition)
        if optimum is None:
            continue
        assert value <= optimum, (seed, sorted(condition))


@pytest.mark.parametrize("seed", range(150))
def test_over_a_goals_relevant_actions_it_stays_a_lower_bound(seed: int) -> None:
    task = random_case(seed).task
    relevant, conditions = relevant_conditions(task, seed)
    part = StateEquation(task, task.restricted(relevant), pair_costs(task, task.actions))
    for condition in conditions:
        optimum, _ = brute_force(task, condition)
        if optimum is not None:
            assert part(condition) <= optimum, (seed, sorted(condition))


def counter_task(tokens: int) -> GroundTask:
    """Tokens on a table go one by one into a box whose counter goes up with each; ``Shake`` needs
    the counter at its top."""
    builder = DomainBuilder("counter").initial([*(f"OnTable(t{i})" for i in range(tokens)), "Count(c0)"])
    for i in range(tokens):
        for n in range(tokens):
            builder.action(
                f"Put(t{i},c{n})",
                pre=[f"OnTable(t{i})", f"Count(c{n})"],
                add=[f"InBox(t{i})", f"Count(c{n + 1})"],
                delete=[f"OnTable(t{i})", f"Count(c{n})"],
                cost=1,
            )
    return builder.build()


def test_it_sees_a_counter_that_disagrees_with_the_tokens() -> None:
    task = counter_task(3)
    spurious = task.resolve_goal("Count(c1) & InBox(t0) & InBox(t1)").ids
    assert brute_force(task, spurious)[0] is None
    pairs = pair_costs(task, task.actions)
    assert pairs is not None
    assert not math.isinf(pairs(spurious))  # every pair of it is reachable
    assert not math.isinf(LmCut(task, task.actions)(spurious))
    assert math.isinf(equation(task)(spurious))
    real = task.resolve_goal("Count(c2) & InBox(t0) & InBox(t1)").ids
    assert equation(task)(real) == brute_force(task, real)[0] == 2


def test_a_core_of_an_unreachable_condition_answers_for_the_conditions_that_hold_it() -> None:
    task = counter_task(3)
    seq = equation(task)
    larger = task.resolve_goal("Count(c1) & InBox(t0) & InBox(t1) & OnTable(t2)").ids
    assert math.isinf(seq(larger))
    assert seq.answered_by_core == 0
    smaller = task.resolve_goal("Count(c1) & InBox(t0) & InBox(t1)").ids  # OnTable(t2) is not in the proof
    assert math.isinf(seq(smaller))
    assert seq.answered_by_core == 1
    real = task.resolve_goal("Count(c2) & InBox(t0) & InBox(t1) & OnTable(t2)").ids
    assert seq(real) == brute_force(task, real)[0] == 2


def test_cores_never_change_a_value() -> None:
    """One equation asked many conditions in turn (its cores answer some) gives each the value of a
    fresh one, which has no core yet."""
    answered = 0
    for seed in range(60):
        task = random_case(seed).task
        rng = random.Random(seed)
        seq = equation(task)
        atoms = range(len(task.atoms))
        for _ in range(30):
            condition = frozenset(rng.sample(atoms, rng.randint(1, min(6, len(atoms)))))
            assert seq(condition) == equation(task)(condition), (seed, sorted(condition))
        answered += seq.answered_by_core
    assert answered > 0


_AFTER_ANOTHER_SOLVER = """
import highspy, math, sys
sys.path[:0] = [{here!r}, {tests!r}]
from test_flow import counter_task, equation
other = highspy.Highs()  # another part of the process starts HiGHS first, with its default threads
other.setOptionValue("output_flag", False)
other.addVar(0, 1)
other.run()
task = counter_task(3)
seq = equation(task)
print(seq(task.resolve_goal("Count(c2) & InBox(t0) & InBox(t1)").ids),
      seq(task.resolve_goal("Count(c1) & InBox(t0) & InBox(t1)").ids))
"""


def test_it_still_solves_after_another_solver_set_the_threads() -> None:
    """The state equation asks HiGHS for one thread; when the process's solver scheduler was started
    with more, it keeps theirs rather than getting no answer (which would read as 0)."""
    here = Path(__file__).parent
    script = _AFTER_ANOTHER_SOLVER.format(here=str(here), tests=str(here.parent))
    done = subprocess.run([sys.executable, "-c", script], capture_output=True, text=True, timeout=120, check=False)
    assert done.returncode == 0, done.stderr
    assert done.stdout.split()[-2:] == ["2.0", "inf"]


@pytest.mark.skipif(
    not (IPC / "elevators-opt08-strips").is_dir(), reason="the shared IPC benchmarks are not beside the checkout"
)
@pytest.mark.parametrize(("domain", "problem"), [("elevators-opt08-strips", "p02"), ("transport-opt08-strips", "p02")])
def test_obtea_with_seq_is_optimal_and_explores_less_on_ipc_instances(domain: str, problem: str) -> None:
    loaded = load_pddl_scenario(IPC / domain / "domain.pddl", IPC / domain / f"{problem}.pddl")
    scenario, goal = loaded.resolve_goal(loaded.problem_goal())
    optimum = json.loads((IPC / "fd_optimal_costs.json").read_text(encoding="utf-8"))[domain][problem]
    with_lmcut = plan(scenario.task, goal, "obtea", heuristic="lmcut", mutexes=scenario.mutexes)
    with_seq = plan(scenario.task, goal, "obtea", heuristic="seq", mutexes=scenario.mutexes)
    assert with_seq.cost == with_lmcut.cost == optimum
    assert simulate(full_tree(with_seq.expansions), scenario.task).reached(goal)
    assert with_seq.stats.explored * 2 < with_lmcut.stats.explored


@pytest.mark.skipif(
    not (IPC / "transport-opt08-strips").is_dir(), reason="the shared IPC benchmarks are not beside the checkout"
)
def test_seq_plans_the_same_tree_every_time() -> None:
    def expansions() -> tuple[object, ...]:
        files = IPC / "transport-opt08-strips"
        loaded = load_pddl_scenario(files / "domain.pddl", files / "p02.pddl")
        scenario, goal = loaded.resolve_goal(loaded.problem_goal())
        return plan(scenario.task, goal, "obtea", heuristic="seq", mutexes=scenario.mutexes).expansions

    assert expansions() == expansions()


def test_without_highs_seq_is_refused_in_one_line(monkeypatch: pytest.MonkeyPatch) -> None:
    monkeypatch.setitem(sys.modules, "highspy", None)
    with pytest.raises(InputError, match=r"pip install 'hbtp\[lp\]'") as raised:
        planner_config("obtea", heuristic="seq")
    assert "\n" not in str(raised.value)


def test_bench_pddl_without_highs_stops_before_it_starts(
    monkeypatch: pytest.MonkeyPatch, tmp_path: Path, capsys: pytest.CaptureFixture[str]
) -> None:
    monkeypatch.setitem(sys.modules, "highspy", None)
    (tmp_path / "suite" / "d").mkdir(parents=True)
    out = tmp_path / "out"
    assert main(["bench", "pddl", str(tmp_path / "suite"), "--no-progress", "-o", str(out)]) == ExitCode.INPUT
    assert capsys.readouterr().err.strip().splitlines() == [
        "hbtp: error: the state-equation heuristic (seq) needs HiGHS: pip install 'hbtp[lp]' (highspy)"
    ]
    assert not out.exists()


def test_the_cli_plans_with_seq_and_prints_no_solver_banner() -> None:
    done = subprocess.run(
        [sys.executable, "-m", "hbtp", "plan", "-s", "robowaiter", "-p", "obtea", "--heuristic", "seq", "-g",
         "On_Coffee_Bar"],
        capture_output=True, text=True, timeout=120, check=False,
    )  # fmt: skip
    assert done.returncode == 0, done.stderr
    assert "HiGHS" not in done.stdout + done.stderr
