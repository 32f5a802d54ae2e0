"""Property tests of the backward search on small random STRIPS tasks, against a brute-force optimum.

The oracle (tests/helpers.py) is a forward uniform-cost search over states, sharing no code with the
planner. For every seed and both with and without the proved mutexes of ``infer_mutexes``:

* OBTEA (heuristic none, hmax, lm, lmcut) is complete, the path it finds is optimal and D(T), the cost of
  running its tree from s0, equals the optimum; an unsolvable task ends UNSOLVABLE;
* HBTP-O with p̂ = an optimal plan (in any order) is optimal (Proposition 1); with a sub-multiset of
  it, sound;
* every planner with any hints (none, the optimal plan, random or unknown action names) is sound
  and complete in the full action space, and never beats the optimum;
* the trees are real behavior trees: ticking them from s0 runs exactly ``result.executed`` and
  reaches the goal, and from every expanded condition (also with extra atoms) they reach the goal.

The last section keeps three counterexamples found with this generator on other seeds, hand-reduced:
two where a tree in expansion order (Algorithm 1, line 21) cost more than the path found under A* or
HBTP-O's discounts (fixed by ordering the branches by cost to the goal), and one where a sub-multiset
p̂ loses optimality in Algorithm 1 itself (strict xfail: it turns into a failure once fixed).
"""

from __future__ import annotations

import functools
import random
from collections.abc import Iterable

import pytest

from hbtp.bt import Condition, Fallback, Sequence, full_tree, path_tree
from hbtp.domains import DomainBuilder
from hbtp.domains.mutex import Mutexes, infer_mutexes
from hbtp.logic.task import GroundTask
from hbtp.planning import Hints, PlanResult, Status, plan
from helpers import RandomCase, brute_force, is_subsequence, plan_cost, random_case, reaches, run_tree

SEEDS = range(600)
HEURISTICS = ("none", "hmax", "lm", "lmcut", "seq")


@functools.cache
def case_of(seed: int) -> RandomCase:
    return random_case(seed)


# Seeds whose task has an optimal plan with at least one action (computed at collection: ~0.5 s).
PLANNED_SEEDS = [seed for seed in SEEDS if case_of(seed).plan]


@functools.cache
def mutexes_of(seed: int) -> Mutexes:
    return infer_mutexes(case_of(seed).task)


def mutex_variants(seed: int) -> Iterable[tuple[str, Mutexes | None]]:
    yield "no-mutexes", None
    yield "inferred-mutexes", mutexes_of(seed)


def names(task: GroundTask, actions: Iterable[int]) -> tuple[str, ...]:
    return tuple(task.actions[i].name for i in actions)


def describe(case: RandomCase, result: PlanResult, label: str) -> str:
    task = case.task
    return (
        f"seed={case.seed} {result.planner} [{label}] goal={case.goal} s0={task.names(task.initial_state)} "
        f"optimum={case.optimum} plan={list(names(task, case.plan))}: status={result.status.value} "
        f"cost={result.cost} solution={list(names(task, result.solution))} "
        f"executed={list(names(task, result.executed))}"
    )


def check_result(case: RandomCase, result: PlanResult, label: str) -> None:
    """Soundness and completeness of one run in the full space, and the trees it builds."""
    where = describe(case, result, label)
    task, goal = case.task, case.goal
    if case.optimum is None:
        assert result.status is Status.UNSOLVABLE, where
        assert result.cost is None, where
        assert result.executed == (), where
        assert result.solution == (), where
        check_robust(case, result, label)
        return
    assert result.status is Status.SOLVED, where
    assert result.cost is not None, where
    assert result.cost >= case.optimum, where
    assert result.expansions[0].condition == goal.ids, where
    assert result.expansions[0].action is None, where
    assert result.expansions[-1].condition <= task.initial_state, where
    # the path found executes from s0
    assert reaches(task, result.solution, goal.ids), where
    assert plan_cost(task, result.solution) >= case.optimum, where
    # the executed actions are what running the tree from s0 does, and they reach the goal
    assert reaches(task, result.executed, goal.ids), where
    assert plan_cost(task, result.executed) == result.cost, where
    # only the last expansion holds in s0, and the tree pays at most its cost to the goal
    assert result.cost <= plan_cost(task, result.solution) == result.expansions[-1].cost_to_goal, where
    limit = len(result.expansions) + 1
    run = run_tree(full_tree(result.expansions), task, task.initial_state, limit)
    assert run.reached, where
    assert goal.ids <= run.state, where
    assert run.actions == result.executed, where
    assert run.cost == result.cost, where
    # the path-only tree reaches the goal too, running a subsequence of the path found
    path_run = run_tree(path_tree(result.expansions), task, task.initial_state, limit)
    assert path_run.reached, where
    assert goal.ids <= path_run.state, where
    assert is_subsequence(path_run.actions, result.solution), where
    check_robust(case, result, label)


def check_robust(case: RandomCase, result: PlanResult, label: str) -> None:
    """From every expanded condition, taken as a state (alone and with extra atoms), the tree reaches
    the goal in at most k actions when the condition is branch k (each action leads to a state where
    a branch placed before it holds)."""
    if not result.expansions:
        return
    task, goal = case.task, case.goal
    tree = full_tree(result.expansions)
    assert isinstance(tree, Fallback)
    assert len(tree.children) == len(result.expansions)
    branch_of = {
        child.children[0].literals: k
        for k, child in enumerate(tree.children)
        if isinstance(child, Sequence) and isinstance(child.children[0], Condition)
    }
    branch_of[goal.ids] = 0
    rng = random.Random(case.seed * 7919 + len(label))
    all_atoms = range(len(task.atoms))
    for position, expansion in enumerate(result.expansions):
        extra = frozenset(rng.sample(all_atoms, rng.randint(0, len(task.atoms))))
        limit = branch_of[expansion.condition] + 1
        for state in (expansion.condition, expansion.condition | extra):
            run = run_tree(tree, task, state, limit)
            where = (
                f"seed={case.seed} {result.planner} [{label}]: from expanded condition #{position} "
                f"{task.names(expansion.condition)} (state {task.names(state)}) the tree does not reach "
                f"the goal in {limit} ticks: ran {list(names(task, run.actions))}"
            )
            assert run.reached, where
            assert goal.ids <= run.state, where


# ------------------------------------------------------------------ the oracle itself
def test_brute_force_finds_the_cheap_detour_and_proves_unsolvability() -> None:
    task = (
        DomainBuilder("oracle")
        .action("Direct(x)", add=["G(x)"], cost=9)
        .action("Prepare(x)", add=["P(x)"], cost=2)
        .action("Finish(x)", pre=["P(x)"], add=["G(x)"], delete=["P(x)"], cost=3)
        .action("Spoil(x)", pre=["G(x)"], add=["S(x)"], delete=["G(x)"], cost=1)
        .action("Never(x)", pre=["Z(x)"], add=["H(x)"], cost=1)
        .build()
    )
    optimum, found = brute_force(task, task.resolve_goal("G(x)").ids)
    assert optimum == 5
    assert names(task, found) == ("Prepare(x)", "Finish(x)")
    assert brute_force(task, task.resolve_goal("G(x) & H(x)").ids) == (None, ())
    assert brute_force(task, task.resolve_goal("S(x)").ids)[0] == 6
    assert brute_force(task, task.resolve_goal("G(x) & S(x)").ids)[0] == 11  # G is deleted by Spoil: redo it
    assert brute_force(task, task.resolve_goal("S(x) & P(x)").ids)[0] == 8  # Prepare, Finish, Spoil, Prepare


def test_generated_cases_cover_the_interesting_situations() -> None:
    """The properties below are not vacuous: the seeds give solvable and unsolvable tasks, longer
    plans, proved mutexes, goals that clash with a mutex and goals with a literal nothing adds."""
    cases = [case_of(seed) for seed in SEEDS]
    solvable = [c for c in cases if c.optimum is not None]
    assert len(solvable) >= 150
    assert len(cases) - len(solvable) >= 150
    assert sum(len(c.plan) >= 3 for c in solvable) >= 30
    assert sum(bool(mutexes_of(c.seed).groups) for c in cases) >= 200
    assert sum(mutexes_of(c.seed).conflict(c.goal.ids) is not None for c in cases) >= 20
    assert sum(bool(c.goal.unreachable) for c in cases) >= 50
    assert len({c.optimum for c in solvable}) >= 15


# ------------------------------------------------------------------ OBTEA: optimal
@pytest.mark.parametrize("seed", SEEDS)
def test_obtea_is_complete_and_optimal(seed: int) -> None:
    case = case_of(seed)
    for label, mutexes in mutex_variants(seed):
        for heuristic in HEURISTICS:
            result = plan(case.task, case.goal, "obtea", heuristic=heuristic, mutexes=mutexes)
            tag = f"{label}, heuristic={heuristic}"
            check_result(case, result, tag)
            if case.optimum is not None:
                where = describe(case, result, tag)
                assert plan_cost(case.task, result.solution) == case.optimum, where
                assert result.cost == case.optimum, where


# ------------------------------------------------------------------ HBTP-O: Proposition 1
@pytest.mark.parametrize("seed", PLANNED_SEEDS)
def test_hbtp_o_with_an_optimal_plan_as_hints_is_optimal(seed: int) -> None:
    case = case_of(seed)
    task = case.task
    optimal = names(task, case.plan)
    shuffled = list(optimal)
    random.Random(seed).shuffle(shuffled)  # I(p̂, a) counts actions: the order of p̂ does not matter
    for label, mutexes in mutex_variants(seed):
        for heuristic in HEURISTICS:
            for path in (optimal, tuple(shuffled)):
                result = plan(
                    task,
                    case.goal,
                    "hbtp-o",
                    hints=Hints(path=path),
                    heuristic=heuristic,
                    alpha=10_000,
                    mutexes=mutexes,
                )
                tag = f"{label}, heuristic={heuristic}, hints={list(path)}"
                check_result(case, result, tag)
                assert result.cost == case.optimum, describe(case, result, tag)


@pytest.mark.parametrize("seed", PLANNED_SEEDS)
def test_hbtp_o_with_a_sub_multiset_of_an_optimal_plan_is_sound(seed: int) -> None:
    """Proposition 1 allows I(p̂, a) <= I(p*, a); Algorithm 1 keeps one value per condition, so the
    discount can be spent on a worse branch (see the xfail counterexample below): only soundness and
    D(T) >= optimum are guaranteed here."""
    case = case_of(seed)
    task = case.task
    rng = random.Random(seed)
    optimal = names(task, case.plan)
    for label, mutexes in mutex_variants(seed):
        for heuristic in ("none", "lm", "lmcut"):
            path = tuple(name for name in optimal if rng.random() < 0.5)
            result = plan(task, case.goal, "hbtp-o", hints=Hints(path=path), heuristic=heuristic, mutexes=mutexes)
            check_result(case, result, f"{label}, heuristic={heuristic}, hints={list(path)}")


# ------------------------------------------------------------------ every planner: sound and complete
def hint_variants(case: RandomCase, rng: random.Random) -> list[tuple[str, Hints | None]]:
    task = case.task
    all_names = [a.name for a in task.actions]
    variants: list[tuple[str, Hints | None]] = [("no hints", None)]
    if case.plan:
        variants.append(("optimal plan", Hints(path=names(task, case.plan))))
    wrong = tuple(rng.choice(all_names) for _ in range(rng.randint(1, 6)))
    variants.append((f"random actions {list(wrong)}", Hints(path=wrong)))
    unknown = (*wrong[:2], "Teleport(x0)", "Op99(x0)", "Fly_moon", "not an action")
    variants.append((f"with unknown names {list(unknown)}", Hints(path=unknown, predicates=("Nope",))))
    return variants


@pytest.mark.parametrize("seed", SEEDS)
def test_every_planner_is_sound_and_complete_with_any_hints(seed: int) -> None:
    case = case_of(seed)
    rng = random.Random(seed)
    for label, mutexes in mutex_variants(seed):
        for hint_label, hints in hint_variants(case, rng):
            for planner in ("bte", "hbtp-s", "hbtp-o"):
                for heuristic in ("none", "lm", "lmcut"):
                    result = plan(case.task, case.goal, planner, hints=hints, heuristic=heuristic, mutexes=mutexes)
                    check_result(case, result, f"{label}, heuristic={heuristic}, {hint_label}")


def test_goal_already_true_in_s0_costs_nothing() -> None:
    task = (
        DomainBuilder("trivial")
        .action("Make(x)", add=["G(x)"], cost=4)
        .action("Undo(x)", pre=["G(x)"], delete=["G(x)"], add=["H(x)"], cost=1)
        .initial(["G(x)"])
        .build()
    )
    for planner in ("bte", "obtea", "hbtp-o", "hbtp-s"):
        for heuristic in HEURISTICS:
            result = plan(task, "G(x)", planner, heuristic=heuristic, hints=Hints(path=("Undo(x)",)))
            assert result.status is Status.SOLVED
            assert result.cost == 0
            assert result.executed == ()
            assert result.solution == ()
            assert len(result.expansions) == 1


# ------------------------------------------------------------------ counterexamples (regressions, one strict xfail)
def _tree_order_task() -> GroundTask:
    """Optimal: Prep, FinA (7). With an admissible heuristic, A* expands {B, P} (g=4, f=6) before
    {A, P, Q} (g=3, f=7); both hold after Prep, so a tree in expansion order runs FinB, not FinA."""
    return (
        DomainBuilder("tree-order")
        .action("Prep(x)", pre=["P(x)"], add=["A(x)", "B(x)"], cost=4)
        .action("FinA(x)", pre=["A(x)", "Q(x)"], add=["R(x)"], cost=3)
        .action("FinB(x)", pre=["B(x)"], add=["Q(x)", "R(x)"], delete=["A(x)", "B(x)"], cost=4)
        .action("Cheap(x)", add=["B(x)"], delete=["P(x)"], cost=2)
        .initial(["P(x)", "Q(x)"])
        .build()
    )


@pytest.mark.parametrize("heuristic", HEURISTICS)
def test_obtea_tree_cost_is_optimal_on_the_tree_order_counterexample(heuristic: str) -> None:
    """With the branches in expansion order (Algorithm 1, line 21), A* made D(T) = 8 here; the tree
    is now ordered by the real cost to the goal."""
    task = _tree_order_task()
    goal = task.resolve_goal("P(x) & Q(x) & R(x)")
    assert brute_force(task, goal.ids)[0] == 7
    result = plan(task, goal, "obtea", heuristic=heuristic)
    assert plan_cost(task, result.solution) == 7  # the path found is optimal in every case
    assert result.cost == 7, names(task, result.executed)


def _discounted_order_task() -> GroundTask:
    """Optimal: Start, Swap, Finish, Back (20). HBTP-O with exactly that p̂ and ``lm`` finds it; with
    the branches in expansion order its tree, run from s0, repeated Start (6) where Back (4) was
    planned: D(T) = 22."""
    return (
        DomainBuilder("discounted-order")
        .action("Start(x)", add=["B(x)", "E(x)"], cost=6)
        .action("Swap(x)", pre=["B(x)"], add=["N(x)"], delete=["B(x)"], cost=7)
        .action("Back(x)", pre=["N(x)"], add=["B(x)"], cost=4)
        .action("Finish(x)", pre=["N(x)"], add=["G(x)"], cost=3)
        .build()
    )


@pytest.mark.parametrize("heuristic", HEURISTICS)
def test_hbtp_o_with_exact_hints_on_the_discounted_order_counterexample(heuristic: str) -> None:
    task = _discounted_order_task()
    goal = task.resolve_goal("B(x) & E(x) & G(x)")
    optimum, found = brute_force(task, goal.ids)
    assert optimum == 20
    result = plan(task, goal, "hbtp-o", hints=Hints(path=names(task, found)), heuristic=heuristic)
    assert plan_cost(task, result.solution) == 20
    assert result.cost == 20, names(task, result.executed)


def _spent_discount_task() -> GroundTask:
    """Optimal: Make, Step, Top (21). With p̂ = (Make), a sub-multiset of it, the goal {G, C} is
    regressed through Make (discounted) and through Top (full cost) to the same condition {G}.
    Algorithm 1 keeps the cheaper value, whose Make discount is already spent; the branch through Top,
    which would still discount the first Make, is dropped, and the search returns Make, Step, Make (22)."""
    return (
        DomainBuilder("spent-discount")
        .action("Make(x)", add=["B(x)", "C(x)"], cost=9)
        .action("Top(x)", add=["C(x)"], cost=8)
        .action("Step(x)", pre=["B(x)"], add=["G(x)"], delete=["C(x)"], cost=4)
        .build()
    )


@pytest.mark.parametrize(
    "path",
    [
        ("Make(x)", "Step(x)", "Top(x)"),
        pytest.param(
            ("Make(x)",),
            marks=pytest.mark.xfail(
                strict=True,
                reason="Algorithm 1 keys h(c) and I(c, .) by the condition alone, so a sub-multiset p̂ "
                "can spend its discount on a branch that is not optimal (Proposition 1 is about paths)",
            ),
        ),
    ],
)
@pytest.mark.parametrize("heuristic", ["none", "lm"])
def test_hbtp_o_on_the_spent_discount_counterexample(path: tuple[str, ...], heuristic: str) -> None:
    task = _spent_discount_task()
    goal = task.resolve_goal("G(x) & C(x)")
    assert brute_force(task, goal.ids)[0] == 21
    result = plan(task, goal, "hbtp-o", hints=Hints(path=path), heuristic=heuristic)
    assert result.solved
    assert result.cost == 21, names(task, result.executed)
