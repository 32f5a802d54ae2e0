"""Shared test helpers: seeded random STRIPS tasks, an independent brute-force optimum, and tree runners.

Nothing here uses the planner: the brute force is a forward uniform-cost search over states
(frozensets of atom ids) with the textbook progression ``(s - del) | add``, so it is an oracle that
shares no code with the backward search under test.
"""

from __future__ import annotations

import heapq
import itertools
import random
import re
import threading
import xml.etree.ElementTree as ET
from collections.abc import Callable, Hashable, Iterable, Sequence
from dataclasses import dataclass
from http.server import BaseHTTPRequestHandler, ThreadingHTTPServer
from typing import Any

from hbtp.bt import Action, Condition, Fallback, Node, NodeStatus, full_tree, tick
from hbtp.bt import Sequence as SequenceNode
from hbtp.bt.simulate import simulate
from hbtp.bt.verify import verify
from hbtp.domains import DomainBuilder, load_scenario
from hbtp.logic.execution import Run
from hbtp.logic.relevance import relevant_to
from hbtp.logic.task import Goal, GroundTask
from hbtp.planning import Status, plan
from hbtp.planning.result import PlanResult

#: The four shipped scenarios (the ``scenario`` fixture runs a test on each).
SCENARIOS = ("robowaiter", "virtualhome", "robothow-small", "robothow")
LOCATIONS = ("l0", "l1", "l2")


@dataclass(frozen=True)
class RandomCase:
    """A generated task with its goal and the brute-force answer (``optimum`` is None: unsolvable)."""

    seed: int
    task: GroundTask
    goal: Goal
    optimum: int | None
    plan: tuple[int, ...]  # one optimal plan (action indices), empty when unsolvable or goal in s0


def random_task(seed: int) -> tuple[GroundTask, Goal]:
    """A small random STRIPS task: 6-10 atoms, 5-12 actions, costs 1-9, a goal of 1-3 atoms.

    Half of the tasks also get a robot location (``At(l0..l2)``, at most one true in s0, every action
    that adds one location deletes the location it requires), so that ``infer_mutexes`` has a real
    invariant to prove and the mutex pruning is exercised.
    """
    rng = random.Random(seed)
    located = rng.random() < 0.5
    n_facts = rng.randint(6, 10) - (len(LOCATIONS) if located else 0)
    facts = [f"F(x{i})" for i in range(n_facts)]
    builder = DomainBuilder(f"random-{seed}")
    for j in range(rng.randint(5, 12)):
        pre = rng.sample(facts, min(len(facts), rng.randint(0, 3)))
        add = rng.sample(facts, rng.randint(1, 3))
        others = [f for f in facts if f not in add]
        delete = rng.sample(others, min(len(others), rng.randint(0, 3)))
        if located and rng.random() < 0.7:
            here, there = rng.sample(LOCATIONS, 2)
            pre.append(f"At({here})")
            if rng.random() < 0.6:
                add.append(f"At({there})")
                delete.append(f"At({here})")
        builder.action(f"Op{j}(x0)", pre=pre, add=add, delete=delete, cost=rng.randint(1, 9))
    initial = rng.sample(facts, min(len(facts), rng.randint(0, 4)))
    if located:
        initial.append(f"At({rng.choice(LOCATIONS)})")
    builder.initial(initial)
    task = builder.build()
    # The first goal atom is false in s0 whenever possible, so that few goals hold from the start.
    atoms = range(len(task.atoms))
    missing = [i for i in atoms if i not in task.initial_state] or list(atoms)
    first = rng.choice(missing)
    goal_ids = {first, *rng.sample([i for i in atoms if i != first], min(rng.randint(0, 2), len(atoms) - 1))}
    goal = task.resolve_goal([task.atoms[i] for i in sorted(goal_ids)])
    return task, goal


def brute_force(
    task: GroundTask, goal: frozenset[int] | Callable[[frozenset[int]], bool]
) -> tuple[int | None, tuple[int, ...]]:
    """Forward Dijkstra from s0: the optimal cost and one optimal plan, or (None, ()) when unsolvable."""
    start = task.initial_state
    best: dict[frozenset[int], int] = {start: 0}
    previous: dict[frozenset[int], tuple[frozenset[int], int] | None] = {start: None}
    heap: list[tuple[int, int, frozenset[int]]] = [(0, 0, start)]
    counter = 0
    while heap:
        cost, _, state = heapq.heappop(heap)
        if cost > best[state]:
            continue
        if goal(state) if callable(goal) else goal <= state:
            plan: list[int] = []
            step = previous[state]
            while step is not None:
                state, action = step
                plan.append(action)
                step = previous[state]
            return cost, tuple(reversed(plan))
        for action in task.actions:
            if action.pre <= state:
                successor = (state - action.delete) | action.add
                value = cost + action.cost
                if value < best.get(successor, value + 1):
                    best[successor] = value
                    previous[successor] = (state, action.index)
                    counter += 1
                    heapq.heappush(heap, (value, counter, successor))
    return None, ()


#: A PDDL domain whose ``go`` needs a road or a rail (a disjunctive precondition over fluents: ``pave``
#: turns a rail into a road), so it grounds to ``go`` and ``go-alt2`` per pair of places.
ROAD_OR_RAIL_DOMAIN = (
    "(define (domain d) (:requirements :adl) (:predicates (road ?a ?b) (rail ?a ?b) (at ?a))"
    " (:action go :parameters (?a ?b) :precondition (and (at ?a) (or (road ?a ?b) (rail ?a ?b)))"
    " :effect (and (at ?b) (not (at ?a))))"
    " (:action pave :parameters (?a ?b) :precondition (rail ?a ?b) :effect (and (road ?a ?b) (not (rail ?a ?b)))))"
)


def cheapest(
    start: Hashable, holds: Callable[[Any], bool], successors: Callable[[Any], Iterable[tuple[int, Hashable]]]
) -> int | None:
    """Dijkstra over any states (an independent brute force for tests that build their own model):
    the cheapest cost from ``start`` to a state where ``holds``, or ``None`` when none is reachable."""
    best: dict[Hashable, int] = {start: 0}
    heap: list[tuple[int, int, Any]] = [(0, 0, start)]
    counter = itertools.count(1)
    while heap:
        cost, _, state = heapq.heappop(heap)
        if cost > best[state]:
            continue
        if holds(state):
            return cost
        for step, successor in successors(state):
            if cost + step < best.get(successor, cost + step + 1):
                best[successor] = cost + step
                heapq.heappush(heap, (cost + step, next(counter), successor))
    return None


def random_case(seed: int) -> RandomCase:
    task, goal = random_task(seed)
    optimum, plan = brute_force(task, goal.ids)
    return RandomCase(seed, task, goal, optimum, plan)


@dataclass(frozen=True)
class TickRun:
    reached: bool  # the tree returned SUCCESS
    actions: tuple[int, ...]
    cost: int
    state: frozenset[int]


_VERIFIED: dict[int, Node] = {}


def assert_verified(tree: Node, task: GroundTask) -> None:
    """The static verifier accepts a planned tree (Fallback(goal, ...)) and proves it reaches its goal."""
    if _VERIFIED.get(id(tree)) is tree or not (isinstance(tree, Fallback) and isinstance(tree.children[0], Condition)):
        return
    check = verify(tree, task, tree.children[0].literals)
    assert check.ok, check.summary()
    assert check.proved_goal_reaching, check.summary()
    _VERIFIED[id(tree)] = tree


def run_tree(tree: Node, task: GroundTask, state: frozenset[int], max_ticks: int, *, planned: bool = True) -> TickRun:
    """Tick ``tree`` from ``state``, applying the RUNNING action each time, until SUCCESS or FAILURE.

    A planned tree is first checked by the static verifier (every planned tree the suite runs is
    verified); ``planned=False`` for the random trees of the simulator tests, which prove nothing.
    """
    if planned:
        assert_verified(tree, task)
    actions: list[int] = []
    cost = 0
    for _ in range(max_ticks):
        status, running = tick(tree, state, task)
        if status is NodeStatus.SUCCESS:
            return TickRun(True, tuple(actions), cost, state)
        if status is NodeStatus.FAILURE:
            break
        assert running is not None, "a RUNNING tick must name its action"
        action = task.actions[running]
        assert action.pre <= state, f"the tree runs {action.name} whose precondition does not hold"
        state = action.progress(state)
        actions.append(running)
        cost += action.cost
    return TickRun(False, tuple(actions), cost, state)


def plan_cost(task: GroundTask, actions: Sequence[int]) -> int:
    return sum(task.actions[i].cost for i in actions)


def reaches(task: GroundTask, actions: Sequence[int], goal: frozenset[int]) -> bool:
    """Whether the action sequence is applicable from s0 and ends in a goal state."""
    state = task.initial_state
    for index in actions:
        action = task.actions[index]
        if not action.pre <= state:
            return False
        state = action.progress(state)
    return goal <= state


def is_subsequence(short: Sequence[int], long: Sequence[int]) -> bool:
    items = iter(long)
    return all(any(x == y for y in items) for x in short)


# --------------------------------------------------- BehaviorTree.CPP (behaviortreepy) driver
def without_ports(xml_text: str) -> str:
    """The document with every ``argN`` attribute and ``input_port`` element removed, re-serialized."""
    root = ET.fromstring(xml_text)
    for element in root.iter():
        for key in [k for k in element.attrib if re.fullmatch(r"arg[0-9]+", k)]:
            del element.attrib[key]
        for port in element.findall("input_port"):
            element.remove(port)
    for element in root.iter():
        element.text = element.tail = None
    ET.indent(root, space="  ")
    return ET.tostring(root, encoding="unicode")


# --------------------------------------------------------------- trees no planner writes (edge shapes)
def edge_shape_trees() -> tuple[GroundTask, list[Node]]:
    """A two-action task and trees of shapes no planner writes: an empty condition, a lone leaf or
    action at the root, a group at the root, sibling groups, a real Sequence of conditions, nesting;
    with a 0-ary predicate (``Rested()``)."""
    task = (
        DomainBuilder("t")
        .constants(["self"])
        .action("Go(a)", add=["At(a)"])
        .action("Rest()", pre=["At(a)"], add=["Rested()"])
        .initial([])
        .build()
    )
    at, rested = task.atom_id("At(a)"), task.atom_id("Rested()")
    both = Condition(frozenset({at, rested}))
    trees: list[Node] = [
        Condition(frozenset()),
        Condition(frozenset({rested})),
        Action(task.action("Rest()").index),
        both,
        SequenceNode((both, both)),
        SequenceNode((Condition(frozenset({at})), Condition(frozenset({rested})))),
        Fallback((SequenceNode((Fallback((both,)),)), Action(task.action("Go(a)").index))),
    ]
    return task, trees


# ------------------------------------------------------------------------------ a small shared task
def kitchen_builder(holding: bool = True) -> DomainBuilder:
    """Walk to the fridge, open it, put the milk in: a small task several tests extend (the milk in
    hand at the start unless ``holding`` is false)."""
    return (
        DomainBuilder("kitchen")
        .constants(["self"])
        .action("Walk(fridge)", pre=["IsStanding(self)"], add=["IsNear(self,fridge)"], cost=15)
        .action(
            "Open(fridge)",
            pre=["IsNear(self,fridge)", "IsClose(fridge)"],
            add=["IsOpen(fridge)"],
            delete=["IsClose(fridge)"],
            cost=3,
        )
        .action(
            "PutIn(milk,fridge)",
            pre=["IsHolding(self,milk)", "IsNear(self,fridge)", "IsOpen(fridge)"],
            add=["IsIn(milk,fridge)"],
            delete=["IsHolding(self,milk)"],
            cost=10,
        )
        .initial(["IsStanding(self)", "IsClose(fridge)", *(["IsHolding(self,milk)"] if holding else [])])
    )


def plan_goals(goals: dict[str, Sequence[str]]) -> dict[tuple[str, str], tuple[GroundTask, PlanResult]]:
    """OBTEA (landmark heuristic) for each scenario's goals: {(scenario, goal): (task, result)}."""
    results = {}
    for scenario, names in goals.items():
        loaded = load_scenario(scenario)
        for goal in names:
            result = plan(loaded.task, goal, "obtea", mutexes=loaded.mutexes, heuristic="lm")
            assert result.solved, (scenario, goal)
            results[scenario, goal] = (loaded.task, result)
    return results


# ---------------------------------------------------------------------------------- loopback servers
class LoopbackHTTP:
    """An HTTP server on 127.0.0.1 in a daemon thread, for tests of the LLM backends: ``base_url``
    is its OpenAI-style ``/v1`` address; :meth:`close` stops it."""

    def __init__(self, handler: type[BaseHTTPRequestHandler]) -> None:
        self.httpd = ThreadingHTTPServer(("127.0.0.1", 0), handler)
        self.httpd.daemon_threads = True
        self.base_url = f"http://127.0.0.1:{self.httpd.server_address[1]}/v1"
        self.thread = threading.Thread(target=self.httpd.serve_forever, kwargs={"poll_interval": 0.05}, daemon=True)
        self.thread.start()

    def close(self) -> None:
        self.httpd.shutdown()
        self.httpd.server_close()
        self.thread.join(5)


def send_json_bytes(handler: BaseHTTPRequestHandler, status: int, data: bytes) -> None:
    """Answer ``handler``'s request with ``data`` as an ``application/json`` body."""
    handler.send_response(status)
    handler.send_header("Content-Type", "application/json")
    handler.send_header("Content-Length", str(len(data)))
    handler.end_headers()
    handler.wfile.write(data)


def assert_obtea_optimal(task: GroundTask, goal: Goal, mutexes: Any, optimum: int | None, where: str) -> list[Run]:
    """OBTEA with every heuristic but hmax: UNSOLVABLE when ``optimum`` is ``None``, else a tree of cost
    ``optimum``, verified from s0, whose run from s0 reaches the goal at that cost; those runs."""
    runs: list[Run] = []
    for heuristic in ("none", "lm", "lmcut", "seq"):
        result = plan(task, goal, "obtea", mutexes=mutexes, heuristic=heuristic)
        if optimum is None:
            assert result.status is Status.UNSOLVABLE, where
            continue
        assert result.solved, where
        assert result.cost == optimum, where
        tree = full_tree(result.expansions)
        assert verify(tree, task, goal, from_initial_state=True).ok, where
        run = simulate(tree, task)
        assert run.reached(goal), where
        assert run.cost == optimum, where
        runs.append(run)
    return runs


def relevant_conditions(task: GroundTask, seed: int, count: int = 12) -> tuple[frozenset[int], list[frozenset[int]]]:
    """A random goal's relevant actions, and ``count`` random conditions made of the goal's atoms and
    the preconditions of those actions (what a search of that goal regresses)."""
    rng = random.Random(seed)
    goal = rng.sample(range(len(task.atoms)), min(3, len(task.atoms)))
    relevant = relevant_to(task, goal)
    atoms = sorted(set(goal).union(*(task.actions[i].pre for i in relevant)))
    return relevant, [frozenset(rng.sample(atoms, rng.randint(1, min(5, len(atoms))))) for _ in range(count)]


def cli(capsys: Any, *argv: str) -> tuple[int, str, str]:
    """``hbtp ARGV`` in this process: its exit code, standard output and standard error."""
    from hbtp.cli import main

    code = main(list(argv))
    captured = capsys.readouterr()
    return code, captured.out, captured.err


def one_error_line(err: str) -> str:
    """The one line of an error report (asserted to be the only line, with hbtp's prefix)."""
    lines = [line for line in err.splitlines() if line.strip()]
    assert len(lines) == 1, err
    assert lines[0].startswith("hbtp: error: "), err
    return lines[0]
