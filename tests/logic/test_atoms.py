"""Atoms: the two spellings, zero-arity atoms, malformed input and conjunctions."""

from __future__ import annotations

import pytest

from hbtp.errors import InputError
from hbtp.logic import Atom, parse_atom, parse_conjunction
from hbtp.logic.atoms import split_conjunction

MILK_IN_FRIDGE = Atom("IsIn", ("milk", "fridge"))


@pytest.mark.parametrize(
    "text",
    [
        "IsIn(milk,fridge)",
        "IsIn_milk_fridge",
        "IsIn(milk, fridge)",
        "  IsIn ( milk ,  fridge )  ",
        "\tIsIn_milk_fridge\n",
    ],
)
def test_both_spellings_and_spaces_give_the_same_atom(text: str) -> None:
    assert parse_atom(text) == MILK_IN_FRIDGE


def test_atom_prints_in_both_spellings() -> None:
    assert str(MILK_IN_FRIDGE) == "IsIn(milk,fridge)"
    assert MILK_IN_FRIDGE.underscored == "IsIn_milk_fridge"
    assert parse_atom(str(MILK_IN_FRIDGE)) == parse_atom(MILK_IN_FRIDGE.underscored) == MILK_IN_FRIDGE


def test_unary_atom_in_both_spellings() -> None:
    assert parse_atom("IsOpen(fridge)") == parse_atom("IsOpen_fridge") == Atom("IsOpen", ("fridge",))


@pytest.mark.parametrize("text", ["IsStanding()", "IsStanding", " IsStanding ( ) "])
def test_zero_arity_atom_has_no_arguments(text: str) -> None:
    # ``P()`` and a bare ``P`` are the same atom with no arguments; it prints as ``P()`` / ``P``.
    atom = parse_atom(text)
    assert atom == Atom("IsStanding", ())
    assert str(atom) == "IsStanding()"
    assert atom.underscored == "IsStanding"


def test_names_keep_case_and_may_contain_hyphens() -> None:
    assert parse_atom("On(ADMilk,Bar2)") == Atom("On", ("ADMilk", "Bar2"))
    assert parse_atom("On(admilk,Bar2)") != parse_atom("On(ADMilk,Bar2)")
    assert parse_atom("On(coffee-cup,table)") == Atom("On", ("coffee-cup", "table"))


def test_underscored_spelling_splits_every_underscore() -> None:
    # The first '_' ends the predicate; every further '_' separates arguments.
    assert parse_atom("RightPutIn_apple_fridge") == Atom("RightPutIn", ("apple", "fridge"))
    assert parse_atom("A_b_c_d") == Atom("A", ("b", "c", "d"))


@pytest.mark.parametrize(
    "text",
    [
        "",
        "   ",
        "IsIn(milk,)",
        "IsIn(,fridge)",
        "IsIn(milk,,fridge)",
        "IsIn(milk fridge)",
        "IsIn(milk,fridge",
        "IsIn milk,fridge)",
        "IsIn(milk,fridge) extra",
        "IsIn((milk),fridge)",
        "IsIn(milk;fridge)",
        "IsIn milk",
        "IsIn__milk",
        "IsIn_milk_",
        "_IsIn_milk",
        "1IsIn(milk)",
        "IsIn(1milk)",
        "(milk,fridge)",
    ],
)
def test_malformed_atoms_raise_input_error(text: str) -> None:
    with pytest.raises(InputError, match="malformed literal"):
        parse_atom(text)


def test_atoms_are_hashable_ordered_values() -> None:
    atoms = {parse_atom("IsOpen(b)"), parse_atom("IsOpen_b"), parse_atom("IsOpen(a)")}
    assert sorted(atoms) == [Atom("IsOpen", ("a",)), Atom("IsOpen", ("b",))]


# --------------------------------------------------------------- conjunctions
def test_conjunction_with_ampersand_keeps_order() -> None:
    goal = parse_conjunction("IsIn_milk_fridge & IsClose(fridge)")
    assert goal == (MILK_IN_FRIDGE, Atom("IsClose", ("fridge",)))


def test_conjunction_without_spaces_and_single_literal() -> None:
    assert parse_conjunction("IsOpen(a)&IsOpen(b)") == (Atom("IsOpen", ("a",)), Atom("IsOpen", ("b",)))
    assert parse_conjunction("IsOpen_a") == (Atom("IsOpen", ("a",)),)


def test_conjunction_drops_repeats_across_spellings() -> None:
    goal = parse_conjunction("IsIn_milk_fridge & IsClose(fridge) & IsIn(milk, fridge) & IsClose_fridge")
    assert goal == (MILK_IN_FRIDGE, Atom("IsClose", ("fridge",)))


def test_commas_inside_an_atom_do_not_split() -> None:
    assert split_conjunction("IsIn(milk,fridge) & IsOn(a,b)") == ["IsIn(milk,fridge)", "IsOn(a,b)"]


@pytest.mark.parametrize("text", ["", "   ", "\n"])
def test_empty_goal_is_rejected(text: str) -> None:
    with pytest.raises(InputError, match="empty goal"):
        parse_conjunction(text)


@pytest.mark.parametrize("text", ["IsOpen(a) &", "& IsOpen(a)", "IsOpen(a) && IsOpen(b)", "IsOpen(a) & & IsOpen(b)"])
def test_empty_conjunct_is_rejected(text: str) -> None:
    with pytest.raises(InputError, match="empty conjunct"):
        parse_conjunction(text)


@pytest.mark.parametrize("text", ["IsOpen(a) | IsOpen(b)", "IsOpen(a) and IsOpen(b)", "IsOpen(a), IsOpen(b)"])
def test_only_ampersand_joins_literals(text: str) -> None:
    with pytest.raises(InputError, match="malformed literal"):
        parse_conjunction(text)


# ------------------------------------------------------------------- long goals (issue 14, G)
def test_a_long_conjunction_is_parsed_without_pairwise_comparisons(monkeypatch: pytest.MonkeyPatch) -> None:
    """Removing repeats compares atoms by hash, not each with every earlier one (was quadratic)."""
    comparisons = 0
    equal = Atom.__eq__

    def counting(self: Atom, other: object) -> bool:
        nonlocal comparisons
        comparisons += 1
        return equal(self, other)

    monkeypatch.setattr(Atom, "__eq__", counting)
    monkeypatch.setattr(Atom, "__hash__", lambda self: hash((self.predicate, self.args)))
    texts = [f"IsIn(x{i},y{i})" for i in range(3000)]
    atoms = parse_conjunction(" & ".join(texts + texts[:10]))
    assert comparisons <= 100  # the ten repeats, and rare hash collisions (the old way: 4.5 million)
    assert [str(a) for a in atoms] == texts


def test_a_10000_literal_conjunction_keeps_order_and_drops_repeats() -> None:
    texts = [f"P_a{i % 7000}" for i in range(10_000)]
    atoms = parse_conjunction(" & ".join(texts))
    assert len(atoms) == 7000
    assert atoms[0] == Atom("P", ("a0",))
    assert atoms[-1] == Atom("P", ("a6999",))


def test_errors_about_long_goals_stay_short() -> None:
    text = " & ".join(f"IsIn(x{i},y{i})" for i in range(10_000)) + " &"
    with pytest.raises(InputError, match="empty conjunct") as error:
        parse_conjunction(text)
    message = str(error.value)
    assert len(message) < 200
    assert f"({len(text.strip())} characters)" in message
    assert "number 10001 of 10001" in message
    with pytest.raises(InputError, match="malformed literal") as error:
        parse_atom("IsIn(x,y) " * 1000)
    assert len(str(error.value)) < 200
