"""The grounded STRIPS task: applicability, progression, execution and goal resolution."""

from __future__ import annotations

import pytest

from hbtp.domains import Scenario
from hbtp.errors import InputError, UnknownSymbolError
from hbtp.logic import Atom, GroundAction, GroundTask
from hbtp.logic.execution import apply_actions
from hbtp.logic.relevance import relevant_actions
from helpers import kitchen_builder


def _action(pre: set[int], add: set[int], delete: set[int], cost: int = 1) -> GroundAction:
    return GroundAction(0, Atom("A", ()), frozenset(pre), frozenset(add), frozenset(delete), cost)


@pytest.fixture
def kitchen() -> GroundTask:
    """Walk to the fridge, open it, put the milk in; a lamp nothing can switch on."""
    return kitchen_builder().action("Wait(lamp)", pre=["IsSwitchedOn(lamp)"], add=["IsSeen(lamp)"]).build()


def _state(task: GroundTask, *names: str) -> frozenset[int]:
    return frozenset(task.atom_id(n) for n in names)


# ------------------------------------------------------------------ semantics
def test_applicable_when_precondition_is_a_subset_of_the_state() -> None:
    action = _action(pre={0, 1}, add={2}, delete=set())
    assert action.applicable(frozenset({0, 1}))
    assert action.applicable(frozenset({0, 1, 5}))
    assert not action.applicable(frozenset({0}))
    assert not action.applicable(frozenset())
    assert _action(pre=set(), add={1}, delete=set()).applicable(frozenset())


def test_progression_is_state_minus_delete_union_add() -> None:
    action = _action(pre={0}, add={1, 4}, delete={0, 2})
    assert action.progress(frozenset({0, 2, 3})) == frozenset({1, 3, 4})
    # Deleting an atom that is not there changes nothing; adding one already there neither.
    assert action.progress(frozenset({0, 1})) == frozenset({1, 4})


def test_progression_adds_win_over_deletes() -> None:
    action = _action(pre=set(), add={1}, delete={1})
    assert action.progress(frozenset({1})) == frozenset({1})
    assert action.progress(frozenset()) == frozenset({1})


def test_action_name_predicate_and_objects() -> None:
    action = GroundAction(3, Atom("PutIn", ("milk", "fridge")), frozenset(), frozenset(), frozenset(), 10)
    assert action.name == "PutIn(milk,fridge)"
    assert action.predicate == "PutIn"
    assert action.objects == ("milk", "fridge")


# ------------------------------------------------------------------ execution
def test_execute_runs_a_valid_plan(kitchen: GroundTask) -> None:
    plan = [kitchen.action(n) for n in ("Walk(fridge)", "Open(fridge)", "PutIn(milk,fridge)")]
    state, done = apply_actions(kitchen, plan)
    assert done == 3
    assert kitchen.names(state) == [
        "IsIn(milk,fridge)",
        "IsNear(self,fridge)",
        "IsOpen(fridge)",
        "IsStanding(self)",
    ]


def test_execute_stops_at_the_first_inapplicable_action(kitchen: GroundTask) -> None:
    walk, open_, put_in = (kitchen.action(n) for n in ("Walk(fridge)", "Open(fridge)", "PutIn(milk,fridge)"))
    # PutIn needs the fridge open: execution stops there, and Open (applicable later) is never run.
    state, done = apply_actions(kitchen, [walk, put_in, open_])
    assert done == 1
    assert state == walk.progress(kitchen.initial_state)
    assert kitchen.atom_id("IsOpen(fridge)") not in state


def test_execute_from_a_given_state_and_empty_plan(kitchen: GroundTask) -> None:
    assert apply_actions(kitchen, []) == (kitchen.initial_state, 0)
    start = _state(kitchen, "IsNear(self,fridge)", "IsClose(fridge)")
    state, done = apply_actions(kitchen, [kitchen.action("Open(fridge)")], start)
    assert done == 1
    assert state == _state(kitchen, "IsNear(self,fridge)", "IsOpen(fridge)")
    state, done = apply_actions(kitchen, [kitchen.action("Walk(fridge)")], start)
    assert (state, done) == (start, 0)


# -------------------------------------------------------------------- lookups
def test_lookups_accept_both_spellings(kitchen: GroundTask) -> None:
    assert kitchen.action("PutIn_milk_fridge") is kitchen.action("PutIn(milk,fridge)")
    assert kitchen.atom_id("IsIn_milk_fridge") == kitchen.atom_id(Atom("IsIn", ("milk", "fridge")))
    assert kitchen.atom(kitchen.atom_id("IsOpen(fridge)")) == Atom("IsOpen", ("fridge",))


def test_unknown_lookups_raise(kitchen: GroundTask) -> None:
    with pytest.raises(UnknownSymbolError, match="not a grounded action"):
        kitchen.action("Close(fridge)")
    with pytest.raises(UnknownSymbolError, match="never occurs"):
        kitchen.atom_id("IsIn(fridge,fridge)")
    with pytest.raises(UnknownSymbolError, match="unknown predicate"):
        kitchen.atom_id("IsBroken(fridge)")


def test_achievers_and_action_predicates(kitchen: GroundTask) -> None:
    assert [kitchen.actions[i].name for i in kitchen.achievers[kitchen.atom_id("IsOpen(fridge)")]] == ["Open(fridge)"]
    assert kitchen.achievers[kitchen.atom_id("IsStanding(self)")] == ()
    assert kitchen.action_predicates == ("Open", "PutIn", "Wait", "Walk")
    assert [a.name for a in kitchen.restricted([2, 0, 2])] == [kitchen.actions[0].name, kitchen.actions[2].name]


# --------------------------------------------------------------- resolve_goal
def test_resolve_goal_from_text_and_from_atoms(kitchen: GroundTask) -> None:
    goal = kitchen.resolve_goal("IsIn_milk_fridge & IsClose(fridge)")
    assert goal.atoms == (Atom("IsIn", ("milk", "fridge")), Atom("IsClose", ("fridge",)))
    assert goal.ids == _state(kitchen, "IsIn(milk,fridge)", "IsClose(fridge)")
    assert goal.unreachable == ()
    assert str(goal) == "IsIn_milk_fridge & IsClose_fridge"
    assert kitchen.resolve_goal(["IsIn(milk,fridge)", Atom("IsClose", ("fridge",))]) == goal


@pytest.mark.parametrize(
    ("goal", "message"),
    [
        ("IsBroken(fridge)", "unknown predicate 'IsBroken'"),
        ("IsOpen(oven)", "unknown object 'oven'"),
        ("IsOpen(fridge,milk)", "takes 1 argument"),
        ("IsIn_milk", "takes 2 argument"),
        ("IsOpen(fridge) & IsOpen(oven)", "unknown object 'oven'"),
    ],
)
def test_resolve_goal_rejects_unknown_symbols(kitchen: GroundTask, goal: str, message: str) -> None:
    with pytest.raises(UnknownSymbolError, match=message):
        kitchen.resolve_goal(goal)


def test_resolve_goal_rejects_empty_goals(kitchen: GroundTask) -> None:
    with pytest.raises(InputError, match="empty goal"):
        kitchen.resolve_goal("")
    with pytest.raises(InputError, match="empty goal"):
        kitchen.resolve_goal([])


def test_literal_that_is_never_grounded_is_unreachable(kitchen: GroundTask) -> None:
    # Well formed (known predicate and objects) but no action mentions it.
    goal = kitchen.resolve_goal("IsIn(fridge,milk) & IsOpen(fridge)")
    assert goal.unreachable == (Atom("IsIn", ("fridge", "milk")),)
    assert goal.disjuncts == ()  # no state holds a literal that is no atom of the task
    assert "no action makes IsIn(fridge,milk) true" in (goal.unsolvable or "")


def test_literal_without_achiever_is_unreachable_unless_true_in_s0(kitchen: GroundTask) -> None:
    # IsSwitchedOn(lamp) occurs (as a precondition) but nothing adds it and s0 lacks it.
    assert kitchen.resolve_goal("IsSwitchedOn(lamp)").unreachable == (Atom("IsSwitchedOn", ("lamp",)),)
    # IsStanding(self) has no achiever either, but it already holds.
    assert kitchen.resolve_goal("IsStanding(self)").unreachable == ()


def test_static_literals_of_a_goal_are_evaluated(robothow_small: Scenario) -> None:
    task = robothow_small.task
    assert "grabbable" not in task.predicates
    assert task.resolve_goal("IsOpen(fridge) & grabbable(apple)").ids == {task.atom_id("IsOpen(fridge)")}
    assert task.resolve_goal("IsOpen(fridge) & ~grabbable(fridge)").ids == {task.atom_id("IsOpen(fridge)")}
    false = task.resolve_goal("IsOpen(fridge) & grabbable(fridge) | IsOpen(fridge) & ~grabbable(apple)")
    assert false.disjuncts == ()
    assert false.unsolvable is not None
    # A static predicate is still checked for its arity and objects.
    with pytest.raises(UnknownSymbolError, match="takes 1 argument"):
        task.resolve_goal("grabbable(apple,plate)")


def test_unreachable_literals_of_a_scenario(robothow_small: Scenario) -> None:
    task = robothow_small.task
    # The fridge has a plug but no switch: IsSwitchedOff(fridge) is needed by PlugOut(fridge) yet never holds.
    goal = task.resolve_goal("IsSwitchedOff(fridge) & IsOn(wine,wine) & IsOpen(fridge)")
    assert set(goal.unreachable) == {Atom("IsOn", ("wine", "wine")), Atom("IsSwitchedOff", ("fridge",))}
    assert goal.disjuncts == ()
    reachable_later = task.resolve_goal("IsSwitchedOff(fridge) & IsOpen(fridge)")
    assert reachable_later.ids == {task.atom_id("IsSwitchedOff(fridge)"), task.atom_id("IsOpen(fridge)")}
    assert reachable_later.reachable == ()  # it can hold (after a disturbance) but no plan reaches it


def test_categories_are_unary_static_facts(robothow_small: Scenario) -> None:
    categories = robothow_small.task.categories
    assert categories["grabbable"] == ("apple", "cutlets", "kitchenknife", "plate", "rag", "wine")
    assert categories["cleaning_tool"] == ("rag",)


def test_a_10000_literal_goal_is_resolved_or_rejected_in_one_pass(robothow: Scenario) -> None:
    """Issue 14 (G): a goal of 10,000 literals took 36 s to reject; parsing is now linear."""
    task = robothow.task
    unknown = " & ".join(f"IsIn(x{i},y{i})" for i in range(10_000))
    with pytest.raises(
        UnknownSymbolError, match=r"^unknown object 'x0' in IsIn\(x0,y0\) \(IsIn takes at argument 1: .* more\)$"
    ):
        task.resolve_goal(unknown)
    objects = task.objects[:100]
    pairs = [f"IsIn({a},{b})" for a in objects for b in objects]
    goal = task.resolve_goal(" & ".join(pairs + pairs[:5]))
    assert len(goal.atoms) == 10_000
    assert [str(a) for a in goal.atoms] == pairs
    assert goal.unreachable  # most of these literals are never grounded
    with pytest.raises(UnknownSymbolError, match="takes 1 argument"):
        task.resolve_goal(" & ".join([*pairs, "grabbable(apple,plate)"]))


def test_task_tables_are_built_once_per_task_and_not_pickled(kitchen: GroundTask) -> None:
    import pickle

    from hbtp.logic.tables import TaskTable

    table: TaskTable[list[int]] = TaskTable("a test table")
    shared: TaskTable[int] = TaskTable("a table that does not depend on s0", state_free=True)
    builds: list[int] = []

    def build() -> list[int]:
        builds.append(1)
        return [len(kitchen.actions)]

    first = table.of(kitchen, build)
    assert table.of(kitchen, build) is first
    assert table.of(kitchen, build, key="another") is not first  # a key: another value
    assert len(builds) == 2
    copy = pickle.loads(pickle.dumps(kitchen))
    assert "_tables" not in copy.__dict__
    assert table.of(copy, lambda: [7]) == [7]
    assert shared.of(kitchen, lambda: 5) == 5
    moved = kitchen.from_state(frozenset())
    assert shared.of(moved, lambda: 6) == 5  # shared with the task from another state
    assert table.of(moved, lambda: [8]) == [8]  # not shared: may depend on s0
    kitchen.tables().clear()
    assert table.of(kitchen, build) == first
    assert len(builds) == 3


def test_a_task_table_is_built_with_the_collector_paused(kitchen: GroundTask) -> None:
    import gc

    from hbtp.logic.tables import TaskTable

    table: TaskTable[bool] = TaskTable("whether the collector ran while it was built")
    assert gc.isenabled()
    assert table.of(kitchen, gc.isenabled) is False
    assert gc.isenabled()  # back as it was
    with pytest.raises(ZeroDivisionError):
        table.of(kitchen, lambda: bool(1 / 0), key="failing")
    assert gc.isenabled()


def test_relevant_actions_follow_achievers_back_from_the_goal() -> None:
    from hbtp.domains import DomainBuilder

    builder = DomainBuilder("relevance")
    builder.action("Fetch(cup)", pre=["At(home)"], add=["Has(cup)"])
    builder.action("Go(home)", add=["At(home)"])
    builder.action("Sing(song)", pre=["At(home)"], add=["Sung(song)"])
    task = builder.build()
    relevant = relevant_actions(task, task.resolve_goal("Has(cup)"))
    assert sorted(task.actions[i].name for i in relevant) == ["Fetch(cup)", "Go(home)"]
