"""Grounding: static facts compiled away, bindings joined (not enumerated blindly), STRIPS or an error."""

from __future__ import annotations

import logging
import re
import time
from typing import Any

import pytest

from hbtp.deadline import Deadline, TimeLimitReached
from hbtp.domains import ground, read_domain, read_problem
from hbtp.domains.lifted import MAX_ACTION_COST
from hbtp.errors import GroundingError, InputError, PlanningError
from hbtp.logic import GroundTask


def _ground(domain: str, problem: str, **options: Any) -> GroundTask:
    parsed = read_domain(domain)
    return ground(parsed, read_problem(problem, parsed), **options)


def _names(task: GroundTask, predicate: str | None = None) -> list[str]:
    return sorted(a.name for a in task.actions if predicate is None or a.predicate == predicate)


def _action(task: GroundTask, name: str) -> tuple[list[str], list[str], list[str], int]:
    action = task.action(name)
    return task.names(action.pre), task.names(action.add), task.names(action.delete), action.cost


def _problem(objects: str, init: str, domain: str = "d") -> str:
    return f"(define (problem p) (:domain {domain}) (:objects {objects}) (:init {init}) (:goal (and)))"


# ====================================================================== types
TYPED = """\
(define (domain d)
  (:requirements :strips :typing)
  (:types item place - object food tool - item)
  (:constants robot)
  (:predicates (Seen ?x) (Held ?x - item))
  (:action Take :parameters (?x - item) :effect (Held ?x))
  (:action Taste :parameters (?x - (either food place)) :effect (Seen ?x))
  (:action Look :parameters (?x) :effect (Seen ?x)))
"""


def test_types_follow_the_hierarchy_and_either() -> None:
    task = _ground(TYPED, _problem("apple - food knife - tool cup - item table - place rock", ""))
    assert _names(task, "Take") == ["Take(apple)", "Take(cup)", "Take(knife)"]
    assert _names(task, "Taste") == ["Taste(apple)", "Taste(table)"]
    # Untyped parameters range over every object and constant.
    assert _names(task, "Look") == [f"Look({x})" for x in sorted(["apple", "knife", "cup", "table", "rock", "robot"])]
    assert task.constants == ("robot",)
    assert sorted(task.objects) == ["apple", "cup", "knife", "rock", "table"]


def test_without_action_costs_every_action_costs_one() -> None:
    task = _ground(TYPED, _problem("apple - food", ""))
    assert {a.cost for a in task.actions} == {1}


# ============================================================ static conditions
STATIC = """\
(define (domain d)
  (:requirements :strips :equality :action-costs :disjunctive-preconditions :conditional-effects)
  (:constants self a d)
  (:predicates (At ?x) (Near ?x) (IsPlugged ?x) (IsOn ?x) (Done ?x) (Holding ?x)
               (place ?x) (has_plug ?x) (red ?x) (blue ?x) (heavy ?x) (link ?x ?y))
  (:functions (total-cost) - number (dist ?x) - number)
%s)
"""
OBJECTS = "b c"
FLUENTS = ["At", "Near", "IsPlugged", "IsOn", "Done", "Holding"]
FACTS = """(place a) (place b) (place c) (has_plug b) (red a) (red b) (blue b) (blue c) (heavy c)
           (link a b) (link b c) (= (dist a) 4) (= (dist b) 7) (= (dist c) 0) (At a)"""


def _static(actions: str) -> GroundTask:
    """Ground ``actions`` in a domain where a, b, c are places; every capitalised predicate is a fluent."""
    return _ground(STATIC % actions, _problem(OBJECTS, FACTS), keep_fluent=FLUENTS)


def test_equality_and_inequality() -> None:
    task = _static(
        "(:action Go :parameters (?x ?y) :precondition (and (place ?x) (place ?y) (not (= ?x ?y)) (At ?x))"
        " :effect (and (At ?y) (not (At ?x))))"
        "(:action Stay :parameters (?x ?y) :precondition (and (place ?x) (= ?x ?y)) :effect (At ?y))"
    )
    assert _names(task, "Go") == ["Go(a,b)", "Go(a,c)", "Go(b,a)", "Go(b,c)", "Go(c,a)", "Go(c,b)"]
    assert _names(task, "Stay") == ["Stay(a,a)", "Stay(b,b)", "Stay(c,c)"]
    assert _action(task, "Go(a,b)") == (["At(a)"], ["At(b)"], ["At(a)"], 0)


def test_imply_over_statics_becomes_a_plain_precondition() -> None:
    task = _static(
        "(:action SwitchOn :parameters (?x) :precondition (and (place ?x) (imply (has_plug ?x) (IsPlugged ?x)))"
        " :effect (and (IsOn ?x) (increase (total-cost) 8)))"
    )
    assert _names(task) == ["SwitchOn(a)", "SwitchOn(b)", "SwitchOn(c)"]
    assert _action(task, "SwitchOn(b)") == (["IsPlugged(b)"], ["IsOn(b)"], [], 8)
    assert _action(task, "SwitchOn(a)") == ([], ["IsOn(a)"], [], 8)


def test_or_over_statics_at_top_level_unions_bindings_without_duplicates() -> None:
    # b is both red and blue: it must be grounded once.
    task = _static("(:action Paint :parameters (?x) :precondition (or (red ?x) (blue ?x)) :effect (Done ?x))")
    assert _names(task) == ["Paint(a)", "Paint(b)", "Paint(c)"]
    assert [a.index for a in task.actions] == [0, 1, 2]


def test_or_with_one_fluent_branch_left_after_static_evaluation() -> None:
    task = _static(
        "(:action Lift :parameters (?x) :precondition (and (place ?x)"
        " (or (and (heavy ?x) (Holding self)) (and (not (heavy ?x)) (Near ?x)))) :effect (Done ?x))"
    )
    assert _action(task, "Lift(c)")[0] == ["Holding(self)"]
    assert _action(task, "Lift(a)")[0] == ["Near(a)"]


def test_static_join_over_a_binary_relation() -> None:
    task = _static("(:action Cross :parameters (?x ?y) :precondition (and (link ?x ?y) (At ?x)) :effect (At ?y))")
    assert _names(task) == ["Cross(a,b)", "Cross(b,c)"]


def test_action_never_applicable_after_static_evaluation_is_dropped() -> None:
    task = _static(
        "(:action Carry :parameters (?x) :precondition (and (place ?x) (imply (heavy ?x) (red ?x)) (Near ?x))"
        " :effect (Done ?x))"
        "(:action Never :parameters (?x) :precondition (and (red ?x) (not (red ?x))) :effect (Done ?x))"
        "(:action Nowhere :parameters (?x) :precondition (and (place ?x) (or (= ?x d) (heavy d))) :effect (Done ?x))"
    )
    # c is heavy and not red: Carry(c) can never run.
    assert _names(task) == ["Carry(a)", "Carry(b)"]


def test_forall_when_effects_over_statics() -> None:
    task = _static(
        "(:action Walk :parameters (?x) :precondition (place ?x)"
        " :effect (and (Near ?x) (forall (?y) (when (and (place ?y) (not (= ?y ?x))) (not (Near ?y))))))"
        "(:action Clear :parameters () :effect (forall (?y) (when (red ?y) (not (Done ?y)))))"
    )
    assert _action(task, "Walk(b)") == ([], ["Near(b)"], ["Near(a)", "Near(c)"], 0)
    assert _action(task, "Clear()") == ([], [], ["Done(a)", "Done(b)"], 0)


def test_conditional_cost_is_added_to_the_base_cost() -> None:
    task = _static(
        "(:action Fetch :parameters (?x) :precondition (place ?x)"
        " :effect (and (Holding ?x) (increase (total-cost) 2) (when (= ?x a) (increase (total-cost) 8))))"
    )
    assert {a.name: a.cost for a in task.actions} == {"Fetch(a)": 10, "Fetch(b)": 2, "Fetch(c)": 2}


def test_only_conditional_cost() -> None:
    task = _static(
        "(:action Fetch :parameters (?x) :precondition (place ?x)"
        " :effect (and (Holding ?x) (when (= ?x a) (increase (total-cost) 8))))"
    )
    assert {a.name: a.cost for a in task.actions} == {"Fetch(a)": 8, "Fetch(b)": 0, "Fetch(c)": 0}


def test_cost_from_a_static_function() -> None:
    task = _static(
        "(:action Drive :parameters (?x) :precondition (place ?x)"
        " :effect (and (At ?x) (increase (total-cost) (dist ?x))))"
    )
    assert {a.name: a.cost for a in task.actions} == {"Drive(a)": 4, "Drive(b)": 7, "Drive(c)": 0}


def test_action_whose_cost_is_undefined_is_dropped_with_a_warning(caplog: pytest.LogCaptureFixture) -> None:
    # Fast Downward never instantiates such an action unless it is reachable (elevators' slow lifts).
    domain = STATIC % (
        "(:action Drive :parameters (?x) :precondition (red ?x)"
        " :effect (and (At ?x) (increase (total-cost) (dist ?x))))"
    )
    full = _ground(domain, _problem(OBJECTS, FACTS), keep_fluent=FLUENTS)
    task = _ground(domain, _problem(OBJECTS, FACTS.replace("(= (dist b) 7)", "")), keep_fluent=FLUENTS)
    assert "Drive(b)" in _names_of_actions(full)
    assert "Drive(b)" not in _names_of_actions(task)
    assert len(task.actions) == len(full.actions) - 1
    assert re.search(r"'Drive' \(line \d+\): 1 ground action\(s\) dropped.*\(dist b\)", caplog.text)


def _names_of_actions(task: GroundTask) -> list[str]:
    return [a.name for a in task.actions]


# ======================================================= not STRIPS: an error
def test_a_conditional_effect_on_fluents_becomes_a_variant_whose_condition_holds() -> None:
    # One variant where (Near a) fails, one where it holds and (Done a) is added too.
    task = _static("(:action Peek :parameters (?x) :effect (and (Holding ?x) (when (Near ?x) (Done ?x))))")
    assert _action(task, "Peek(a)")[0] == ["~Near(a)"]
    assert _action(task, "Peek-alt2(a)")[0] == ["Near(a)"]
    assert sorted(task.names(task.action("Peek-alt2(a)").add)) == ["Done(a)", "Holding(a)"]


def test_fluent_disjunction_is_fine_when_statics_decide_it() -> None:
    # For a (red), the static branch is true, so the disjunction vanishes; for b (red, blue) too.
    task = _static(
        "(:action Peek :parameters (?x) :precondition (and (red ?x) (or (red ?x) (Near ?x))) :effect (Done ?x))"
    )
    assert _action(task, "Peek(a)")[0] == []


# ============================================================ keep_fluent etc.
STANDING = """\
(define (domain d)
  (:constants self)
  (:predicates (IsStanding ?a) (IsNear ?a ?x) (spot ?x))
  (:action Walk :parameters (?x) :precondition (and (spot ?x) (IsStanding self)) :effect (IsNear self ?x)))
"""


def test_predicate_no_action_changes_is_static_by_default() -> None:
    task = _ground(STANDING, _problem("a b", "(spot a) (spot b) (IsStanding self)"))
    assert _action(task, "Walk(a)")[0] == []
    assert "IsStanding" not in task.predicates
    assert task.names(task.initial_state) == []


def test_keep_fluent_keeps_a_predicate_no_action_changes() -> None:
    task = _ground(STANDING, _problem("a b", "(spot a) (spot b) (IsStanding self)"), keep_fluent=["IsStanding"])
    assert _action(task, "Walk(a)")[0] == ["IsStanding(self)"]
    assert task.predicates == {"IsStanding": 1, "IsNear": 2}
    assert task.names(task.initial_state) == ["IsStanding(self)"]
    # Without the fact in s0 the actions still exist: their precondition is just false.
    task = _ground(STANDING, _problem("a b", "(spot a) (spot b)"), keep_fluent=["IsStanding"])
    assert _names(task) == ["Walk(a)", "Walk(b)"]


def test_keep_fluent_must_name_a_predicate() -> None:
    with pytest.raises(InputError, match="keep_fluent names unknown predicate"):
        _ground(STANDING, _problem("a", "(spot a)"), keep_fluent=["IsSitting"])


def test_object_categories_define_the_objects() -> None:
    problem = _problem("a b table lamp", "(spot a) (spot b) (spot table) (big table) (big lamp) (IsStanding self)")
    domain = STANDING.replace("(spot ?x))", "(spot ?x) (big ?x))")
    default = _ground(domain, problem)
    assert default.objects == ("a", "b", "table", "lamp")
    assert default.constants == ("self",)
    task = _ground(domain, problem, object_categories=["big"])
    assert task.objects == ("lamp", "table")
    assert task.constants == ("a", "b", "self")
    assert task.symbols == {"a", "b", "table", "lamp", "self"}
    union = _ground(domain, problem, object_categories=["big", "spot"])
    assert union.objects == ("a", "b", "lamp", "table")
    with pytest.raises(InputError, match="object category 'small'"):
        _ground(domain, problem, object_categories=["small"])


def test_task_records_static_facts_initial_state_and_names() -> None:
    task = _static("(:action Go :parameters (?x) :precondition (place ?x) :effect (and (At ?x) (not (Near ?x))))")
    assert task.name == "p"
    assert _ground(STATIC % "", _problem(OBJECTS, FACTS), name="custom").name == "custom"
    assert task.names(task.initial_state) == ["At(a)"]
    assert task.predicates == dict.fromkeys(FLUENTS, 1)
    assert "place" not in task.predicates
    assert {str(f) for f in task.static_facts} >= {"place(a)", "link(a,b)", "heavy(c)"}
    assert task.categories["place"] == ("a", "b", "c")
    assert list(task.atoms) == sorted(task.atoms)
    assert [a.name for a in task.actions] == sorted(a.name for a in task.actions)


# ============================================================== not blind
def test_bindings_are_joined_from_static_facts_not_enumerated() -> None:
    objects = [f"o{i}" for i in range(200)]
    ports = ["o7", "o42", "o199"]
    domain = """\
(define (domain wires)
  (:requirements :strips :equality)
  (:predicates (port ?x) (Free ?x) (Wired ?x ?y ?z))
  (:action Connect :parameters (?x ?y ?z)
    :precondition (and (port ?x) (port ?y) (port ?z) (not (= ?x ?y)) (Free ?z))
    :effect (and (Wired ?x ?y ?z) (not (Free ?z)))))
"""
    init = " ".join(f"(port {p})" for p in ports) + " " + " ".join(f"(Free {o})" for o in objects)
    started = time.perf_counter()
    task = _ground(domain, _problem(" ".join(objects), init, "wires"))
    elapsed = time.perf_counter() - started
    # A blind product would try 200**3 = 8 million bindings.
    assert elapsed < 0.5
    assert len(task.actions) == 3 * 2 * 3
    assert {a.objects for a in task.actions} == {(x, y, z) for x in ports for y in ports for z in ports if x != y}
    assert _action(task, "Connect(o7,o42,o199)") == (["Free(o199)"], ["Wired(o7,o42,o199)"], ["Free(o199)"], 1)


# ============================================================ bounded grounding
CUBE = """\
(define (domain cube)
  (:requirements :strips)
  (:predicates (p ?x ?y ?z) (q))
  (:action a :parameters (?x ?y ?z) :precondition (q) :effect (p ?x ?y ?z)))
"""


def _objects(count: int) -> str:
    return " ".join(f"o{i}" for i in range(count))


def test_grounding_beyond_the_limit_grounds_what_is_reachable_then_refuses(caplog: pytest.LogCaptureFixture) -> None:
    # The static bound (8,000) is over the limit, so only the actions reachable from s0 are
    # grounded; all of them are, and the 1,001st is refused.
    caplog.set_level(logging.INFO, logger="hbtp.domains.grounding")
    with pytest.raises(GroundingError) as info:
        _ground(CUBE, _problem(_objects(20), "(q)", "cube"), max_ground_actions=1000)
    message = str(info.value)
    assert message.startswith("grounding the actions reachable from s0 would create more than the limit of 1,000 ")
    assert "max_ground_actions" in message
    assert "HBTP_MAX_GROUND_ACTIONS" in message
    assert "is action 1,001" in message
    assert "\n" not in message
    assert "a(?x ?y ?z) alone may have 8,000 (20 x 20 x 20 candidate objects)" in caplog.text


def test_the_limit_is_an_option_and_an_environment_variable(monkeypatch: pytest.MonkeyPatch) -> None:
    problem = _problem(_objects(10), "(q)", "cube")
    assert len(_ground(CUBE, problem, max_ground_actions=1000).actions) == 1000
    with pytest.raises(GroundingError, match="limit of 999 "):
        _ground(CUBE, problem, max_ground_actions=999)
    monkeypatch.setenv("HBTP_MAX_GROUND_ACTIONS", "999")
    with pytest.raises(GroundingError, match="limit of 999 "):
        _ground(CUBE, problem)
    monkeypatch.setenv("HBTP_MAX_GROUND_ACTIONS", "1e6")
    with pytest.raises(InputError, match="HBTP_MAX_GROUND_ACTIONS must be a whole number"):
        _ground(CUBE, problem)
    with pytest.raises(InputError, match="at least 1"):
        _ground(CUBE, problem, max_ground_actions=0)


def test_the_estimate_follows_static_joins_not_the_blind_product() -> None:
    # 200**3 blind, but the static join allows at most 3 * 3 * 200 bindings (18 actions in fact).
    objects = [f"o{i}" for i in range(200)]
    domain = """\
(define (domain wires)
  (:requirements :strips :equality)
  (:predicates (port ?x) (Free ?x) (Wired ?x ?y ?z))
  (:action Connect :parameters (?x ?y ?z)
    :precondition (and (port ?x) (port ?y) (not (= ?x ?y)) (Free ?z))
    :effect (and (Wired ?x ?y ?z) (not (Free ?z)))))
"""
    init = "(port o7) (port o42) (port o199) " + " ".join(f"(Free {o})" for o in objects)
    task = _ground(domain, _problem(" ".join(objects), init, "wires"), max_ground_actions=1800)
    assert len(task.actions) == 3 * 2 * 200
    # Beyond the bound, only what is reachable from s0 is grounded: the same 1,200 actions.
    assert _ground(domain, _problem(" ".join(objects), init, "wires"), max_ground_actions=1799).actions == task.actions
    with pytest.raises(GroundingError, match="reachable from s0 would create more than the limit of 1,199 "):
        _ground(domain, _problem(" ".join(objects), init, "wires"), max_ground_actions=1199)


def test_a_deadline_stops_grounding() -> None:
    deadline = Deadline(0.2)
    started = time.perf_counter()
    with pytest.raises(TimeLimitReached) as info:
        _ground(CUBE, _problem(_objects(100), "(q)", "cube"), deadline=deadline)
    assert time.perf_counter() - started < 1.5  # a million actions take about 20 s
    assert str(info.value) == "time limit of 0.2 s reached while grounding"
    assert isinstance(info.value, PlanningError)  # the command line's exit code 1: not solved


def test_a_static_condition_with_too_many_disjunctive_cases_is_refused() -> None:
    ors = " ".join(f"(or (s{i} ?x) (t{i} ?x))" for i in range(14))  # 2**14 cases
    predicates = " ".join(f"(s{i} ?x) (t{i} ?x)" for i in range(14))
    domain = f"""\
(define (domain many)
  (:requirements :strips :disjunctive-preconditions)
  (:predicates (Done ?x) {predicates})
  (:action a :parameters (?x) :precondition (and {ors}) :effect (Done ?x)))
"""
    with pytest.raises(GroundingError, match="16,384 cases in disjunctive normal form"):
        _ground(domain, _problem("o1", "(s0 o1)", "many"))


def test_costs_beyond_the_maximum_or_negative_costs_from_functions_are_refused() -> None:
    domain = """\
(define (domain costly)
  (:requirements :strips :action-costs)
  (:predicates (Done ?x))
  (:functions (total-cost) - number (price ?x) - number)
  (:action buy :parameters (?x)
    :effect (and (Done ?x) (increase (total-cost) 600000) (increase (total-cost) (price ?x)))))
"""
    cheap = _ground(domain, _problem("a", "(= (price a) 400000)", "costly"))
    assert cheap.actions[0].cost == MAX_ACTION_COST
    with pytest.raises(GroundingError, match=r"buy\(a\) costs 1000001, more than the maximum 1000000"):
        _ground(domain, _problem("a", "(= (price a) 400001)", "costly"))
    with pytest.raises(GroundingError, match=r"cost \(price a\) is -600001, and action costs must not be negative"):
        _ground(domain, _problem("a", "(= (price a) -600001)", "costly"))


def test_an_add_effect_the_precondition_requires_is_dropped_and_an_action_that_changes_nothing_too() -> None:
    domain = (
        "(define (domain d) (:predicates (free ?r) (sent ?x) (seen ?x))"
        " (:action send :parameters (?r ?x) :precondition (and (free ?r) (seen ?x))"
        "  :effect (and (not (free ?r)) (free ?r) (sent ?x)))"
        " (:action look :parameters (?x) :precondition (seen ?x) :effect (seen ?x)))"
    )
    task = _ground(domain, _problem("r a", "(free r) (seen a)"))
    assert _names(task, "look") == []  # look only re-adds what it needs: it changes nothing
    assert "send(r,a)" in _names(task, "send")
    pre, add, delete, _cost = _action(task, "send(r,a)")
    assert (pre, add, delete) == (["free(r)", "seen(a)"], ["sent(a)"], [])
    assert task.action("send(r,a)").progress(task.initial_state) == task.initial_state | task.action("send(r,a)").add
