"""Relaxed reachability (``ground(..., reachable_only=True)``): what it removes and what it must keep."""

from __future__ import annotations

from typing import Any

import pytest

from hbtp.domains import ground, load_scenario, read_domain, read_problem
from hbtp.domains.pddl_writer import write_grounded
from hbtp.domains.reachability import reachable_actions
from hbtp.domains.scenarios import manifest_entry
from hbtp.logic import GroundTask
from hbtp.planning import Status, plan
from helpers import brute_force, random_case

DOMAIN = """\
(define (domain d)
  (:requirements :strips)
  (:predicates (At ?x) (Link ?x ?y) (Has ?x) (Done))
  (:action Go :parameters (?x ?y) :precondition (and (At ?x) (Link ?x ?y)) :effect (and (At ?y) (not (At ?x))))
  (:action Take :parameters (?x) :precondition (At ?x) :effect (Has ?x))
  (:action Finish :parameters (?x) :precondition (Has ?x) :effect (and (Done) (not (Has ?x)))))
"""
# a -> b is linked, c is an island: nothing can reach c, so Take(c), Finish(c), Go(c,a) never happen.
PROBLEM = """\
(define (problem p) (:domain d) (:objects a b c)
  (:init (At a) (Link a b) (Link c a)) (:goal (and (Done))))
"""


def _ground(domain: str, problem: str, **options: Any) -> GroundTask:
    parsed = read_domain(domain)
    return ground(parsed, read_problem(problem, parsed), **options)


def test_unreachable_actions_and_atoms_are_removed() -> None:
    full = _ground(DOMAIN, PROBLEM)
    pruned = _ground(DOMAIN, PROBLEM, reachable_only=True)
    assert [a.name for a in full.actions] == [
        "Finish(a)", "Finish(b)", "Finish(c)", "Go(a,b)", "Go(c,a)", "Take(a)", "Take(b)", "Take(c)"
    ]  # fmt: skip
    assert [a.name for a in pruned.actions] == ["Finish(a)", "Finish(b)", "Go(a,b)", "Take(a)", "Take(b)"]
    assert [a.index for a in pruned.actions] == list(range(5))
    assert [str(a) for a in pruned.atoms] == ["At(a)", "At(b)", "Done()", "Has(a)", "Has(b)"]
    assert pruned.names(pruned.initial_state) == ["At(a)"]


def test_pruning_is_deterministic_and_keeps_the_relative_order() -> None:
    full = _ground(DOMAIN, PROBLEM)
    first = _ground(DOMAIN, PROBLEM, reachable_only=True)
    second = _ground(DOMAIN, PROBLEM, reachable_only=True)
    kept = [a.name for a in first.actions]
    assert kept == [a.name for a in second.actions]
    assert first.atoms == second.atoms
    assert kept == [a.name for a in full.actions if a.name in set(kept)]


def test_a_pruned_goal_literal_is_unreachable_not_an_input_error() -> None:
    pruned = _ground(DOMAIN, PROBLEM, reachable_only=True)
    goal = pruned.resolve_goal("Has(c)")
    assert [str(a) for a in goal.unreachable] == ["Has(c)"]
    assert plan(pruned, goal, "obtea").status is Status.UNSOLVABLE


def test_the_fixpoint_ignores_deletes_and_reaches_through_chains() -> None:
    actions = [({"b"}, {"c"}), ({"a"}, {"b"}), ({"z"}, {"a"}), ((), {"y"})]
    assert reachable_actions({"a"}, actions) == [0, 1, 3]
    assert reachable_actions((), actions) == [3]


@pytest.mark.parametrize("seed", range(150))
def test_pruning_never_removes_an_action_of_a_plan(seed: int) -> None:
    case = random_case(seed)
    domain, problem = write_grounded(case.task, case.goal)
    full = _ground(domain, problem)
    pruned = _ground(domain, problem, reachable_only=True)
    optima = []
    for task in (full, pruned):
        goal = task.resolve_goal(case.goal.atoms)
        optimum, best = brute_force(task, goal.ids) if not goal.unreachable else (None, ())
        found = plan(task, goal, "obtea")
        assert found.cost == optimum, (seed, task is pruned)
        optima.append(optimum)
        if task is full:
            assert {task.actions[i].name for i in best} <= {a.name for a in pruned.actions}, seed
    assert optima == [case.optimum, case.optimum]


@pytest.mark.parametrize(
    ("name", "removed"),
    [
        ("robowaiter", []),
        ("virtualhome", []),
        # IsSwitchedOff(fridge) and IsSwitchedOff(mouse) never hold: these two can never be applied.
        ("robothow-small", ["PlugOut(fridge)", "PlugOut(mouse)"]),
    ],
)
def test_scenarios_keep_their_counts_and_lose_only_unreachable_actions(name: str, removed: list[str]) -> None:
    scenario = load_scenario(name, keep_self_placements=True)  # the paper's action space
    parsed = scenario.parsed
    assert parsed is not None
    task = scenario.task
    counts = {"robowaiter": 174, "virtualhome": 480, "robothow-small": 155}
    assert len(task.actions) == counts[name]  # the default grounding does not prune
    keep = manifest_entry(name).get("keep_fluent", ())
    pruned = ground(parsed.domain, parsed.problem, keep_fluent=keep, reachable_only=True)
    assert sorted({a.name for a in task.actions} - {a.name for a in pruned.actions}) == removed
    assert len(pruned.actions) == counts[name] - len(removed)
