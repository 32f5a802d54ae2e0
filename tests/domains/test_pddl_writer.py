"""PDDL writing: read -> write -> read is the identity; a grounded task written out grounds back to itself."""

from __future__ import annotations

import json
from importlib import resources
from pathlib import Path

import pytest

from hbtp.cli import main
from hbtp.domains import (
    DomainBuilder,
    Scenario,
    ground,
    load_scenario,
    read_domain,
    read_domain_file,
    read_problem,
    read_problem_file,
    write_domain,
    write_grounded,
    write_problem,
)
from hbtp.domains.lifted import And, AtomFormula
from hbtp.logic import GroundTask

DATA = Path(str(resources.files("hbtp.domains") / "data"))

# (domain file, problem file) of every shipped scenario, as in scenarios.toml.
SHIPPED = [
    ("robowaiter.domain.pddl", "robowaiter.problem.pddl"),
    ("virtualhome.domain.pddl", "virtualhome.problem.pddl"),
    ("robothow.domain.pddl", "robothow-small.problem.pddl"),
    ("robothow.domain.pddl", "robothow.problem.pddl"),
]

HAND_WRITTEN_DOMAIN = """\
(define (domain shop)
  (:requirements :strips :typing :equality :action-costs :conditional-effects)
  (:types item place - object food - item)
  (:constants self - object till - place)
  (:predicates (at ?x - item ?p - place) (near ?a - object ?p - place) (clean ?p - place) (Exists ?x))
  (:functions (total-cost) - number (dist ?p - place) - number)
  (:action move
    :parameters (?x - (either item place) ?p ?q - place)
    :precondition (and (at ?x ?p) (not (= ?p ?q)) (or (clean ?p) (clean ?q)) (imply (clean ?q) (near self ?q)))
    :effect (and (at ?x ?q) (not (at ?x ?p))
                 (forall (?r - place) (when (not (= ?r ?q)) (not (near self ?r))))
                 (when (= ?p till) (increase (total-cost) 8))
                 (increase (total-cost) (dist ?q))))
  (:action noop :parameters () :precondition (and) :effect (and)))
"""

HAND_WRITTEN_PROBLEM = """\
(define (problem p1)
  (:domain shop)
  (:objects apple - food shelf - place)
  (:init (at apple shelf) (near self till) (= (dist shelf) 4) (= (dist till) 1))
  (:goal (and (at apple till) (not (clean shelf))))
  (:metric minimize (total-cost)))
"""


@pytest.mark.parametrize("domain_file", sorted({d for d, _ in SHIPPED}))
def test_shipped_domain_round_trip(domain_file: str) -> None:
    domain = read_domain_file(DATA / domain_file)
    text = write_domain(domain)
    again = read_domain(text)
    assert again == domain
    assert len(again.actions) == len(domain.actions) > 0
    assert write_domain(again) == text


@pytest.mark.parametrize(("domain_file", "problem_file"), SHIPPED)
def test_shipped_problem_round_trip(domain_file: str, problem_file: str) -> None:
    domain = read_domain_file(DATA / domain_file)
    problem = read_problem_file(DATA / problem_file, domain)
    text = write_problem(problem)
    again = read_problem(text, read_domain(write_domain(domain)))
    assert again == problem
    assert len(again.init) == len(problem.init) > 0
    assert write_problem(again) == text


def test_hand_written_round_trip_keeps_every_construct() -> None:
    domain = read_domain(HAND_WRITTEN_DOMAIN)
    problem = read_problem(HAND_WRITTEN_PROBLEM, domain)
    domain_text, problem_text = write_domain(domain), write_problem(problem)
    assert read_domain(domain_text) == domain
    assert read_problem(problem_text, domain) == problem
    for fragment in (
        "(either item place)",
        "(imply (clean ?q) (near self ?q))",
        "(forall (?r - place)",
        "(increase (total-cost) (dist ?q))",
        "(when (= ?p till) (increase (total-cost) 8))",
    ):
        assert fragment in domain_text
    assert "(= (dist shelf) 4)" in problem_text
    assert "(:metric minimize (total-cost))" in problem_text


def test_round_trip_changes_meaning_when_the_text_changes() -> None:
    # Equality is structural: it is not blind to a real difference.
    domain = read_domain(HAND_WRITTEN_DOMAIN)
    assert read_domain(HAND_WRITTEN_DOMAIN.replace("(increase (total-cost) 8)", "(increase (total-cost) 9)")) != domain
    assert (
        read_domain(HAND_WRITTEN_DOMAIN.replace("(or (clean ?p) (clean ?q))", "(or (clean ?q) (clean ?p))")) != domain
    )


# ------------------------------------------------------------------ grounded
def _actions_by_name(task: GroundTask, *, underscored: bool) -> dict[str, tuple[list[str], list[str], list[str], int]]:
    """Every action as readable (pre, add, del, cost), keyed by ``Walk_apple``.

    ``underscored`` names the original task's actions; a re-grounded task's actions are 0-ary and
    already called ``Walk_apple``.
    """
    return {
        (a.signature.underscored if underscored else a.predicate): (
            task.names(a.pre),
            task.names(a.add),
            task.names(a.delete),
            a.cost,
        )
        for a in task.actions
    }


@pytest.mark.parametrize(
    ("name", "goal"),
    [("robowaiter", "On(Coffee,Table1) & Holding(Nothing)"), ("robothow-small", "IsIn(apple,fridge) & IsClean(bed)")],
)
def test_write_grounded_grounds_back_to_the_same_task(name: str, goal: str) -> None:
    task = load_scenario(name).task
    # Our reader takes a predicate named Exists as a predicate: read back the export without renaming.
    domain_text, problem_text = write_grounded(task, task.resolve_goal(goal), rename_keywords=False)
    domain = read_domain(domain_text, "grounded-domain")
    problem = read_problem(problem_text, domain, "grounded-problem")
    # Predicates that no action changes (IsStanding) would be compiled away as static: keep them.
    again = ground(domain, problem, keep_fluent={atom.predicate for atom in task.atoms})
    assert all(a.objects == () for a in again.actions)
    assert len(again.actions) == len(task.actions)
    assert _actions_by_name(again, underscored=False) == _actions_by_name(task, underscored=True)
    assert again.names(again.initial_state) == task.names(task.initial_state)
    assert problem.goal == And(tuple(AtomFormula(a.predicate, a.args) for a in task.resolve_goal(goal).atoms))
    assert problem.minimize_cost


def test_write_grounded_text(robothow_small: Scenario) -> None:
    task = robothow_small.task
    domain_text, problem_text = write_grounded(task, task.resolve_goal("IsIn_apple_fridge & IsClose_fridge"))
    assert "(:requirements :strips :action-costs)" in domain_text
    assert "(:action RightPutIn_apple_fridge\n" in domain_text
    assert "grabbable" not in domain_text  # static facts are compiled away
    assert "(:goal (and (IsIn apple fridge) (IsClose fridge)))" in problem_text
    assert "(= (total-cost) 0)" in problem_text
    assert "(:domain robothow-small)" in problem_text
    assert write_grounded(task, task.resolve_goal("IsOpen(fridge)"), domain_name="d")[0].startswith(
        "(define (domain d)"
    )


def test_names_of_type_object_keep_their_type_before_typed_names() -> None:
    # In "a b - place" the type covers both names: an object-typed name before a typed one needs "- object".
    domain = read_domain(
        "(define (domain d) (:requirements :typing) (:types item place - object food - item)"
        " (:constants a - object b - place c) (:predicates (p ?x - object ?y - place ?z)))"
    )
    text = write_domain(domain)
    assert "(:types item - object place - object food - item)" in text
    assert "(:constants a - object b - place c)" in text
    again = read_domain(text)
    assert again == domain
    assert again.types == {"item": "object", "place": "object", "food": "item"}


def test_grounded_export_names_the_literals_no_action_changes(robothow_small: Scenario) -> None:
    task = robothow_small.task
    domain_text, _ = write_grounded(task, task.resolve_goal("IsOpen(fridge)"))
    assert domain_text.startswith(
        "(define (domain robothow-small)\n"
        "  ; No action changes IsStanding: to keep it in the state when reading this file\n"
        "  ; back into hbtp, add --keep-fluent IsStanding\n  (:requirements"
    )
    plain = DomainBuilder("t").initial(["At(a)"]).action("Go(b)", pre=["At(a)"], add=["At(b)"]).build()
    assert write_grounded(plain, plain.resolve_goal("At(b)"))[0].startswith("(define (domain t)\n  (:requirements")


def test_grounded_export_read_back_with_keep_fluent_has_the_same_state(
    capsys: pytest.CaptureFixture[str], tmp_path: Path
) -> None:
    """The export of issue 11 lost IsStanding(self) from s0: no action changes it, so it read back as static."""
    assert main(["export-pddl", "-s", "robothow-small", "-g", "IsOpen(fridge)", "-o", str(tmp_path)]) == 0
    assert main(["ground", "-s", "robothow-small", "--json"]) == 0
    original = json.loads(capsys.readouterr().out.split("\n", 1)[1])
    files = [str(tmp_path / "domain.pddl"), str(tmp_path / "problem.pddl")]
    assert main(["ground", "--pddl", *files, "--keep-fluent", "IsStanding", "--json"]) == 0
    again = json.loads(capsys.readouterr().out)
    assert again["initial_state"] == original["initial_state"]
    # --pddl keeps only actions reachable from s0: PlugOut(fridge) and PlugOut(mouse) (and the two
    # IsPlugged... atoms only they mention) are not; the shipped scenario keeps the paper's list.
    assert (again["s0"], again["atoms"], again["actions"]) == (
        original["s0"],
        original["atoms"] - 2,
        original["actions"] - 2,
    )
    assert main(["ground", "--pddl", *files, "--json"]) == 0
    static = json.loads(capsys.readouterr().out)
    assert set(original["initial_state"]) - set(static["initial_state"]) == {"IsStanding(self)"}
