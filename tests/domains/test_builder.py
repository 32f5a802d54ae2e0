"""DomainBuilder: grounded tasks from Python, without PDDL."""

from __future__ import annotations

import doctest

import pytest

import hbtp.domains.builder
from hbtp.domains import DomainBuilder
from hbtp.errors import InputError
from hbtp.logic import Atom
from hbtp.logic.execution import apply_actions


def test_doctest_example_runs() -> None:
    result = doctest.testmod(hbtp.domains.builder, raise_on_error=False, verbose=False)
    assert result.attempted > 0
    assert result.failed == 0


def test_builds_actions_atoms_and_initial_state() -> None:
    task = (
        DomainBuilder("kitchen")
        .constants(["self"])
        .action("Walk(fridge)", pre=["IsStanding(self)"], add=["IsNear(self,fridge)"], cost=15)
        .action(
            "Open_fridge",
            pre=["IsNear_self_fridge", "IsClose(fridge)"],
            add=["IsOpen(fridge)"],
            delete=["IsClose(fridge)"],
            cost=3,
        )
        .initial(["IsStanding(self)", "IsClose(fridge)"])
        .build()
    )
    assert task.name == "kitchen"
    assert [a.name for a in task.actions] == ["Open(fridge)", "Walk(fridge)"]  # sorted by name
    assert [a.index for a in task.actions] == [0, 1]
    assert list(task.atoms) == sorted(task.atoms)
    assert task.names(task.initial_state) == ["IsClose(fridge)", "IsStanding(self)"]
    open_ = task.action("Open(fridge)")
    assert task.names(open_.pre) == ["IsClose(fridge)", "IsNear(self,fridge)"]
    assert task.names(open_.add) == ["IsOpen(fridge)"]
    assert task.names(open_.delete) == ["IsClose(fridge)"]
    assert open_.cost == 3
    assert task.predicates == {"IsClose": 1, "IsNear": 2, "IsOpen": 1, "IsStanding": 1}
    assert task.objects == ("fridge",)
    assert task.constants == ("self",)
    state, done = apply_actions(task, [task.action("Walk(fridge)"), open_])
    assert done == 2
    assert task.atom_id("IsOpen(fridge)") in state


def test_default_cost_is_one_and_add_beats_delete() -> None:
    task = DomainBuilder("t").action("Touch(a)", add=["Seen(a)"], delete=["Seen(a)", "Fresh(a)"]).build()
    action = task.action("Touch(a)")
    assert action.cost == 1
    assert task.names(action.add) == ["Seen(a)"]
    assert task.names(action.delete) == ["Fresh(a)"]  # an atom both added and deleted is added


def test_objects_and_constants() -> None:
    builder = DomainBuilder("t").constants(["self"]).action("Grab(self,cup)", add=["Holding(self,cup)"])
    builder.action("Look(lamp)", pre=["On(lamp)"], add=["Seen(lamp)"])
    task = builder.build()
    assert task.objects == ("cup", "lamp")
    assert task.constants == ("self",)
    chosen = builder.build(objects=["cup"])
    assert chosen.objects == ("cup",)
    # Symbols that are neither chosen objects nor constants are kept as constants, so goals can name them.
    assert chosen.constants == ("self", "lamp")
    assert chosen.resolve_goal("Seen(lamp)").ids == {chosen.atom_id("Seen(lamp)")}


def test_duplicate_action_is_rejected() -> None:
    builder = DomainBuilder("t").action("Walk(a)", add=["Near(a)"])
    with pytest.raises(InputError, match=r"Walk\(a\) is defined twice"):
        builder.action("Walk_a", add=["Near(a)"])


def test_negative_cost_is_rejected() -> None:
    with pytest.raises(InputError, match="must not be negative"):
        DomainBuilder("t").action("Walk(a)", add=["Near(a)"], cost=-1)


def test_zero_cost_is_allowed() -> None:
    assert DomainBuilder("t").action("Wait()", add=["Done()"], cost=0).build().actions[0].cost == 0


def test_inconsistent_arity_is_rejected() -> None:
    builder = (
        DomainBuilder("t").action("Put(a,b)", pre=["Holding(a)"], add=["On(a,b)"]).action("Drop(a)", add=["On(a)"])
    )
    with pytest.raises(InputError, match="'On' is used with different numbers of arguments"):
        builder.build()


def test_inconsistent_arity_between_initial_state_and_actions() -> None:
    builder = DomainBuilder("t").action("Open(a)", add=["Open(a)"]).initial(["Open(a,b)"])
    with pytest.raises(InputError, match="different numbers of arguments"):
        builder.build()


@pytest.mark.parametrize("bad", ["Walk(a", "Walk(a,)", ""])
def test_malformed_names_are_rejected(bad: str) -> None:
    with pytest.raises(InputError, match="malformed literal"):
        DomainBuilder("t").action(bad)
    with pytest.raises(InputError, match="malformed literal"):
        DomainBuilder("t").action("Walk(a)", pre=[bad])
    with pytest.raises(InputError, match="malformed literal"):
        DomainBuilder("t").initial([bad])


def test_action_signature_keeps_its_arguments() -> None:
    task = DomainBuilder("t").action("Put(cup,table)", add=["On(cup,table)"]).build()
    assert task.actions[0].signature == Atom("Put", ("cup", "table"))
