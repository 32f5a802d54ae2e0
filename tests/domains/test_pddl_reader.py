"""PDDL reading: the supported subset, and errors that name the construct and point at it."""

from __future__ import annotations

import re
import time
from pathlib import Path

import pytest

from hbtp.domains import ground, read_domain, read_domain_file, read_problem, read_problem_file, write_domain
from hbtp.domains.lifted import (
    ActionSchema,
    AddEffect,
    And,
    AndEffect,
    AtomFormula,
    CostEffect,
    DeleteEffect,
    Equals,
    Exists,
    ForallEffect,
    Imply,
    Not,
    Or,
    TypedName,
    WhenEffect,
)
from hbtp.domains.sexpr import MAX_NESTING, SList, Symbol, parse_sexprs
from hbtp.errors import InputError, PddlError

# In the texts below, "@" marks where an error must point; it is removed before reading.
MARK = "@"

# A small domain that the error cases are variations of; %s is where actions go.
DOMAIN = """\
(define (domain shop)
  (:requirements :strips :typing :equality :action-costs)
  (:types item place - object food - item)
  (:constants self - object till - place)
  (:predicates (at ?x - item ?p - place) (near ?a - object ?p - place) (clean ?p - place) (Exists ?x))
  (:functions (total-cost) - number (dist ?p - place) - number)
%s)
"""

PROBLEM = """\
(define (problem p1)
  (:domain shop)
  (:objects apple - food shelf - place)
  (:init (at apple shelf) (near self till) (= (dist shelf) 4))
  (:goal (and (at apple till)))
  (:metric minimize (total-cost)))
"""


def _marked(text: str) -> tuple[str, int, int]:
    """Remove the marker from ``text``; return the text and the marker's 1-based line and column."""
    index = text.index(MARK)
    line = text.count("\n", 0, index) + 1
    column = index - (text.rfind("\n", 0, index) + 1) + 1
    return text.replace(MARK, "", 1), line, column


def _action(body: str) -> str:
    return DOMAIN % f"  (:action act\n    {body})\n"


# ==================================================================== errors
DOMAIN_ERRORS = {
    "unbalanced close": ("(define (domain d)\n  (:predicates (p ?x)))\n@)", r"unbalanced '\)'"),
    "unclosed section": ("(define (domain d)\n  @(:predicates (p ?x)\n", r"'\(' is never closed"),
    "unclosed define": ("@(define (domain d)\n  (:predicates (p ?x))\n", r"'\(' is never closed"),
    "unknown predicate": (
        _action(":parameters (?x - item) :precondition @(onn ?x) :effect (clean till)"),
        "unknown predicate 'onn'",
    ),
    "unknown predicate in effect": (
        _action(":parameters (?x - item) :effect (and (Exists ?x) @(gone ?x))"),
        "unknown predicate 'gone'",
    ),
    "wrong arity": (
        _action(":parameters (?x - item) :precondition @(at ?x) :effect (clean till)"),
        r"predicate 'at' takes 2 argument\(s\), found 1",
    ),
    "wrong arity in a delete effect": (
        _action(":parameters (?p - place) :effect (not @(clean ?p ?p))"),
        r"predicate 'clean' takes 1 argument\(s\), found 2",
    ),
    "unknown object": (
        _action(":parameters (?x - item) :precondition (at ?x @cellar) :effect (clean till)"),
        "unknown object or constant 'cellar'",
    ),
    "unbound variable": (
        _action(":parameters (?x - item) :precondition (at ?x @?p) :effect (clean till)"),
        r"unbound variable '\?p'",
    ),
    "unbound variable in effect": (
        _action(":parameters (?x - item) :effect (near self @?q)"),
        r"unbound variable '\?q'",
    ),
    "unknown type of a parameter": (
        _action(":parameters (?x - @gadget) :effect (Exists ?x)"),
        r"action 'act': unknown type 'gadget' \(of '\?x'\)",
    ),
    "unknown type in either": (
        _action(":parameters (?x - (either item @gadget)) :effect (Exists ?x)"),
        "unknown type 'gadget'",
    ),
    "unknown type of a forall variable": (
        _action(":parameters () :effect (forall (?y - @gadget) (Exists ?y))"),
        "unknown type 'gadget'",
    ),
    "unknown type of a predicate argument": (
        "(define (domain d)\n  (:types place)\n  (:predicates (p ?x - @gadget)))",
        r"unknown type 'gadget' \(of '\?x'\)",
    ),
    "unknown type of a constant": (
        "(define (domain d)\n  (:constants c - @gadget)\n  (:predicates (p ?x)))",
        r"unknown type 'gadget' \(of 'c'\)",
    ),
    "fluents requirement": ("(define (domain d)\n  (:requirements :strips @:fluents))", "requirement :fluents"),
    "durative-actions requirement": (
        "(define (domain d)\n  (:requirements @:durative-actions))",
        "requirement :durative-actions",
    ),
    "numeric-fluents requirement": (
        "(define (domain d) (:requirements :typing @:numeric-fluents))",
        "requirement :numeric-fluents",
    ),
    "derived section": (
        "(define (domain d)\n  (:predicates (p ?x) (q ?x))\n  @(:derived (p ?x) (q ?x)))",
        r"derived predicates \(:derived\) are not supported",
    ),
    "durative-action section": (
        "(define (domain d)\n  (:predicates (p))\n  @(:durative-action a :parameters () :duration (= ?duration 1)"
        "\n   :condition (at start (p)) :effect (at end (p))))",
        r"durative actions \(:durative-action\) are not supported",
    ),
    "exists binding no variable": (
        _action(
            ":parameters (?x - item) :precondition (and (Exists ?x) @(exists () (at ?x till))) :effect (clean till)"
        ),
        r"\(exists \.\.\.\) binds no variable",
    ),
    "forall with three parts": (
        _action(
            ":parameters (?x - item) :precondition @(forall (?p - place) (at ?x ?p) (clean ?p)) :effect (clean till)"
        ),
        r"\(forall \(\?vars\) condition\) takes two parts",
    ),
    "forall over an unknown type": (
        _action(":parameters (?x - item) :precondition (forall (?p - @room) (at ?x ?p)) :effect (clean till)"),
        r"unknown type 'room'",
    ),
    "numeric condition >": (
        _action(":parameters (?p - place) :precondition (and (clean ?p) @(> (dist ?p) 3)) :effect (clean ?p)"),
        r"numeric conditions \(>\)",
    ),
    "numeric condition <=": (
        _action(":parameters (?p - place) :precondition @(<= (dist ?p) 3) :effect (clean ?p)"),
        r"numeric conditions \(<=\)",
    ),
    "decrease effect": (
        _action(":parameters (?p - place) :effect (and (clean ?p) @(decrease (total-cost) 1))"),
        r"numeric effect \(decrease\) is not supported",
    ),
    "assign effect": (
        _action(":parameters (?p - place) :effect (and (clean ?p) @(assign (dist ?p) 1))"),
        r"numeric effect \(assign\)",
    ),
    "negative cost": (
        _action(":parameters () :effect (and (clean till) (increase (total-cost) @-2))"),
        "must not be negative",
    ),
    "cost that is not a number": (
        _action(":parameters () :effect (and (clean till) (increase (total-cost) @lots))"),
        "not a whole number",
    ),
    "cost in Arabic-Indic digits": (
        _action(":parameters () :effect (and (clean till) (increase (total-cost) @\u0663))"),
        "not a whole number",
    ),
    "cost with an underscore": (
        _action(":parameters () :effect (and (clean till) (increase (total-cost) @1_0))"),
        "not a whole number",
    ),
    "cost of 400 digits": (
        _action(":parameters () :effect (and (clean till) (increase (total-cost) @" + "9" * 400 + "))"),
        r"\(400 digits\) is too large \(at most 1000000\)",
    ),
    "cost just above the maximum": (
        _action(":parameters () :effect (and (clean till) (increase (total-cost) @1000001))"),
        "too large",
    ),
    "nesting 500 deep": (
        _action(
            ":parameters () :precondition " + "(and " * 98 + "@" + "(and " * 402 + ")" * 500 + " :effect (clean till)"
        ),
        "nested deeper than 100 levels",
    ),
    "increase of another function": (
        _action(":parameters (?p - place) :effect (increase @(dist ?p) 1)"),
        r"only \(increase \(total-cost\)",
    ),
    "cost from an undeclared function": (
        _action(":parameters (?p - place) :effect (increase (total-cost) @(size ?p))"),
        "declared static function",
    ),
    "unknown action keyword": (
        _action(":parameters () @:duration 3 :effect (clean till)"),
        "unknown keyword :duration",
    ),
    "action without effect": (DOMAIN % "  @(:action act :parameters ())\n", "has no :effect"),
    "duplicate action": (
        DOMAIN % "  (:action a :effect (clean till))\n  @(:action a :effect (clean till))\n",
        "action 'a' is declared twice",
    ),
    "duplicate predicate": ("(define (domain d)\n  (:predicates (p ?x) @(p ?y)))", "predicate 'p' is declared twice"),
    "unknown section": ("(define (domain d)\n  @(:axioms))", "unknown domain section :axioms"),
    "variable among constants": ("(define (domain d)\n  (:constants a @?b))", r"expected a name without '\?'"),
}


@pytest.mark.parametrize("case", sorted(DOMAIN_ERRORS))
def test_domain_error_names_the_construct_and_its_place(case: str) -> None:
    text, line, column = _marked(DOMAIN_ERRORS[case][0])
    with pytest.raises(PddlError) as info:
        read_domain(text, "shop.pddl")
    error = info.value
    assert re.search(DOMAIN_ERRORS[case][1], error.message), error.message
    assert (error.line, error.column) == (line, column), error.message
    assert error.source == "shop.pddl"
    assert str(error).startswith(f"shop.pddl:{line}:{column}: ")
    assert isinstance(error, InputError)


PROBLEM_ERRORS = {
    "problem for another domain": (
        PROBLEM.replace("(:domain shop)", "@(:domain other)"),
        "problem is for domain 'other', not 'shop'",
    ),
    "unbalanced close": (PROBLEM + "@)", r"unbalanced '\)'"),
    "unknown object in init": (
        PROBLEM.replace("(near self till)", "(near self @attic)"),
        "unknown object or constant 'attic'",
    ),
    "unknown predicate in goal": (
        PROBLEM.replace("(and (at apple till))", "(and @(on apple till))"),
        "unknown predicate 'on'",
    ),
    "wrong arity in init": (PROBLEM.replace("(at apple shelf)", "@(at apple)"), "takes 2 argument"),
    "unknown type of an object": (
        PROBLEM.replace("apple - food", "apple - @fruit"),
        r"unknown type 'fruit' \(of 'apple'\)",
    ),
    "unknown function": (PROBLEM.replace("(= (dist shelf) 4)", "(= @(size shelf) 4)"), "unknown function 'size'"),
    "variable in init": (PROBLEM.replace("(at apple shelf)", "(at @?x shelf)"), r"unbound variable '\?x'"),
    "negation in init": (PROBLEM.replace("(at apple shelf)", "@(not (at apple shelf))"), "atoms only"),
    "other metric": (
        PROBLEM.replace("(:metric minimize (total-cost))", "@(:metric maximize (total-cost))"),
        r"only \(:metric minimize \(total-cost\)\)",
    ),
    "numeric goal": (
        PROBLEM.replace("(and (at apple till))", "(and (at apple till) @(< (dist shelf) 3))"),
        r"numeric conditions \(<\)",
    ),
    "numeric fact in Arabic-Indic digits": (PROBLEM.replace("(dist shelf) 4)", "(dist shelf) @\u0664)"), "not a whole"),
    "numeric fact of 400 digits": (PROBLEM.replace("(dist shelf) 4)", "(dist shelf) @" + "4" * 400 + ")"), "too large"),
    "exists in goal binding no variable": (
        PROBLEM.replace("(and (at apple till))", "@(exists () (at apple till))"),
        r"binds no variable",
    ),
}


@pytest.mark.parametrize("case", sorted(PROBLEM_ERRORS))
def test_problem_error_names_the_construct_and_its_place(case: str) -> None:
    domain = read_domain(DOMAIN % "")
    text, line, column = _marked(PROBLEM_ERRORS[case][0])
    with pytest.raises(PddlError) as info:
        read_problem(text, domain, "p1.pddl")
    error = info.value
    assert re.search(PROBLEM_ERRORS[case][1], error.message), error.message
    assert (error.line, error.column) == (line, column), error.message
    assert error.source == "p1.pddl"


def test_object_that_repeats_a_constant_of_another_type_is_rejected() -> None:
    domain = read_domain(DOMAIN % "")
    text, line, column = _marked(PROBLEM.replace("shelf - place", "shelf @till - item"))
    with pytest.raises(PddlError, match="'till' is already a domain constant, of another type") as info:
        read_problem(text, domain)
    assert (info.value.line, info.value.column) == (line, column)


# ==================================================== a predicate named Exists
def test_predicate_named_exists_is_a_predicate_not_the_quantifier() -> None:
    domain = read_domain(
        _action(":parameters (?x - item) :precondition (and (Exists ?x) (not (= ?x self))) :effect (not (Exists ?x))")
    )
    (action,) = domain.actions
    assert action.precondition == And((AtomFormula("Exists", ("?x",)), Not(Equals("?x", "self"))))
    assert action.effect == DeleteEffect(AtomFormula("Exists", ("?x",)))
    problem = read_problem(
        PROBLEM.replace("(at apple shelf)", "(Exists apple)").replace("(and (at apple till))", "(Exists apple)"),
        domain,
    )
    assert AtomFormula("Exists", ("apple",)) in problem.init
    assert problem.goal == AtomFormula("Exists", ("apple",))


def test_lower_case_exists_stays_the_quantifier_beside_a_predicate_named_exists() -> None:
    domain = read_domain(_action(":parameters () :precondition (exists (?x - item) (Exists ?x)) :effect (clean till)"))
    action = domain.actions[-1]
    assert action.precondition == Exists((TypedName("?x", ("item",)),), AtomFormula("Exists", ("?x",)))


def test_robowaiter_exists_reads_as_a_predicate() -> None:
    domain = read_domain_file(Path(__file__).parents[2] / "src/hbtp/domains/data/robowaiter.domain.pddl")
    assert "Exists" in domain.predicates
    pick_up = next(a for a in domain.actions if a.name == "PickUp")
    assert isinstance(pick_up.effect, AndEffect)
    assert DeleteEffect(AtomFormula("Exists", ("?x",))) in pick_up.effect.parts


# ====================================================== what the reader accepts
def test_reads_types_constants_predicates_and_functions() -> None:
    domain = read_domain(DOMAIN % "")
    assert domain.name == "shop"
    assert domain.requirements == (":strips", ":typing", ":equality", ":action-costs")
    assert domain.types == {"item": "object", "place": "object", "food": "item"}
    assert domain.constants == (TypedName("self"), TypedName("till", ("place",)))
    assert domain.predicates["at"] == (TypedName("?x", ("item",)), TypedName("?p", ("place",)))
    assert domain.predicates["near"] == (TypedName("?a"), TypedName("?p", ("place",)))
    assert domain.functions == {"total-cost": (), "dist": (TypedName("?p", ("place",)),)}
    assert domain.uses_action_costs


def test_keywords_and_names_are_case_insensitive_and_keep_the_declared_spelling() -> None:
    domain = read_domain(
        "(DEFINE (DOMAIN Shop) (:REQUIREMENTS :STRIPS) (:PREDICATES (Near ?X) (far ?x))"
        " (:ACTION Go :PARAMETERS (?x) :PRECONDITION (AND (NEAR ?x)) :EFFECT (AND (Far ?X) (NOT (near ?x)))))"
    )
    assert domain.name == "Shop"
    assert domain.requirements == (":strips",)
    assert set(domain.predicates) == {"Near", "far"}
    (action,) = domain.actions
    assert action.name == "Go"
    assert action.parameters == (TypedName("?x"),)
    assert action.effect == AndEffect(
        (AddEffect(AtomFormula("far", ("?x",))), DeleteEffect(AtomFormula("Near", ("?x",))))
    )


def test_reads_an_action_with_every_supported_construct() -> None:
    text = _action(
        """:parameters (?x - (either item place) ?p ?q - place)
    :precondition (and (at ?x ?p) (not (= ?p ?q)) (or (clean ?p) (clean ?q)) (imply (clean ?q) (near self ?q)))
    :effect (and (at ?x ?q) (not (at ?x ?p))
                 (forall (?r - place) (when (not (= ?r ?q)) (not (near self ?r))))
                 (when (= ?p till) (increase (total-cost) 8))
                 (increase (total-cost) (dist ?q)))"""
    )
    (action,) = read_domain(text).actions
    near_r = AtomFormula("near", ("self", "?r"))
    assert action == ActionSchema(
        "act",
        (TypedName("?x", ("item", "place")), TypedName("?p", ("place",)), TypedName("?q", ("place",))),
        And(
            (
                AtomFormula("at", ("?x", "?p")),
                Not(Equals("?p", "?q")),
                Or((AtomFormula("clean", ("?p",)), AtomFormula("clean", ("?q",)))),
                Imply(AtomFormula("clean", ("?q",)), AtomFormula("near", ("self", "?q"))),
            )
        ),
        AndEffect(
            (
                AddEffect(AtomFormula("at", ("?x", "?q"))),
                DeleteEffect(AtomFormula("at", ("?x", "?p"))),
                ForallEffect((TypedName("?r", ("place",)),), WhenEffect(Not(Equals("?r", "?q")), DeleteEffect(near_r))),
                WhenEffect(Equals("?p", "till"), CostEffect(8)),
                CostEffect(AtomFormula("dist", ("?q",))),
            )
        ),
    )


def test_empty_precondition_and_missing_parameters() -> None:
    (action,) = read_domain(DOMAIN % "  (:action a :precondition () :effect (clean till))\n").actions
    assert action.parameters == ()
    assert action.precondition == And(())
    assert action.effect == AddEffect(AtomFormula("clean", ("till",)))


def test_reads_a_problem() -> None:
    problem = read_problem(PROBLEM, read_domain(DOMAIN % ""))
    assert problem.name == "p1"
    assert problem.domain_name == "shop"
    assert problem.objects == (TypedName("apple", ("food",)), TypedName("shelf", ("place",)))
    assert problem.init == (AtomFormula("at", ("apple", "shelf")), AtomFormula("near", ("self", "till")))
    assert problem.numeric_init == {("dist", ("shelf",)): 4}
    assert problem.goal == And((AtomFormula("at", ("apple", "till")),))
    assert problem.minimize_cost


def test_domain_name_of_a_problem_is_case_insensitive() -> None:
    problem = read_problem(PROBLEM.replace("(:domain shop)", "(:domain SHOP)"), read_domain(DOMAIN % ""))
    assert problem.domain_name == "SHOP"


def test_comments_are_skipped_and_positions_count_from_one() -> None:
    exprs = parse_sexprs("; a comment (with a paren\n  (a (b c)) ; more\nd")
    first, last = exprs
    assert isinstance(first, SList)
    assert (first.line, first.column) == (2, 3)
    assert first.head() == "a"
    inner = first.items[1]
    assert isinstance(inner, SList)
    assert (inner.line, inner.column) == (2, 6)
    assert inner.items[1] == Symbol("c", 2, 9)
    assert last == Symbol("d", 3, 1)


def test_file_reading_errors_are_pddl_errors(tmp_path: Path) -> None:
    missing = tmp_path / "missing.pddl"
    with pytest.raises(PddlError, match="cannot read the PDDL file") as info:
        read_domain_file(missing)
    assert info.value.source == str(missing)
    binary = tmp_path / "binary.pddl"
    binary.write_bytes(b"(define \xff\xfe)")
    with pytest.raises(PddlError, match="not UTF-8"):
        read_domain_file(binary)


def test_file_errors_name_the_file(tmp_path: Path) -> None:
    domain_file = tmp_path / "shop.pddl"
    domain_file.write_text(DOMAIN % "", encoding="utf-8")
    problem_file = tmp_path / "p1.pddl"
    problem_file.write_text(PROBLEM.replace("(near self till)", "(near self attic)"), encoding="utf-8")
    with pytest.raises(PddlError) as info:
        read_problem_file(problem_file, read_domain_file(domain_file))
    assert str(info.value).startswith(f"{problem_file}:4:")


@pytest.mark.parametrize(
    ("text", "message"),
    [
        ("", "<domain>:1:1: the file is empty"),
        ("; only a comment", "<domain>:1:1: the file holds only comments"),
        ("(define (domain a)) (define (domain b))", "<domain>:1:21: expected exactly one (define ...) form"),
    ],
)
def test_exactly_one_define_form(text: str, message: str) -> None:
    with pytest.raises(PddlError) as info:
        read_domain(text)
    assert str(info.value).startswith(message)


def test_a_utf8_byte_order_mark_is_skipped(tmp_path: Path) -> None:
    domain_path, problem_path = tmp_path / "domain.pddl", tmp_path / "problem.pddl"
    domain_path.write_bytes(b"\xef\xbb\xbf" + (DOMAIN % "").encode())
    problem_path.write_text(PROBLEM, encoding="utf-8-sig")
    domain = read_domain_file(domain_path)
    assert domain == read_domain(DOMAIN % "")
    assert read_problem_file(problem_path, domain) == read_problem(PROBLEM, domain)
    # Positions stay those of the text without the mark.
    with pytest.raises(PddlError) as info:
        read_domain("\ufeff(define (domain d) @x)".replace("@", ""))
    assert (info.value.line, info.value.column) == (1, 20)


def test_costs_up_to_the_maximum_and_signed_numerals_are_read() -> None:
    domain = read_domain(DOMAIN % _action_text("(increase (total-cost) 1000000)"))
    assert domain.actions[0].effect == AndEffect((AddEffect(AtomFormula("clean", ("till",))), CostEffect(1000000)))
    plus = read_domain(DOMAIN % _action_text("(increase (total-cost) +07)"))
    assert plus.actions[0].effect == AndEffect((AddEffect(AtomFormula("clean", ("till",))), CostEffect(7)))


def _action_text(cost: str) -> str:
    return f"  (:action act :parameters () :effect (and (clean till) {cost}))\n"


def test_nesting_up_to_the_limit_is_read_and_grounded() -> None:
    depth = MAX_NESTING - 6  # define, :action, and the (not ...) / (clean ...) around the chain
    precondition = "(and " * depth + "(near self till)" + ")" * depth
    domain = read_domain(DOMAIN % f"  (:action act :parameters () :precondition {precondition} :effect (clean till))\n")
    task = ground(domain, read_problem(PROBLEM, domain))
    assert [a.name for a in task.actions] == ["act()"]
    assert write_domain(domain).count("(and ") == depth


def test_many_actions_and_objects_are_read_in_linear_time() -> None:
    # Duplicate checks used to compare every action (and every object) with all earlier ones.
    actions = "".join(f"  (:action a{i} :parameters () :effect (clean till))\n" for i in range(20_000))
    started = time.perf_counter()
    domain = read_domain(DOMAIN % actions)
    objects = " ".join(f"o{i}" for i in range(20_000))
    problem = read_problem(PROBLEM.replace("apple - food", f"apple {objects} - food"), domain)
    elapsed = time.perf_counter() - started
    assert len(domain.actions) == 20_000
    assert len(problem.objects) == 20_002  # apple, the 20,000 and shelf
    assert elapsed < 6.0  # quadratic checks took about a minute
