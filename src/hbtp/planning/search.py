"""The one backward best-first search of BT planning (the paper's Algorithm 1).

Starting from the goal, a condition ``c`` is expanded by regressing it through every action ``a``
that adds one of its literals and deletes none (``c_a = pre(a) | (c - add(a))``). Conditions are
taken off the open list by priority; every expanded condition becomes a ``Sequence(c, a)`` of the
behavior tree; the search stops when an expanded condition holds in s0.

BT Expansion, OBTEA, HBTP-O and HBTP-S differ only in the *step cost* ``h(a)`` of an action:

* ``bte``: 1 (breadth-first, costs ignored);
* ``obtea``: ``D(a)``;
* ``hbtp-o``: ``D(a)/α`` while the heuristic path p̂ still owes ``a`` on this search path, else ``D(a)``
  (costs are kept as integers scaled by α when α is a whole number);
* ``hbtp-s``: 0 while owed, else ``D(a)``.

With ``heuristic="hmax"`` the priority becomes ``g + h_max`` for OBTEA (A*, still optimal) and
conditions with an unreachable literal are dropped for every planner.

Speed: actions are indexed by the atoms they add; the best known value per condition is kept
(Algorithm 1, line 11) and stale heap entries are skipped; a condition is pruned when an expanded
subset of it was reached at no higher cost (the g-check keeps this safe under A*); conditions with
mutually exclusive literals are pruned using the domain's mutexes. Ties are broken by the number of
heuristic actions still owed, then by the number of literals false in s0, then by insertion order,
so runs are deterministic.
"""

from __future__ import annotations

import heapq
import logging
import math
import time
from collections.abc import Sequence
from dataclasses import dataclass
from fractions import Fraction
from typing import Literal

from hbtp.domains.mutex import Mutexes
from hbtp.logic.task import Goal, GroundAction, GroundTask
from hbtp.planning.execution import execute_expansions
from hbtp.planning.heuristics import hmax_table
from hbtp.planning.hints import ResolvedHints
from hbtp.planning.limits import Limits, LimitWatch
from hbtp.planning.result import Expansion, PlanResult, SearchStats, Status

log = logging.getLogger(__name__)

StepCost = Literal["unit", "cost", "optimal-heuristic", "satisficing-heuristic"]
HeuristicName = Literal["none", "hmax"]
Number = int | float | Fraction


@dataclass(frozen=True)
class SearchConfig:
    """One planner: how an action's step cost is computed, and the optional LLM-free heuristic."""

    name: str
    step_cost: StepCost
    alpha: Number = 10_000
    heuristic: HeuristicName = "none"


class _Node:
    """Search bookkeeping for one condition (mutable, internal)."""

    __slots__ = ("action", "closed", "cost", "g", "owed", "parent")

    def __init__(
        self, g: Number, cost: int, owed: tuple[int, ...], parent: frozenset[int] | None, action: int | None
    ) -> None:
        self.g = g
        self.cost = cost
        self.owed = owed
        self.parent = parent
        self.action = action
        self.closed = False


def search(
    task: GroundTask,
    goal: Goal,
    actions: Sequence[GroundAction],
    config: SearchConfig,
    *,
    mutexes: Mutexes | None = None,
    hints: ResolvedHints | None = None,
    limits: Limits | None = None,
) -> PlanResult:
    """Run the backward search for ``goal`` with the action space ``actions``."""
    started = time.perf_counter()
    limits = limits or Limits()
    watch = LimitWatch(limits, started)
    space = len(actions)

    def finish(status: Status, message: str = "", **stats: int) -> PlanResult:
        return PlanResult(
            status,
            config.name,
            goal,
            message=message,
            stats=SearchStats(time_s=time.perf_counter() - started, action_space=space, **stats),
        )

    if goal.unreachable:
        names = ", ".join(str(a) for a in goal.unreachable)
        return finish(Status.UNSOLVABLE, f"no action makes {names} true and s0 does not hold it")
    goal_condition = goal.ids
    if mutexes is not None:
        clash = mutexes.conflict(goal_condition)
        if clash is not None:
            names = " and ".join(task.names(clash))
            return finish(Status.UNSOLVABLE, f"the goal asks for {names}, which cannot hold together")

    table: list[float] | None = None
    if config.heuristic == "hmax":
        table = hmax_table(task, actions)
        dead = [a for a in sorted(goal_condition) if math.isinf(table[a])]
        if dead:
            names = ", ".join(task.names(dead))
            return finish(Status.UNSOLVABLE, f"{names} cannot be reached from s0 with this action space")

    # --------------------------------------------------------- step costs
    path_index: dict[int, int] = {}
    initial_owed: list[int] = []
    if hints is not None and config.step_cost in ("optimal-heuristic", "satisficing-heuristic"):
        for action_id, count in sorted(hints.owed.items()):
            path_index[action_id] = len(initial_owed)
            initial_owed.append(count)
    alpha = config.alpha
    scaled = config.step_cost == "optimal-heuristic" and isinstance(alpha, int)
    full_cost: dict[int, Number] = {}
    owed_cost: dict[int, Number] = {}
    for action in actions:
        if config.step_cost == "unit":
            full_cost[action.index] = 1
        elif config.step_cost == "optimal-heuristic":
            full_cost[action.index] = action.cost * alpha if scaled else action.cost
            owed_cost[action.index] = action.cost if scaled else Fraction(action.cost) / Fraction(alpha)
        elif config.step_cost == "satisficing-heuristic":
            full_cost[action.index] = action.cost
            owed_cost[action.index] = 0
        else:
            full_cost[action.index] = action.cost
    astar = table is not None and config.step_cost == "cost"

    # -------------------------------------------------------- action index
    adders: dict[int, list[GroundAction]] = {}
    for action in actions:
        for atom in action.add:
            adders.setdefault(atom, []).append(action)
    no_adders: list[GroundAction] = []

    partners = mutexes.partners if mutexes is not None else None
    nogoods = mutexes.nogoods_by_atom if mutexes is not None and mutexes.nogoods else None
    s0 = task.initial_state

    # ------------------------------------------------------------ the loop
    owed0 = tuple(initial_owed)
    nodes: dict[frozenset[int], _Node] = {goal_condition: _Node(0, 0, owed0, None, None)}
    counter = 0
    open_list: list[tuple[Number, int, int, int, Number, frozenset[int]]] = []

    def priority(condition: frozenset[int], g: Number) -> Number:
        if astar and table is not None:
            return g + max((table[a] for a in condition), default=0.0)
        return g

    heapq.heappush(
        open_list,
        (priority(goal_condition, 0), sum(owed0), len(goal_condition - s0), counter, 0, goal_condition),
    )
    expanded_index: dict[int, list[tuple[frozenset[int], Number]]] = {}
    expansions: list[Expansion] = []
    position: dict[frozenset[int], int] = {}
    generated = pruned_subset = pruned_mutex = pruned_dead = 0

    def dominated(condition: frozenset[int], g: Number) -> bool:
        for atom in condition:
            for other, other_g in expanded_index.get(atom, ()):
                if other_g <= g and other <= condition:
                    return True
        return False

    final: frozenset[int] | None = None
    status = Status.UNSOLVABLE
    while open_list:
        _, _, _, _, entry_g, condition = heapq.heappop(open_list)
        node = nodes[condition]
        if node.closed or node.g != entry_g:
            continue  # stale entry
        if condition is not goal_condition and dominated(condition, node.g):
            pruned_subset += 1
            continue
        node.closed = True
        parent_position = -1 if node.parent is None else position[node.parent]
        position[condition] = len(expansions)
        expansions.append(Expansion(condition, node.action, parent_position, node.cost))
        key = min(condition, key=lambda a: len(expanded_index.get(a, ())), default=None)
        if key is not None:
            expanded_index.setdefault(key, []).append((condition, node.g))
        if condition <= s0:
            final = condition
            status = Status.SOLVED
            break
        stop = watch.check(len(expansions), generated)
        if stop is not None:
            status = stop
            break

        seen: set[int] = set()
        candidates: list[GroundAction] = []
        for atom in sorted(condition):
            for action in adders.get(atom, no_adders):
                if action.index not in seen:
                    seen.add(action.index)
                    candidates.append(action)
        for count, action in enumerate(candidates):
            if count & 511 == 511 and watch.timed_out():
                break
            if not condition.isdisjoint(action.delete):
                continue
            rest = condition - action.add
            child = action.pre | rest
            if partners is not None and _clashes(action.pre, rest, partners, nogoods, child):
                pruned_mutex += 1
                continue
            if table is not None and any(math.isinf(table[a]) for a in action.pre):
                pruned_dead += 1
                continue
            slot = path_index.get(action.index)
            owed = node.owed
            if slot is not None and owed[slot] > 0:
                step = owed_cost[action.index]
                owed = (*owed[:slot], owed[slot] - 1, *owed[slot + 1 :])
            else:
                step = full_cost[action.index]
            g = node.g + step
            known = nodes.get(child)
            if known is not None and (known.closed or known.g <= g):
                continue
            if dominated(child, g):
                pruned_subset += 1
                continue
            nodes[child] = _Node(g, node.cost + action.cost, owed, condition, action.index)
            counter += 1
            generated += 1
            heapq.heappush(open_list, (priority(child, g), sum(owed), len(child - s0), counter, g, child))

    elapsed = time.perf_counter() - started
    stats = SearchStats(
        explored=len(expansions),
        generated=generated,
        pruned_subset=pruned_subset,
        pruned_mutex=pruned_mutex,
        pruned_dead_end=pruned_dead,
        time_s=elapsed,
        action_space=space,
    )
    solution: tuple[int, ...] = ()
    executed: tuple[int, ...] = ()
    cost: int | None = None
    message = ""
    if final is not None:
        path: list[int] = []
        current: frozenset[int] | None = final
        while current is not None:
            current_node = nodes[current]
            if current_node.action is not None:
                path.append(current_node.action)
            current = current_node.parent
        solution = tuple(path)
        run = execute_expansions(task, goal_condition, expansions)
        executed, cost = run.actions, run.cost
        if not run.reached:
            message = "the tree did not reach the goal when executed from s0"
            status = Status.UNSOLVABLE
            log.error("%s: %s (this is a bug)", config.name, message)
    elif status is Status.UNSOLVABLE:
        message = "no condition that holds in s0 can be reached (open list emptied)"
    else:
        message = watch.reason(status)
    return PlanResult(status, config.name, goal, tuple(expansions), solution, executed, cost, stats, message)


def _clashes(
    pre: frozenset[int],
    rest: frozenset[int],
    partners: Sequence[frozenset[int]],
    nogoods: Sequence[Sequence[frozenset[int]]] | None,
    child: frozenset[int],
) -> bool:
    """Whether the regressed condition holds mutually exclusive literals (only new pairs are checked)."""
    for atom in pre:
        if atom not in rest and not partners[atom].isdisjoint(child):
            return True
    if nogoods is not None:
        for atom in child:
            for nogood in nogoods[atom]:
                if nogood <= child and not nogood <= rest:
                    return True
    return False
