"""Grounding only some actions (``ground(..., only=...)``) and listing the ground actions without their
effects (``action_bindings``): both agree exactly with the full grounding."""

from __future__ import annotations

import dataclasses
import time
from collections.abc import Callable
from pathlib import Path

import pytest

from hbtp.deadline import Deadline, TimeLimitReached
from hbtp.domains import load_scenario, read_domain, read_problem
from hbtp.domains.grounding import action_bindings, ground
from hbtp.domains.lifted import Domain, Problem
from hbtp.domains.pddl_reader import read_domain_file, read_problem_file
from hbtp.domains.scale import clone_objects
from hbtp.domains.scenarios import ScenarioOptions
from hbtp.errors import GroundingError
from hbtp.logic import GroundTask
from hbtp.logic.atoms import Atom

Only = Callable[[str, tuple[str, ...]], bool]
Facts = dict[Atom, tuple[frozenset[Atom], frozenset[Atom], frozenset[Atom], int]]

BENCHMARKS = Path(__file__).resolve().parents[2] / ".." / "shared" / "benchmarks" / "ipc"
ELEVATORS = BENCHMARKS / "elevators-opt08-strips"


def _facts(task: GroundTask) -> Facts:
    """Each action's precondition, add and delete atoms (by name) and cost."""
    atoms = task.atoms
    return {
        a.signature: (
            frozenset(atoms[i] for i in a.pre),
            frozenset(atoms[i] for i in a.add),
            frozenset(atoms[i] for i in a.delete),
            a.cost,
        )
        for a in task.actions
    }


def _assert_restriction(part: GroundTask, full: GroundTask, only: Only, reachable_only: bool = False) -> None:
    """``part`` holds exactly the actions of ``full`` that ``only`` accepts (some of them, when reachable
    ones only), unchanged, and the atoms s0 or they mention; the rest of the task is the full one's."""
    mine, theirs = _facts(part), _facts(full)
    selected = {name for name in theirs if only(name.predicate, name.args)}
    if reachable_only:
        assert set(mine) <= selected
    else:
        assert set(mine) == selected
    assert all(mine[name] == theirs[name] for name in mine)
    assert [a.index for a in part.actions] == list(range(len(part.actions)))
    assert [a.name for a in part.actions] == sorted(a.name for a in part.actions)
    mentioned = set(part.initial_state)
    for action in part.actions:
        mentioned |= action.pre | action.add | action.delete
    assert mentioned == set(range(len(part.atoms)))
    assert list(part.atoms) == sorted(part.atoms)
    assert {part.atoms[i] for i in part.initial_state} == {full.atoms[i] for i in full.initial_state}
    assert (part.objects, part.constants, part.static_facts) == (full.objects, full.constants, full.static_facts)
    assert dict(part.predicates) == dict(full.predicates)


def _ground_shipped(name: str, only: Only | None = None) -> tuple[GroundTask, GroundTask]:
    """The shipped scenario's task (the paper's action space, as ``ground`` gives it), and ``name``
    grounded again with ``only``, with its options."""
    scenario = load_scenario(name, keep_self_placements=True)
    options = ScenarioOptions.shipped(name)
    part = ground(
        scenario.pddl.domain,
        scenario.pddl.problem,
        keep_fluent=options.keep_fluent,
        object_categories=options.objects,
        name=name,
        only=only,
    )
    return scenario.task, part


def _every_other_schema(domain: Domain) -> Only:
    chosen = {schema.name for schema in domain.actions[::2]}
    return lambda schema, args: schema in chosen


def _first_objects(problem: Problem) -> Only:
    chosen = {o.name for o in problem.objects[: len(problem.objects) // 2]}
    return lambda schema, args: all(a in chosen for a in args)


# ======================================================================== only
@pytest.mark.parametrize("name", ["robowaiter", "robothow-small"])
@pytest.mark.parametrize("kind", ["schemas", "objects", "both", "nothing"])
def test_only_builds_exactly_the_selected_actions_of_the_full_task(name: str, kind: str) -> None:
    pddl = load_scenario(name).pddl
    by_schema, by_object = _every_other_schema(pddl.domain), _first_objects(pddl.problem)
    only: Only = {
        "schemas": by_schema,
        "objects": by_object,
        "both": lambda schema, args: by_schema(schema, args) and by_object(schema, args),
        "nothing": lambda schema, args: False,
    }[kind]
    full, part = _ground_shipped(name, only)
    _assert_restriction(part, full, only)
    assert (len(part.actions) == 0) == (kind == "nothing")
    assert len(part.actions) < len(full.actions)


def test_only_accepting_everything_grounds_the_full_task() -> None:
    full, part = _ground_shipped("robowaiter", lambda schema, args: True)
    assert part.atoms == full.atoms
    assert part.actions == full.actions
    assert part.initial_state == full.initial_state


@pytest.mark.skipif(not ELEVATORS.is_dir(), reason="the IPC benchmark files (../shared/benchmarks/ipc) are absent")
@pytest.mark.parametrize("reachable_only", [False, True])
def test_only_on_an_ipc_domain_with_costs_and_reachability(reachable_only: bool) -> None:
    domain = read_domain_file(ELEVATORS / "domain.pddl")
    problem = read_problem_file(ELEVATORS / "p01.pddl", domain)
    full = ground(domain, problem, reachable_only=reachable_only)
    lifts = {o.name for o in problem.objects if o.name.startswith(("fast0", "slow0"))}

    def only(schema: str, args: tuple[str, ...]) -> bool:
        return "up" in schema or any(a in lifts for a in args)

    part = ground(domain, problem, reachable_only=reachable_only, only=only)
    _assert_restriction(part, full, only, reachable_only)
    assert 0 < len(part.actions) < len(full.actions)
    if not reachable_only:
        assert len({a.cost for a in part.actions}) > 1  # the costs come from the problem's functions


NEGATIVE_COST = """\
(define (domain d)
  (:requirements :strips :action-costs)
  (:predicates (Done ?x) (Seen ?x) (item ?x))
  (:functions (total-cost) - number (price ?x) - number (penalty ?x) - number)
  (:action Do :parameters (?x) :precondition (item ?x) :effect (and (Seen ?x) (increase (total-cost) (price ?x))))
  (:action Peek :parameters (?x) :precondition (item ?x) :effect (and (Done ?x) (increase (total-cost) (penalty ?x)))))
"""


def _negative_cost() -> tuple[Domain, Problem]:
    domain = read_domain(NEGATIVE_COST)
    init = "(item a) (item b) (item c) (= (price a) 3) (= (price b) 4) (= (penalty a) -1)"
    problem = read_problem(f"(define (problem p) (:domain d) (:objects a b c) (:init {init}) (:goal (and)))", domain)
    return domain, problem


def test_the_effects_of_actions_left_out_are_never_computed() -> None:
    domain, problem = _negative_cost()
    with pytest.raises(GroundingError, match="must not be negative"):
        ground(domain, problem)
    task = ground(domain, problem, only=lambda schema, args: schema == "Do")
    assert [(a.name, a.cost) for a in task.actions] == [("Do(a)", 3), ("Do(b)", 4)]  # Do(c)'s cost is undefined


# ============================================================== only: the limit
CUBE = """\
(define (domain cube)
  (:requirements :strips)
  (:predicates (p ?x ?y ?z) (q))
  (:action a :parameters (?x ?y ?z) :precondition (q) :effect (p ?x ?y ?z)))
"""


def _cube(count: int) -> tuple[Domain, Problem]:
    domain = read_domain(CUBE)
    objects = " ".join(f"o{i}" for i in range(count))
    problem = read_problem(f"(define (problem p) (:domain cube) (:objects {objects}) (:init (q)) (:goal (q)))", domain)
    return domain, problem


def test_with_only_the_limit_applies_to_the_actions_kept() -> None:
    domain, problem = _cube(10)  # 1,000 actions
    with pytest.raises(GroundingError, match="reachable from s0 would create more than the limit of 50 "):
        ground(domain, problem, max_ground_actions=50)
    task = ground(domain, problem, max_ground_actions=50, only=lambda schema, args: args[:2] == ("o1", "o2"))
    assert [a.name for a in task.actions] == [f"a(o1,o2,o{i})" for i in range(10)]
    with pytest.raises(GroundingError, match="limit of 50 ") as info:
        ground(domain, problem, max_ground_actions=50, only=lambda schema, args: args[0] == "o1")  # 100 kept
    assert "max_ground_actions" in str(info.value)
    assert "\n" not in str(info.value)


# ================================================================ action_bindings
@pytest.mark.parametrize("name", ["robowaiter", "virtualhome", "robothow-small", "robothow"])
def test_action_bindings_name_exactly_the_ground_actions(name: str) -> None:
    scenario = load_scenario(name, keep_self_placements=True)  # the paper's action space, as ground() gives it
    options = ScenarioOptions.shipped(name)
    found = action_bindings(scenario.pddl.domain, scenario.pddl.problem, keep_fluent=options.keep_fluent)
    assert list(found) == [schema.name for schema in scenario.pddl.domain.actions]
    for bindings in found.values():
        assert list(bindings) == sorted(bindings)
    listed = sorted((Atom(schema, args), cost) for schema, bindings in found.items() for args, cost in bindings)
    assert listed == sorted((a.signature, a.cost) for a in scenario.task.actions)


def test_action_bindings_of_robothow_scaled_twice() -> None:
    pddl = load_scenario("robothow").pddl
    problem = clone_objects(pddl.problem, 2.0)
    options = ScenarioOptions.shipped("robothow")
    started = time.perf_counter()
    found = action_bindings(pddl.domain, problem, keep_fluent=options.keep_fluent)
    listing = time.perf_counter() - started
    task = ground(pddl.domain, problem, keep_fluent=options.keep_fluent, object_categories=options.objects)
    listed = sorted((Atom(schema, args), cost) for schema, bindings in found.items() for args, cost in bindings)
    assert listed == sorted((a.signature, a.cost) for a in task.actions)
    assert len(listed) == 28_202
    assert listing < 5.0  # about 0.1 s: effects are not computed


def test_action_bindings_list_each_binding_once_and_drop_undefined_costs(caplog: pytest.LogCaptureFixture) -> None:
    """Peek has two variants per binding (Seen holds or not): listed once, at the cost when no
    conditional effect fires."""
    text = NEGATIVE_COST.replace(":action-costs)", ":action-costs :conditional-effects)")
    domain = read_domain(
        text.replace("(penalty ?x)))))", "(penalty ?x)) (when (Seen ?x) (increase (total-cost) 5)))))")
    )
    costs = "(= (price a) 3) (= (price b) 4) (= (penalty a) 0) (= (penalty b) 1) (= (penalty c) 2)"
    init = f"(item a) (item b) (item c) {costs}"
    problem = read_problem(f"(define (problem p) (:domain d) (:objects a b c) (:init {init}) (:goal (and)))", domain)
    found = action_bindings(domain, problem)
    assert found == {"Do": ((("a",), 3), (("b",), 4)), "Peek": ((("a",), 0), (("b",), 1), (("c",), 2))}
    peeks = [(a.name, a.cost) for a in ground(domain, problem).actions if a.predicate.startswith("Peek")]
    assert peeks[:3] == [("Peek(a)", 0), ("Peek(b)", 1), ("Peek(c)", 2)]  # Seen fails
    assert peeks[3:] == [("Peek-alt2(a)", 5), ("Peek-alt2(b)", 6), ("Peek-alt2(c)", 7)]  # Seen holds
    assert "'Do' (line 5): 1 ground action(s) dropped, their cost is not defined in :init ((price c))" in caplog.text


def test_action_bindings_with_fluent_preconditions_false_once_statics_are_known() -> None:
    domain = read_domain("""\
(define (domain d)
  (:requirements :strips :disjunctive-preconditions)
  (:predicates (Done ?x) (Near ?x) (red ?x) (item ?x))
  (:action Paint :parameters (?x) :precondition (and (item ?x) (or (red ?x) (Near ?x)) (imply (red ?x) (Near ?x)))
    :effect (Done ?x))
  (:action Never :parameters (?x) :precondition (and (item ?x) (or (red ?x) (and (red ?x) (Near ?x))))
    :effect (Done ?x)))
""")
    problem = read_problem("(define (problem p) (:domain d) (:objects a b) (:init (item a) (item b) (red a)))", domain)
    found = action_bindings(domain, problem, keep_fluent=["Near"])
    task = ground(domain, problem, keep_fluent=["Near"])
    assert found == {"Paint": ((("a",), 1), (("b",), 1)), "Never": ((("a",), 1),)}
    assert sorted(a.name for a in task.actions) == ["Never(a)", "Paint(a)", "Paint(b)"]


# ====================================================================== deadlines
@pytest.mark.parametrize("how", ["ground", "only", "action_bindings"])
def test_a_deadline_still_stops_grounding(how: str) -> None:
    domain, problem = _cube(100)  # a million actions: about 10 s to ground, 2 s to list
    deadline = Deadline(0.1)

    def run() -> object:
        if how == "action_bindings":
            return action_bindings(domain, problem, deadline=deadline)
        only = (lambda schema, args: args[0] != "o1") if how == "only" else None
        return ground(domain, problem, deadline=deadline, only=only)

    started = time.process_time()  # the CPU spent, which other jobs on the machine do not stretch
    with pytest.raises(TimeLimitReached, match=r"^time limit of 0\.1 s reached while grounding$"):
        run()
    assert time.process_time() - started < 1.0


def test_a_deadline_stops_a_large_forall() -> None:
    # One action whose forall effect alone spans 300 x 300 objects.
    domain = read_domain("""\
(define (domain d)
  (:requirements :strips :conditional-effects)
  (:predicates (Link ?x ?y) (go))
  (:action Reset :parameters () :precondition (go) :effect (forall (?x ?y) (not (Link ?x ?y)))))
""")
    objects = " ".join(f"o{i}" for i in range(300))
    problem = read_problem(f"(define (problem p) (:domain d) (:objects {objects}) (:init (go)))", domain)
    assert len(ground(domain, dataclasses.replace(problem, objects=problem.objects[:3])).atoms) == 9
    started = time.process_time()
    with pytest.raises(TimeLimitReached):
        ground(domain, problem, deadline=Deadline(0.02))
    assert time.process_time() - started < 1.0
