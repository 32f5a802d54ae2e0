"""Re-planning as repair (hbtp.planning.repair): a kept search continued from other states.

Every answer is checked against a fresh search from the same state (the same optimal cost, the same
verdict) and, on the small random tasks, against the brute-force optimum of tests/helpers.py; every
tree a repair returns is ticked from its state and reaches the goal at that cost. One search is
continued many times in a row (its state carries over), on random tasks with and without proved
mutexes, and on disturbed states of the shipped scenarios.
"""

from __future__ import annotations

import dataclasses
import random
from pathlib import Path
from typing import Any

import pytest

from hbtp import replanning
from hbtp.bt import tree_of
from hbtp.bt.disturb import seeded_disturbances
from hbtp.domains import DomainBuilder, Scenario
from hbtp.domains.mutex import infer_mutexes
from hbtp.logic.task import Goal, GroundTask
from hbtp.planning import PlanResult, Status, plan, planner_config, search
from hbtp.planning.hints import PrunedSpace, hints_from_names, pruned_action_space, resolve_hints
from hbtp.planning.planners import Space
from hbtp.planning.repair import RepairableSearch, repairable
from hbtp.planning.search_state import SearchConfig
from hbtp.replanning import KeptSearch, Replanner, ReplanOptions, replanning_runs
from helpers import brute_force, random_task, run_tree

CONTINUED = ("none", "hmax", "lm")


def check_tree(result: PlanResult, task: GroundTask, state: frozenset[int]) -> None:
    """Both trees of a solved result reach the goal from ``state`` at the result's cost."""
    for kind in ("full", "path"):
        run = run_tree(tree_of(result, kind), task, state, 1000)
        assert run.reached, kind
        assert run.cost == result.cost, kind


def random_states(task: GroundTask, rng: random.Random, count: int) -> list[frozenset[int]]:
    return [frozenset(i for i in range(len(task.atoms)) if rng.random() < 0.4) for _ in range(count)]


def disturbed_states(scenario: Scenario, goal: Goal) -> list[frozenset[int]]:
    """States four ticks of seeded disturbances (p = 0.5, seed 11) make from s0, where ``goal`` does
    not hold and the proved mutexes do."""
    task, proved = scenario.task, scenario.mutexes.proved_only()
    states = []
    for disturbance in seeded_disturbances(task, scenario.mutexes, 0.5, 15, seed=11):
        state = task.initial_state
        for tick in range(1, 5):
            event = disturbance(tick, state, None, None)
            state = event.apply(state) if event is not None else state
        if not goal.holds(state) and proved.conflict(state) is None:
            states.append(state)
    return states


@pytest.mark.parametrize("heuristic", CONTINUED)
def test_repairs_are_optimal_on_random_tasks(heuristic: str) -> None:
    """One kept search per task, continued from 5 random states in a row: the brute-force optimum."""
    config = planner_config("obtea", heuristic=heuristic)  # type: ignore[arg-type]
    checked = 0
    for seed in range(150):
        task, goal = random_task(seed)
        mutexes = infer_mutexes(task) if seed % 2 else None
        kept, first = RepairableSearch.start(task, goal, task.actions, config, mutexes=mutexes)
        assert first.cost == brute_force(task, goal.ids)[0]
        if kept is None:
            continue
        for state in random_states(task, random.Random(seed), 5):
            if mutexes is not None and mutexes.conflict(state) is not None:
                continue  # a repair is used only from states that keep the proved mutexes
            world = task.from_state(state)
            here = world.resolve_goal(goal)
            optimum, _ = brute_force(world, here.ids)
            result = kept.repair(world, here)
            assert result.cost == optimum, (seed, sorted(state))
            assert result.status is (Status.UNSOLVABLE if optimum is None else Status.SOLVED)
            if result.solved:
                check_tree(result, world, state)
            checked += 1
    assert checked > 400


def continue_on_disturbed_states(scenario: Scenario, goal_text: str, states: int) -> int:
    """A kept search continued from ``states`` disturbed states: each answer as a fresh search's."""
    task, mutexes = scenario.task, scenario.mutexes.proved_only()
    goal = task.resolve_goal(goal_text)
    config = planner_config("obtea", heuristic="lm")
    kept, first = RepairableSearch.start(task, goal, task.actions, config, mutexes=mutexes)
    assert kept is not None
    assert first.solved
    compared = 0
    for disturbance in seeded_disturbances(task, scenario.mutexes, 0.5, states, seed=3):
        state = task.initial_state
        for tick in range(1, 4):  # a few events in a row, as during a run
            event = disturbance(tick, state, None, None)
            state = event.apply(state) if event is not None else state
        if mutexes.conflict(state) is not None or goal.holds(state):
            continue
        world = task.from_state(state)
        here = world.resolve_goal(goal)
        fresh = search(world, here, world.actions, config, mutexes=mutexes)
        repaired = kept.repair(world, here)
        assert (repaired.status, repaired.cost) == (fresh.status, fresh.cost)
        if repaired.solved:
            check_tree(repaired, world, state)
        compared += 1
    return compared


def test_repairs_match_fresh_searches_on_robowaiter(robowaiter: Scenario) -> None:
    assert continue_on_disturbed_states(robowaiter, "On_Coffee_Table1", 25) >= 10


def test_repairs_match_fresh_searches_on_virtualhome(virtualhome: Scenario) -> None:
    assert continue_on_disturbed_states(virtualhome, "IsOn_cupcake_kitchentable & IsSwitchedOn_tablelamp", 25) >= 10


def test_repairs_match_fresh_searches_on_robothow_small(robothow_small: Scenario) -> None:
    assert continue_on_disturbed_states(robothow_small, "IsIn_cutlets_fridge & IsClose_fridge", 20) >= 8


def test_only_consistent_costs_and_heuristics_continue() -> None:
    assert repairable(planner_config("obtea", heuristic="lm"))
    assert not repairable(planner_config("obtea", heuristic="lmcut"))
    assert not repairable(planner_config("hbtp-s"))
    assert not repairable(planner_config("bte", heuristic="lm"))
    task, goal = random_task(1)
    with pytest.raises(ValueError, match="cannot be continued"):
        RepairableSearch.start(task, goal, task.actions, planner_config("hbtp-s"))


def test_a_search_continues_for_its_own_goal_only() -> None:
    task, goal = random_task(2)
    kept, _ = RepairableSearch.start(task, goal, task.actions, planner_config("obtea", heuristic="lm"))
    assert kept is not None
    other = task.resolve_goal([task.atoms[i] for i in range(len(task.atoms)) if i not in goal.ids][:1])
    with pytest.raises(ValueError, match="own goal"):
        kept.repair(task, other)


def test_replanning_runs_by_repair_reach_the_goal(robothow_small: Scenario) -> None:
    """Runs re-planned by repair (one kept search shared by the runs): every run whose goal stays
    reachable reaches it, within the budget."""
    goal = robothow_small.task.resolve_goal("IsIn_apple_fridge & IsClose_fridge")
    tree = tree_of(plan(robothow_small.task, goal, "obtea", mutexes=robothow_small.mutexes), "path")
    runs = replanning_runs(robothow_small, goal, tree, 0.5, 12, seed=5, max_ticks=200)
    assert sum(len(r.replans) for r in runs) >= 3, "the disturbances should force re-plans"
    for run in runs:
        assert run.unsolvable or run.reached(goal.ids), run.gave_up
        assert all(replan.status in ("solved", "unsolvable") for replan in run.replans)


@pytest.mark.parametrize("bound", [None, 2], ids=["repair", "bounded-repair"])
def test_a_replanner_repairs_at_the_cost_of_a_fresh_search(
    robothow_small: Scenario, bound: int | None, monkeypatch: pytest.MonkeyPatch
) -> None:
    """A Replanner re-planning by repair from a series of disturbed states: each re-plan costs what
    a fresh search from that state costs, and its tree reaches the goal from there at that cost. With
    the repair bounded to 2 conditions (these states have no interchangeable objects) the repair goes
    on past the bound: the same costs."""
    symmetric: list[bool] = []
    if bound is not None:
        monkeypatch.setattr(replanning, "REPAIR_EXPANSIONS", bound)
        find = replanning.find_symmetry

        def recorded(*args: Any) -> Any:
            found = find(*args)
            symmetric.append(found is not None)
            return found

        monkeypatch.setattr(replanning, "find_symmetry", recorded)
    task, mutexes = robothow_small.task, robothow_small.mutexes.proved_only()
    goal = task.resolve_goal("IsIn_apple_fridge & IsClose_fridge")
    policy = Replanner(robothow_small, goal, None, ReplanOptions(max_replans=100))
    config = planner_config("obtea", heuristic="lm")
    compared = 0
    for state in disturbed_states(robothow_small, goal):
        world = task.from_state(state)
        fresh = search(world, world.resolve_goal(goal), world.actions, config, mutexes=mutexes)
        assert policy.replan(state, "test") == fresh.solved
        replan = policy.replans[-1]
        assert (replan.status, replan.cost) == (fresh.status.value, fresh.cost)
        if replan.tree is not None:
            run = run_tree(replan.tree, world, state, 1000)
            assert run.reached
            assert run.cost == fresh.cost
        compared += 1
        policy.gave_up = None
    assert compared >= 5
    assert policy.kept.search is not None
    if bound is not None:  # its states have no interchangeable objects: every bounded repair went on
        assert symmetric
        assert True not in symmetric


def test_a_kept_search_is_shared_and_dropped_for_another_goal(robowaiter: Scenario) -> None:
    kept = KeptSearch()
    task = robowaiter.task
    goal = task.resolve_goal("On_Coffee_Table1")
    policy = Replanner(robowaiter, goal, None, ReplanOptions(kept=kept))
    policy(task.initial_state)  # no tree: the first tick re-plans and starts the kept search
    assert kept.search is not None
    assert policy.replans[0].status == "solved"
    first = kept.search
    Replanner(robowaiter, goal, None, ReplanOptions(kept=kept))(task.initial_state)
    assert kept.search is first  # continued, not started anew
    other = task.resolve_goal("On_Dessert_Bar")
    Replanner(robowaiter, other, None, ReplanOptions(kept=kept))(task.initial_state)
    assert kept.search is not first
    assert kept.search is not None
    assert kept.search.goal.disjuncts == other.disjuncts


def _shelves_scenario() -> Scenario:
    """A robot that must have its hand empty to wipe the table, and four empty shelves it may put
    what it holds on: interchangeable objects in every state where it holds the cup."""
    builder = DomainBuilder("shelves").constants(["self"])
    for shelf in ("s1", "s2", "s3", "s4"):
        builder.action(f"Put(cup,{shelf})", pre=["Holding(cup)"], add=["HandEmpty(self)", f"On(cup,{shelf})"],
                       delete=["Holding(cup)"], cost=2)  # fmt: skip
        builder.action(f"Take(cup,{shelf})", pre=["HandEmpty(self)", f"On(cup,{shelf})"], add=["Holding(cup)"],
                       delete=["HandEmpty(self)", f"On(cup,{shelf})"], cost=2)  # fmt: skip
    builder.action("Wipe(table)", pre=["HandEmpty(self)"], add=["Clean(table)"], cost=3)
    task = builder.initial(["HandEmpty(self)", "On(cup,s1)"]).build()
    return Scenario(task.name, task.name, "", task, infer_mutexes(task), Path("-"), Path("-"))


def test_a_long_repair_gives_way_to_a_search_with_symmetry_pruning(monkeypatch: pytest.MonkeyPatch) -> None:
    """A repair bounded to one condition stops; the state (the cup in hand, four empty shelves) has
    interchangeable objects, so a fresh search prunes by them: the same optimal cost, a tree that
    reaches the goal from the state."""
    monkeypatch.setattr(replanning, "REPAIR_EXPANSIONS", 1)
    searched = replanning.confirmed_search
    configs: list[SearchConfig] = []

    def recorded(*args: Any, **kwargs: Any) -> PlanResult:
        configs.append(args[3])
        return searched(*args, **kwargs)

    monkeypatch.setattr(replanning, "confirmed_search", recorded)
    scenario = _shelves_scenario()
    task = scenario.task
    goal = task.resolve_goal("Clean(table)")
    holding = frozenset(task.atom_id(name) for name in ("Holding(cup)",))
    assert replanning.find_symmetry(task.from_state(holding), goal.disjuncts, task.actions) is not None
    policy = Replanner(scenario, goal, None, ReplanOptions())
    assert policy.replan(task.initial_state, "first")  # starts the kept search
    assert policy.replan(holding, "the cup is in hand again")
    replan = policy.replans[-1]
    assert (replan.status, replan.cost) == ("solved", 5)  # put the cup on a shelf, wipe
    assert replan.tree is not None
    run = run_tree(replan.tree, task.from_state(holding), holding, 100)
    assert run.reached
    assert run.cost == 5
    assert configs
    assert configs[-1].symmetry  # the fresh search pruned by the interchangeable shelves


def test_a_replan_with_hints_searches_their_space_widened_by_what_changed(robothow_small: Scenario) -> None:
    """With the hints the tree was planned with, a re-plan answers from their pruned space widened by
    the objects of the atoms the state changed and the predicates of the actions that undo a change:
    at the cost of a fresh OBTEA search of that space, its tree reaching the goal from the state;
    where that space holds no tree, from the space of the undo actions within a step, else from the
    full space at the optimal cost. The pruned answer is
    checked against the full space's optimum (never below)."""
    task = robothow_small.task
    goal = task.resolve_goal("IsIn_apple_fridge & IsClose_fridge")
    hints = hints_from_names(
        predicates=["Walk", "RightGrab", "Open", "RightPutIn", "Close"], objects=["apple", "fridge"]
    )
    policy = Replanner(robothow_small, goal, None, ReplanOptions(max_replans=100, hints=hints))
    config = planner_config("obtea", heuristic="lm")
    spaces = []
    for state in disturbed_states(robothow_small, goal):
        world = task.from_state(state)
        gained, lost = state - task.initial_state, task.initial_state - state
        changed = {obj for index in gained | lost for obj in task.atoms[index].args}
        undoing = [a for a in task.actions if a.delete & gained or a.add & lost]
        undo = {a.predicate for a in undoing}
        widened = hints_from_names(hints.path, [*hints.predicates, *undo], [*hints.objects, *changed])
        around = set(pruned_action_space(task, resolve_hints(task, widened)))
        around |= {a.index for a in task.actions if a.add & lost and a.pre <= state}  # give back, now
        pruned = search(world, world.resolve_goal(goal), [world.actions[i] for i in sorted(around)], config)
        if not pruned.solved:  # then the actions that undo a change within a step (tested below)
            further = policy.kept.pruned_space(task, hints).beyond(state)
            pruned = search(world, world.resolve_goal(goal), [world.actions[i] for i in further], config)
        optimum = replanning.full_space_cost(robothow_small, goal, state)
        assert policy.replan(state, "test")
        replan = policy.replans[-1]
        expected = pruned.cost if pruned.solved else optimum
        assert replan.space is (Space.PRUNED if pruned.solved else Space.FULL)
        assert replan.cost == expected
        assert optimum is not None
        assert replan.cost >= optimum
        assert replan.tree is not None
        run = run_tree(replan.tree, world, state, 1000)
        assert run.reached
        assert run.cost == replan.cost
        spaces.append(replan.space)
        policy.gave_up = None
    assert Space.PRUNED in spaces
    assert len(spaces) >= 5


def test_a_pruned_space_widens_by_objects_as_a_pass_over_every_action_does(robothow_small: Scenario) -> None:
    task = robothow_small.task
    hints = resolve_hints(task, hints_from_names(predicates=["Walk", "RightGrab", "Open"], objects=["apple", "fridge"]))
    space = PrunedSpace(task, hints)
    assert space.actions() == pruned_action_space(task, hints)
    rng = random.Random(3)
    for _ in range(20):
        more = set(rng.sample(sorted(task.objects), 4))
        others = set(rng.sample(sorted(task.action_predicates), 2))
        wide = dataclasses.replace(hints, objects=hints.objects | more, predicates=hints.predicates | others)
        slow = tuple(
            a.index
            for a in task.actions
            if a.predicate in wide.predicates and all(o in wide.objects for o in a.objects)
        )
        assert space.actions(more, others) == slow


def test_a_replan_puts_down_what_a_disturbance_put_in_a_hand(robothow_small: Scenario) -> None:
    """A disturbance puts the cutlets in the hand the hints' plan uses. The hints' space widened by
    the objects alone frees the hand the long way (into the fridge, opened for the apple anyway);
    widened by the predicates that undo the change too (``RightPut``), it puts them down on the bed
    (an object of the hints): cheaper, if not the full space's optimum (the left hand, which the
    hints never use)."""
    task, mutexes = robothow_small.task, robothow_small.mutexes
    goal = task.resolve_goal("IsIn_apple_fridge & IsClose_fridge")
    predicates = ["Walk", "RightGrab", "PlugIn", "Open", "RightPutIn", "Close"]
    hints = hints_from_names(predicates=predicates, objects=["apple", "fridge", "bed"])
    empty = task.initial_state - {task.atom_id("IsRightHandEmpty_self")}
    state = empty | {task.atom_id("IsRightHolding_self_cutlets"), task.atom_id("IsRightHandFull_self")}
    assert mutexes.proved_only().conflict(state) is None
    policy = Replanner(robothow_small, goal, None, ReplanOptions(hints=hints))
    assert policy.replan(state, "test")
    replan = policy.replans[-1]
    optimum = replanning.full_space_cost(robothow_small, goal, state)
    assert replan.space is Space.PRUNED
    assert replan.tree is not None
    world = task.from_state(state)
    assert run_tree(replan.tree, world, state, 1000).reached
    objects_only = hints_from_names(predicates=predicates, objects=["apple", "fridge", "bed", "cutlets", "self"])
    longer = plan(world, goal, "obtea", hints=objects_only, space=Space.PRUNED, mutexes=mutexes)
    assert optimum is not None
    assert replan.cost is not None
    assert longer.cost is not None
    assert optimum <= replan.cost < longer.cost, (optimum, replan.cost, longer.cost)


def test_a_thing_in_the_hand_that_must_be_free_is_put_down_where_the_hints_name_no_place(
    robothow_small: Scenario,
) -> None:
    """The cutlets in the left hand, which opening the fridge needs free, and no place to put them in
    the hints' space even widened (:meth:`PrunedSpace.around`): the space of the actions that undo the
    change within one step (:meth:`PrunedSpace.beyond`: put them down on a surface after walking
    there) answers, its tree reaching the goal, at no less than the full space's optimum."""
    task, mutexes = robothow_small.task, robothow_small.mutexes
    goal = task.resolve_goal("IsIn_apple_fridge & IsClose_fridge")
    predicates = ["Walk", "RightGrab", "PlugIn", "Open", "RightPutIn", "Close"]
    hints = hints_from_names(predicates=predicates, objects=["apple", "fridge"])
    empty = task.initial_state - {task.atom_id("IsLeftHandEmpty_self")}
    state = empty | {task.atom_id("IsLeftHolding_self_cutlets"), task.atom_id("IsLeftHandFull_self")}
    space = PrunedSpace(task, resolve_hints(task, hints))
    world = task.from_state(state)
    config = planner_config("obtea", heuristic="lm")
    narrow = search(world, world.resolve_goal(goal), [world.actions[i] for i in space.around(state)], config)
    assert narrow.status is Status.UNSOLVABLE
    policy = Replanner(robothow_small, goal, None, ReplanOptions(hints=hints))
    assert policy.replan(state, "test")
    replan = policy.replans[-1]
    assert replan.space is Space.PRUNED
    assert replan.tree is not None
    assert run_tree(replan.tree, world, state, 1000).reached
    optimum = replanning.full_space_cost(robothow_small, goal, state)
    assert optimum is not None
    assert replan.cost is not None
    assert replan.cost >= optimum
    assert set(space.around(state)) < set(space.beyond(state))
    assert mutexes.proved_only().conflict(state) is None


def test_the_second_widening_walks_only_where_an_undo_needs_the_robot(robothow_small: Scenario) -> None:
    """Moved near the TV with the kitchen knife in the left hand, out of the hints' reach: the space
    of the undo actions within a step adds putting the knife down and the walks to where it can be
    put, not a walk to every object because the robot moved (a walk of the space already takes it
    away from the TV); its search reaches the goal."""
    task = robothow_small.task
    goal = task.resolve_goal("IsPlugged_tv & IsPlugged_mouse")
    hints = hints_from_names(predicates=["Walk", "PlugIn"], objects=["tv", "mouse"])
    space = PrunedSpace(task, resolve_hints(task, hints))
    gained = {"IsNear_self_tv", "IsLeftHolding_self_kitchenknife", "IsLeftHandFull_self"}
    state = (task.initial_state - {task.atom_id("IsLeftHandEmpty_self")}) | {task.atom_id(a) for a in gained}
    around, beyond = set(space.around(state)), set(space.beyond(state))
    added = [task.actions[i] for i in sorted(beyond - around)]
    puts = [a for a in added if a.predicate != "Walk"]
    walks = [a for a in added if a.predicate == "Walk"]
    assert puts
    assert {a.predicate for a in puts} <= {"LeftPut", "LeftPutIn"}
    assert all(a.objects[0] == "kitchenknife" for a in puts)
    needed = frozenset().union(*(a.pre for a in puts)) - state
    assert walks
    assert all(walk.add & needed for walk in walks)  # each walk leads where a put needs the robot
    assert len(walks) < len([a for a in task.actions if a.predicate == "Walk"]) - 2
    world = task.from_state(state)
    config = planner_config("obtea", heuristic="lm")
    assert not search(world, world.resolve_goal(goal), [world.actions[i] for i in sorted(around)], config).solved
    result = search(world, world.resolve_goal(goal), [world.actions[i] for i in sorted(beyond)], config)
    assert result.solved
    check_tree(result, world, state)
