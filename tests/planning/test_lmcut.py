"""LM-cut from s0 to a regressed condition, and the search that evaluates it deferred and re-opens.

* LM-cut's rounds in C (the optional extension) and in Python give the same values and leave the
  same states (h_max, precondition values and choices, costs), to the last bit, on random tasks and
  on the shipped scenarios; where the extension is built, everything else here runs with it too;
* LM-cut is admissible: on random tasks and random conditions it never exceeds the optimal cost of
  the delete relaxation (h+, by brute force), and it is at least h_max;
* on gripper it finds the textbook landmarks (a pick and a drop per ball, one move): 2n + 1 = h+;
* OBTEA with ``lmcut`` is optimal against the brute-force optimum (also in tests/planning/test_search_random.py);
* a Deferred heuristic's costly estimates are computed one at a time: the second only for a
  condition the first did not push beyond the priority it came off the list with;
* the search's re-opening keeps OBTEA optimal under an admissible, deliberately inconsistent
  estimate (the exact cost for half of the conditions, 0 for the rest), and does re-open; the tree,
  with the old branches of re-opened conditions, reaches the goal from every condition in it.
"""

from __future__ import annotations

import heapq
import importlib
import itertools
import math
import random
from collections.abc import Collection, Iterable, Sequence

import pytest

from hbtp.bt import full_tree
from hbtp.domains import DomainBuilder, load_scenario
from hbtp.errors import PlanningError
from hbtp.logic.task import GroundAction, GroundTask
from hbtp.planning import plan
from hbtp.planning.heuristics import Deferred, Heuristic, HMax, build_heuristic, hmax_table
from hbtp.planning.lmcut import LmCut
from helpers import brute_force, random_case, relevant_conditions, run_tree

search_module = importlib.import_module("hbtp.planning.search_state")  # where the search builds its heuristic
lmcut_module = importlib.import_module("hbtp.planning.lmcut")
#: The ways to make LM-cut's rounds here: in Python, and in C where the extension is built.
KERNELS = [False, True] if lmcut_module.COMPILED else [False]
needs_c = pytest.mark.skipif(not lmcut_module.COMPILED, reason="LM-cut's C extension is not built (no C compiler)")


def relaxed_optimum(task: GroundTask, condition: frozenset[int]) -> float:
    """h+: the cheapest plan for ``condition`` ignoring deletes (Dijkstra over growing atom sets)."""
    start = task.initial_state
    best = {start: 0}
    heap = [(0, 0, start)]
    counter = itertools.count()
    while heap:
        cost, _, state = heapq.heappop(heap)
        if cost > best[state]:
            continue
        if condition <= state:
            return float(cost)
        for action in task.actions:
            if action.pre <= state and not action.add <= state:
                successor = state | action.add
                value = cost + action.cost
                if value < best.get(successor, value + 1):
                    best[successor] = value
                    heapq.heappush(heap, (value, next(counter), successor))
    return math.inf


@pytest.mark.parametrize("compiled", KERNELS)
@pytest.mark.parametrize("seed", range(150))
def test_lmcut_lies_between_hmax_and_the_relaxed_optimum(seed: int, compiled: bool) -> None:
    case = random_case(seed)
    task = case.task
    lmcut = LmCut(task, task.actions, compiled=compiled)
    hmax = HMax(hmax_table(task, task.actions))
    rng = random.Random(seed)
    atoms = range(len(task.atoms))
    for _ in range(8):
        condition = frozenset(rng.sample(atoms, rng.randint(1, min(4, len(atoms)))))
        value, relaxed = lmcut(condition), relaxed_optimum(task, condition)
        assert hmax(condition) <= value <= relaxed, (seed, sorted(condition))
        assert math.isinf(value) == math.isinf(relaxed)


def forward_cut(state: lmcut_module._Round, zone: set[int], top: float) -> list[int]:
    """The cut by its definition: a forward search from s0 over precondition choices that does not
    enter ``zone``; the actions it meets that add an atom of the zone."""
    lm = state.lm
    reached = set(lm.initial)
    stack = list(lm.initial)
    cut = []
    while stack:
        p = stack.pop()
        for i in lm.users[p]:
            if state.choice[i] != p:
                continue
            adds = set(lm.add[i])
            if adds & zone:
                cut.append(i)
            fresh = adds - zone - reached
            reached |= fresh
            stack.extend(fresh)
    return cut


@pytest.mark.parametrize("seed", range(150))
def test_the_cut_from_the_zones_achievers_equals_the_forward_search(seed: int, monkeypatch: pytest.MonkeyPatch) -> None:
    """The cut read off the zone's achievers (h_max below the zone's, else a search backwards) is
    the set of actions the forward search from s0 finds, on random tasks and conditions."""
    task = random_case(seed).task
    rng = random.Random(seed)
    atoms = range(len(task.atoms))
    conditions = [frozenset(rng.sample(atoms, rng.randint(1, min(5, len(atoms))))) for _ in range(12)]
    fast = lmcut_module._Round._cut_actions
    cuts = 0

    def compared(state: lmcut_module._Round, zone: set[int], top: float) -> list[int]:
        nonlocal cuts
        cut = fast(state, zone, top)
        assert sorted(cut) == sorted(forward_cut(state, zone, top)), (seed, sorted(zone))
        cuts += 1
        return cut

    monkeypatch.setattr(lmcut_module._Round, "_cut_actions", compared)
    lmcut = LmCut(task, task.actions, compiled=False)
    values = [lmcut(c) for c in conditions]
    assert cuts > 0 or all(v in (0.0, math.inf) for v in values)


@pytest.mark.parametrize("seed", range(150))
def test_lmcut_over_the_actions_relevant_to_a_goal_equals_lmcut_over_all(seed: int) -> None:
    """The search evaluates LM-cut over the actions relevant to the goal only: on every condition
    made of the goal's atoms and the preconditions of relevant actions it gives the whole space's value."""
    task = random_case(seed).task
    relevant, conditions = relevant_conditions(task, seed)
    whole, part = LmCut(task, task.actions), LmCut(task, task.restricted(relevant))
    for condition in conditions:
        assert part(condition) == whole(condition), (seed, sorted(condition))


def gripper(balls: int) -> GroundTask:
    builder = DomainBuilder(f"gripper-{balls}")
    rooms, hands = ("a", "b"), ("left", "right")
    for here, there in itertools.permutations(rooms):
        builder.action(f"Move({here},{there})", pre=[f"At_robby({here})"], add=[f"At_robby({there})"],
                       delete=[f"At_robby({here})"])  # fmt: skip
    for ball, room, hand in itertools.product(range(balls), rooms, hands):
        at, carry, robby, free = f"At(b{ball},{room})", f"Carry(b{ball},{hand})", f"At_robby({room})", f"Free({hand})"
        builder.action(f"Pick(b{ball},{room},{hand})", pre=[at, robby, free], add=[carry], delete=[at, free])
        builder.action(f"Drop(b{ball},{room},{hand})", pre=[carry, robby], add=[at, free], delete=[carry])
    builder.initial(["At_robby(a)", "Free(left)", "Free(right)", *(f"At(b{i},a)" for i in range(balls))])
    return builder.build()


@pytest.mark.parametrize("balls", [1, 3, 6])
def test_lmcut_finds_the_landmarks_of_gripper(balls: int) -> None:
    task = gripper(balls)
    goal = task.resolve_goal([f"At(b{i},b)" for i in range(balls)])
    assert LmCut(task, task.actions)(goal.literal_ids) == 2 * balls + 1
    heuristic = build_heuristic("lmcut", task, task.actions, goal.literal_ids)
    assert isinstance(heuristic, Deferred)
    assert heuristic.refine(goal.literal_ids) == 2 * balls + 1
    # The cheap part (landmarks, h_max and h²) is exact for one ball (pick, move, drop), weaker for more.
    cheap = heuristic(goal.literal_ids)
    assert cheap == 3 if balls == 1 else cheap < 2 * balls + 1


def test_lmcut_with_changed_costs_uses_them() -> None:
    task = gripper(2)
    goal = task.resolve_goal(["At(b0,b)", "At(b1,b)"])
    doubled = {a.index: 2.0 * a.cost for a in task.actions}
    assert LmCut(task, task.actions, doubled)(goal.literal_ids) == 2 * 5
    halved = {a.index: 0.5 * a.cost for a in task.actions}
    assert LmCut(task, task.actions, halved)(goal.literal_ids) == pytest.approx(2.5)


@pytest.mark.parametrize("balls", [2, 3])
def test_obtea_with_lmcut_is_optimal_on_gripper(balls: int) -> None:
    task = gripper(balls)
    goal = task.resolve_goal([f"At(b{i},b)" for i in range(balls)])
    optimum, _ = brute_force(task, goal.literal_ids)
    result = plan(task, goal, "obtea", heuristic="lmcut")
    assert result.solved
    assert result.cost == optimum
    lm = plan(task, goal, "obtea", heuristic="lm")
    assert result.stats.explored < lm.stats.explored


class _Zero:
    """0, or ``inf`` where h_max is (consistent; the search is then ordered by the refined value)."""

    def __init__(self, hmax: Heuristic) -> None:
        self.hmax = hmax

    def __call__(self, condition: Iterable[int]) -> float:
        return math.inf if math.isinf(self.hmax(condition)) else 0.0

    def precondition_bound(self, action: GroundAction) -> float:
        return 0.0


class _Inconsistent:
    """An admissible estimate that is exact on two thirds of the conditions and 0 on the others."""

    def __init__(self, task: GroundTask) -> None:
        self.task = task
        self.known: dict[frozenset[int], float] = {}

    def __call__(self, condition: frozenset[int]) -> float:
        if sum(condition) % 3 == 0:
            return 0.0
        if condition not in self.known:
            optimum, _ = brute_force(self.task, condition)
            self.known[condition] = math.inf if optimum is None else float(optimum)
        return self.known[condition]


def test_reopening_keeps_obtea_optimal_under_an_inconsistent_estimate(monkeypatch: pytest.MonkeyPatch) -> None:
    def inconsistent(
        name: str, task: GroundTask, actions: Sequence[GroundAction], goal: Collection[int], **options: object
    ) -> Deferred:
        hmax = build_heuristic("hmax", task, actions, goal, **options)  # type: ignore[arg-type]
        assert hmax is not None
        return Deferred(_Zero(hmax), _Inconsistent(task))

    monkeypatch.setattr(search_module, "build_heuristic", inconsistent)
    reopened = 0
    for seed in range(600):  # seeds 31, 205, 528 and 594 re-open
        case = random_case(seed)
        result = plan(case.task, case.goal, "obtea", heuristic="lmcut")
        reopened += result.stats.reopened
        if case.optimum is None:
            assert not result.solved, seed
            continue
        assert result.solved, seed
        assert result.cost == case.optimum, seed
        assert sum(case.task.actions[i].cost for i in result.solution) == case.optimum
        tree, ticks = full_tree(result.expansions), 2 * len(result.expansions) + 2
        for expansion in result.expansions:  # a re-opened condition's old branch stays, and is sound
            assert run_tree(tree, case.task, expansion.condition, ticks).reached, seed
    assert reopened > 0


class _Exact:
    """The cost of reaching a condition from s0 (brute force, ``inf``: never); counts what it is asked."""

    def __init__(self, task: GroundTask, zero: bool = False) -> None:
        self.task = task
        self.zero = zero
        self.asked: list[frozenset[int]] = []

    def __call__(self, condition: frozenset[int]) -> float:
        self.asked.append(condition)
        if self.zero:
            return 0.0
        optimum, _ = brute_force(self.task, condition)
        return math.inf if optimum is None else float(optimum)


@pytest.mark.parametrize("first_is_exact", [True, False])
def test_deferred_estimates_are_computed_one_at_a_time(monkeypatch: pytest.MonkeyPatch, first_is_exact: bool) -> None:
    """Two costly estimates. With the exact cost first, a condition it puts beyond the optimum is not
    taken off the list again, so the second is asked about fewer conditions, and only about ones the
    first was asked about; with 0 first (it raises nothing), the second is asked about every one.
    OBTEA stays optimal either way and its tree reaches the goal."""
    made: list[tuple[_Exact, _Exact]] = []

    def lazy(
        name: str, task: GroundTask, actions: Sequence[GroundAction], goal: Collection[int], **options: object
    ) -> Deferred:
        hmax = build_heuristic("hmax", task, actions, goal, **options)  # type: ignore[arg-type]
        assert hmax is not None
        parts = (_Exact(task, zero=not first_is_exact), _Exact(task, zero=first_is_exact))
        made.append(parts)
        return Deferred(_Zero(hmax), *parts)

    monkeypatch.setattr(search_module, "build_heuristic", lazy)
    first_asked = second_asked = 0
    for seed in range(60):
        case = random_case(seed)
        result = plan(case.task, case.goal, "obtea", heuristic="lmcut")
        if not made:  # the goal holds in s0, or a literal is never reachable: nothing to estimate
            assert (result.cost if result.solved else None) == case.optimum in (0, None), seed
            continue
        first, second = made.pop()
        assert set(second.asked) <= set(first.asked), seed
        first_asked, second_asked = first_asked + len(first.asked), second_asked + len(second.asked)
        if case.optimum is None:
            assert not result.solved, seed
            continue
        assert result.cost == case.optimum, seed
        tree = full_tree(result.expansions)
        assert run_tree(tree, case.task, case.task.initial_state, 2 * len(result.expansions) + 2).reached, seed
    if first_is_exact:  # computing both at once would ask the second as often as the first
        assert second_asked < first_asked
    else:
        assert second_asked == first_asked


def test_a_deferred_heuristic_needs_a_costly_part() -> None:
    with pytest.raises(ValueError, match="costly part"):
        Deferred(_Zero(HMax([])))


def test_reopening_finds_the_path_an_inconsistent_estimate_hid(monkeypatch: pytest.MonkeyPatch) -> None:
    """S -E(10)-> W; W -C1(10)-> X -A1(1)-> G costs 21, W -C2(1)-> Y -A2(5)-> G costs 16. The estimate
    says 0 for X and W (admissible, inconsistent: h*(W) = 10) and 11 for Y, so {W} is expanded first
    at g = 11 (through X), then reached at g = 6 through Y: re-opened, the optimum is found."""
    builder = DomainBuilder("reopen")
    for name, pre, add, cost in [("E", "S", "W", 10), ("C1", "W", "X", 10), ("A1", "X", "G", 1),
                                 ("C2", "W", "Y", 1), ("A2", "Y", "G", 5)]:  # fmt: skip
        builder.action(f"{name}(o)", pre=[f"{pre}(o)"], add=[f"{add}(o)"], cost=cost)
    task = builder.initial(["S(o)"]).build()
    estimate = {"G(o)": 16.0, "Y(o)": 11.0}

    def inconsistent(
        name: str, task: GroundTask, actions: Sequence[GroundAction], goal: Collection[int], **options: object
    ) -> Deferred:
        hmax = build_heuristic("hmax", task, actions, goal, **options)  # type: ignore[arg-type]
        assert hmax is not None
        return Deferred(_Zero(hmax), lambda c: max((estimate.get(str(task.atoms[a]), 0.0) for a in c), default=0.0))

    monkeypatch.setattr(search_module, "build_heuristic", inconsistent)
    result = plan(task, task.resolve_goal(["G(o)"]), "obtea", heuristic="lmcut")
    assert result.stats.reopened == 1
    assert result.cost == 16
    assert [task.actions[i].name for i in result.executed] == ["E(o)", "C2(o)", "A2(o)"]
    tree, ticks = full_tree(result.expansions), 2 * len(result.expansions) + 2
    for expansion in result.expansions:  # {W} twice: the branch through Y comes first
        assert run_tree(tree, task, expansion.condition, ticks).reached


def test_planning_with_lmcut_is_deterministic_with_a_warm_table() -> None:
    """The table of states after cuts is kept with the task; a second search that reuses it, and a
    search on a fresh copy of the task, give the very same tree."""
    goal_atoms = [f"At(b{i},b)" for i in range(4)]
    task = gripper(4)
    first = plan(task, task.resolve_goal(goal_atoms), "obtea", heuristic="lmcut")
    again = plan(task, task.resolve_goal(goal_atoms), "obtea", heuristic="lmcut")
    fresh_task = gripper(4)
    fresh = plan(fresh_task, fresh_task.resolve_goal(goal_atoms), "obtea", heuristic="lmcut")
    assert first.solved
    assert first.expansions == again.expansions == fresh.expansions
    assert first.executed == again.executed == fresh.executed


def reached_conditions(task: GroundTask, rng: random.Random, count: int) -> list[frozenset[int]]:
    """Parts of states reached by random walks from s0 (finite, mostly nonzero estimates)."""
    found = []
    for _ in range(count):
        state = task.initial_state
        for _ in range(rng.randint(1, 6)):
            applicable = [a for a in task.actions if a.applicable(state)]
            if not applicable:
                break
            state = rng.choice(applicable).progress(state)
        found.append(frozenset(rng.sample(sorted(state), min(len(state), rng.randint(1, 4)))))
    return found


@pytest.mark.parametrize("compiled", KERNELS)
@pytest.mark.parametrize("seed", range(60))
def test_lmcut_shares_rounds_between_conditions_without_changing_a_value(
    seed: int, compiled: bool, monkeypatch: pytest.MonkeyPatch
) -> None:
    """One LmCut asked many conditions in turn (sharing the states after cuts in its table, or, with
    no room for the table, computing each round again) gives each the value of a fresh one."""
    task = random_case(seed).task
    conditions = reached_conditions(task, random.Random(seed), 20)
    expected = [LmCut(task, task.actions, compiled=compiled)(c) for c in conditions]
    kept = LmCut(task, task.actions, compiled=compiled)
    assert [kept(c) for c in conditions] == expected
    monkeypatch.setattr(lmcut_module, "_TABLE_SLOTS", 0)
    full = LmCut(task, task.actions, compiled=compiled)
    assert [full(c) for c in conditions] == expected
    assert full.root.next == {}  # nothing was kept


def kept_states(lmcut: LmCut) -> dict[tuple[int, ...], tuple[list[float], ...]]:
    """Every state in an LmCut's table, by the atoms cut for to reach it, as plain lists."""
    found = {}
    stack: list[tuple[tuple[int, ...], lmcut_module._Step]] = [((), lmcut.root)]
    while stack:
        path, step = stack.pop()
        state = step.state
        found[path] = (list(state.hmax), list(state.value), list(state.choice), list(state.cost), [step.gained])
        stack.extend(((*path, atom), following) for atom, following in (step.next or {}).items())
    return found


def assert_same_rounds(task: GroundTask, conditions: Sequence[frozenset[int]], where: object) -> int:
    """The C and the Python rounds give every condition the same value and keep the same states;
    returns how many states were compared."""
    python, c = LmCut(task, task.actions, compiled=False), LmCut(task, task.actions, compiled=True)
    for condition in conditions:
        assert c(condition) == python(condition), (where, sorted(condition))
    states = kept_states(python)
    assert kept_states(c) == states, where
    return len(states)


@needs_c
@pytest.mark.parametrize("seed", range(150))
def test_the_c_rounds_equal_the_python_rounds_on_random_tasks(seed: int) -> None:
    task = random_case(seed).task
    rng = random.Random(seed)
    atoms = range(len(task.atoms))
    conditions = reached_conditions(task, rng, 12)
    conditions += [frozenset(rng.sample(atoms, rng.randint(1, min(5, len(atoms))))) for _ in range(12)]
    assert_same_rounds(task, conditions, seed)


@needs_c
@pytest.mark.parametrize("name", ["robothow", "virtualhome", "robowaiter"])
def test_the_c_rounds_equal_the_python_rounds_on_the_scenarios(name: str) -> None:
    """On the shipped scenarios (hundreds to thousands of actions), many cuts a condition."""
    task = load_scenario(name).task
    rng = random.Random(7)
    conditions = []
    for _ in range(15):
        state = task.initial_state
        for _ in range(rng.randint(2, 8)):
            state = rng.choice([a for a in task.actions if a.applicable(state)]).progress(state)
        changed = sorted(state - task.initial_state)
        conditions.append(frozenset(rng.sample(changed, min(len(changed), 3))))
    assert assert_same_rounds(task, conditions, name) >= 10  # rounds were made, not only looked up


def test_lmcut_asked_for_c_rounds_without_the_extension_says_so(monkeypatch: pytest.MonkeyPatch) -> None:
    monkeypatch.setattr(lmcut_module, "_compiled", None)
    task = gripper(2)
    with pytest.raises(PlanningError, match=r"hbtp\.planning\._lmcut is not built"):
        LmCut(task, task.actions, compiled=True)
    assert LmCut(task, task.actions, compiled=False)(task.resolve_goal(["At(b0,b)"]).disjuncts[0]) == 3.0


@needs_c
def test_the_c_round_refuses_arrays_that_do_not_fit() -> None:
    task = gripper(2)
    lmcut = LmCut(task, task.actions, compiled=True)
    assert lmcut.rows is not None
    state = lmcut.root.state.copy()
    cut = lmcut_module._compiled.cut
    with pytest.raises(ValueError, match="lengths do not match"):
        cut(*lmcut.rows, state.hmax, state.value[:-1], state.choice, state.cost, 0)
    with pytest.raises(TypeError, match="item size"):
        cut(*lmcut.rows, state.hmax, state.value, state.cost, state.cost, 0)
    with pytest.raises(IndexError, match="out of range"):
        cut(*lmcut.rows, state.hmax, state.value, state.choice, state.cost, len(state.hmax))
