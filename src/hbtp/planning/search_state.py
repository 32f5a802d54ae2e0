"""The state of one run of the backward search (:mod:`hbtp.planning.search`): its configuration,
its nodes and open-list entries, and what is set up once or read at the end (the achievers of each
atom, the heuristic, the roots, the result). The loop itself lives in :mod:`hbtp.planning.search`.
"""

from __future__ import annotations

import logging
import math
import time
from collections.abc import Callable, Iterator, Sequence
from dataclasses import dataclass

from hbtp.domains.mutex import Mutexes
from hbtp.logic.subsets import SubsetIndex
from hbtp.logic.task import Goal, GroundAction, GroundTask
from hbtp.planning.costs import Number, StepCosts
from hbtp.planning.execution import execute_expansions
from hbtp.planning.heuristic_names import HeuristicName
from hbtp.planning.heuristics import Deferred, Heuristic, build_heuristic
from hbtp.planning.hints import ResolvedHints
from hbtp.planning.limits import LimitWatch
from hbtp.planning.result import Expansion, PlanResult, SearchStats, Status
from hbtp.planning.symmetry import Symmetry, find_symmetry

log = logging.getLogger(__name__)


@dataclass(frozen=True)
class SearchConfig:
    """One planner: its step costs, and the optional LLM-free heuristic."""

    name: str
    costs: StepCosts
    heuristic: HeuristicName = HeuristicName.NONE
    #: Prune conditions symmetric to one held at no higher g (interchangeable objects, see
    #: :mod:`hbtp.planning.symmetry`): still optimal, a smaller tree. Only without p̂, in the whole space.
    symmetry: bool = False

    def __post_init__(self) -> None:
        # A name given as text (an untyped caller) becomes the value, so every use can trust it.
        object.__setattr__(self, "heuristic", HeuristicName(self.heuristic))


# An open-list entry: (priority, owed, unmet, order, g, condition, stage), compared left to right:
# the priority, then the number of actions p̂ still owes, the number of literals false in s0, the
# insertion order; then g, the condition and the entry's stage: READY to expand, RESUME the
# condition's pending children (see _Search.generate), or UNREFINED + k (the costly estimates of a
# Deferred heuristic from its k-th on are still to be computed). A plain tuple: a NamedTuple costs
# 0.3 µs more per push.
Entry = tuple[Number, int, int, int, Number, frozenset[int], int]
READY, RESUME, UNREFINED = 0, 1, 2


class Node:
    """Search bookkeeping for one condition (mutable, internal)."""

    __slots__ = ("action", "closed", "cost", "g", "owed", "parent", "peek", "pending", "reopened", "seen")

    def __init__(
        self, g: Number, cost: int, owed: tuple[int, ...], parent: frozenset[int] | None, action: int | None
    ) -> None:
        self.g = g
        self.cost = cost
        self.owed = owed
        self.parent = parent
        self.action = action
        self.closed = False
        self.reopened = False  # the condition was expanded before, at a higher g
        self.pending: Iterator[tuple[Number, int]] | None = None
        self.peek: tuple[Number, int] | None = None
        self.seen: set[int] | None = None


def _symmetry(
    task: GroundTask, goal: Goal, actions: Sequence[GroundAction], config: SearchConfig, follows_path: bool
) -> Symmetry | None:
    """The interchangeable objects the search prunes by, when asked (and said when it cannot)."""
    if not config.symmetry:
        return None
    if follows_path or len(actions) != len(task.actions):
        log.info("%s: no symmetry pruning: it needs the whole action space and no heuristic path", config.name)
        return None
    return find_symmetry(task, goal.disjuncts, actions)


def _owed_slots(
    costs: StepCosts, hints: ResolvedHints | None, actions: Sequence[GroundAction]
) -> tuple[dict[int, int], tuple[int, ...]]:
    """For the actions of p̂ in the space (planners that follow hints only): each one's slot in the
    owed counts, and how many times p̂ owes each at the goal."""
    slots: dict[int, int] = {}
    owed: list[int] = []
    if hints is not None and costs.follows_hints:
        in_space = {a.index for a in actions}
        for action_id, count in sorted(hints.owed.items()):
            if action_id in in_space:
                slots[action_id] = len(owed)
                owed.append(count)
    return slots, tuple(owed)


def _achiever_index(
    task: GroundTask, actions: Sequence[GroundAction]
) -> tuple[Sequence[Sequence[int]] | dict[int, list[int]], frozenset[int] | None]:
    """The achievers of each atom, and the space's action indices if they must still be filtered.

    Large spaces use the task's index (filtered by the space unless it is the whole task); pruned
    ones a small index of their own (filtering the task's 3000-entry lists would cost more than
    building it).
    """
    if len(actions) * 4 < len(task.actions):
        own: dict[int, list[int]] = {}
        for action in actions:
            for atom in action.add:
                own.setdefault(atom, []).append(action.index)
        return own, None
    if len(actions) == len(task.actions):
        return task.achievers, None
    return task.achievers, frozenset(a.index for a in actions)


class SearchState:
    """The state of one run of the search and what does not run per generated child: setting it
    up, the achievers of an atom, the roots, and the result (:class:`hbtp.planning.search._Search`
    runs it)."""

    def __init__(
        self,
        task: GroundTask,
        goal: Goal,
        actions: Sequence[GroundAction],
        config: SearchConfig,
        mutexes: Mutexes | None,
        hints: ResolvedHints | None,
        watch: LimitWatch,
        extra_expansions: int = 0,
    ) -> None:
        self.task = task
        self.goal = goal
        self.config = config
        self.watch = watch
        self.space = len(actions)
        self.partners = mutexes.partners if mutexes is not None else None
        # Per action, whether two of its preconditions are mutex (asked when first regressed through).
        self.self_clashing: dict[int, bool] = {}
        self.nogoods = mutexes.nogoods_by_atom if mutexes is not None and mutexes.nogoods else None
        self.s0 = task.initial_state
        costs = config.costs
        self.full_cost: Callable[[GroundAction], Number] = costs.full_cost
        self.owed_cost: Callable[[GroundAction], Number] = costs.owed_cost
        self.path_index, self.initial_owed = _owed_slots(costs, hints, actions)
        # The heuristic estimates the same step costs (owed actions at their reduced cost). It
        # orders the search (A*) unless the costs say otherwise; for every planner it drops dead ends.
        discounts = {i: float(self.owed_cost(task.actions[i])) for i in self.path_index}
        self.heuristic: Heuristic | None = build_heuristic(
            config.heuristic, task, actions, goal.literal_ids, scale=float(costs.scale), discounts=discounts,
            deadline=watch.as_deadline(),
        )  # fmt: skip
        self.astar = self.heuristic is not None and costs.orders_by_heuristic
        self.deferred = self.heuristic if isinstance(self.heuristic, Deferred) and self.astar else None
        self.fresh = UNREFINED if self.deferred is not None else READY  # the stage of a new condition
        self.check_every = 15 if self.deferred is not None else 255  # pops between time checks, minus 1
        self.reopened = 0
        self.achievers, self.in_space = _achiever_index(task, actions)
        # Achievers of each atom, built when first needed and sorted by a lower bound of how much a
        # child's priority exceeds its parent's g (see adders_of).
        self.adders: dict[int, list[tuple[Number, int]]] = {}

        self.mutexes = mutexes
        self.symmetry = _symmetry(task, goal, actions, config, bool(self.path_index))
        self.orbits: dict[frozenset[int], frozenset[int]] = {}  # canonical image -> the condition holding it
        self.nodes: dict[frozenset[int], Node] = {}
        self.open: list[Entry] = []
        self.counter = 0
        self.expanded = SubsetIndex()  # the expanded conditions, valued by their g
        self.expansions: list[Expansion] = []
        self.position: dict[frozenset[int], int] = {}
        self.generated = self.pruned_subset = self.pruned_mutex = self.pruned_dead_end = self.pruned_symmetric = 0
        self.stopped: Status | None = None
        self.extra_expansions = extra_expansions
        self.explored_at_solution = 0

    def adders_of(self, atom: int) -> list[tuple[Number, int]]:
        """The achievers of ``atom`` in the action space, sorted by their bound.

        The bound is the step cost, plus under A* the heuristic's bound for the preconditions (the
        child holds them, so its priority is at least the parent's g plus the bound). Actions whose
        preconditions are a dead end are left out.
        """
        entries = self.adders.get(atom)
        if entries is not None:
            return entries
        entries = []
        actions = self.task.actions
        in_space = self.in_space
        heuristic = self.heuristic
        achievers = self.achievers
        candidates = achievers.get(atom, ()) if isinstance(achievers, dict) else achievers[atom]
        for index in candidates:
            if in_space is not None and index not in in_space:
                continue
            action = actions[index]
            bound: Number = self.full_cost(action)
            if heuristic is not None:
                pre_cost = heuristic.precondition_bound(action)
                if math.isinf(pre_cost):
                    continue
                if self.astar:
                    bound = bound + pre_cost
            entries.append((bound, index))
        entries.sort()
        self.adders[atom] = entries
        return entries

    def clashes(self, condition: frozenset[int], action: GroundAction) -> bool:
        """Whether ``condition`` regressed through ``action`` holds a mutex pair: an atom it keeps
        (one ``action`` does not add) is mutex with a precondition, or two preconditions are (a
        condition holds no mutex pair, so its own atoms never clash with each other). Asked atom by
        atom of the condition (a few), never building the set of everything mutex with the
        precondition: in a large world that set holds thousands of atoms per action."""
        assert self.partners is not None
        partners, pre = self.partners, action.pre
        clashing = self.self_clashing.get(action.index)
        if clashing is None:
            clashing = self.self_clashing[action.index] = any(not partners[p].isdisjoint(pre) for p in pre)
        if clashing:
            return bool(condition)
        add = action.add
        for atom in condition:  # noqa: SIM110 (a loop, not any() over a generator: this runs for every child)
            if atom not in add and not partners[atom].isdisjoint(pre):
                return True
        return False

    def live_roots(self) -> list[frozenset[int]]:
        """The goal's disjuncts the search expands: those that no mutex rules out and whose
        heuristic value is finite (the others stay in the tree as goal checks)."""
        mutexes, heuristic = self.mutexes, self.heuristic
        return [
            d
            for d in self.goal.reachable
            if (mutexes is None or mutexes.conflict(d) is None) and (heuristic is None or not math.isinf(heuristic(d)))
        ]

    def release(self) -> tuple[object, ...]:
        """Hand over the search state, to be freed later (returning costs nothing then)."""
        state = (self.nodes, self.open, self.adders, self.expanded, self.position, self.orbits)
        self.nodes, self.open, self.adders, self.expanded, self.position = {}, [], {}, SubsetIndex(), {}
        self.orbits = {}
        return state

    def result(self, final: frozenset[int] | None) -> PlanResult:
        stats = SearchStats(
            explored=self.explored_at_solution or len(self.expansions),
            tree_conditions=len(self.expansions),
            generated=self.generated,
            pruned_subset=self.pruned_subset,
            pruned_mutex=self.pruned_mutex,
            pruned_dead_end=self.pruned_dead_end,
            pruned_symmetric=self.pruned_symmetric,
            reopened=self.reopened,
            time_s=time.perf_counter() - self.watch.started,
            action_space=self.space,
        )
        expansions = tuple(self.expansions)
        name, goal = self.config.name, self.goal
        if final is None:
            status = self.stopped or Status.UNSOLVABLE
            message = (
                self.watch.reason(status)
                if self.stopped is not None
                else "no condition that holds in s0 can be reached (open list emptied)"
            )
            return PlanResult(status, name, goal, expansions, stats=stats, message=message)
        path = self.path_to_goal(final)
        run = execute_expansions(self.task, expansions)
        if not run.succeeded:  # cannot happen: every Sequence(c, a) leads to an earlier condition
            log.error("%s: the tree did not reach the goal from s0 (a bug)", name)
            message = "internal error: the tree did not reach the goal when executed from s0"
            return PlanResult(Status.ERROR, name, goal, expansions, path, stats=stats, message=message)
        return PlanResult(
            Status.SOLVED, name, goal, expansions, path, run.executed, run.cost, stats, final=self.position[final]
        )

    def path_to_goal(self, final: frozenset[int]) -> tuple[int, ...]:
        """The actions from the condition ``final`` (it holds in s0) to the goal, along the parents."""
        path: list[int] = []
        current: frozenset[int] | None = final
        while current is not None:
            current_node = self.nodes[current]
            if current_node.action is not None:
                path.append(current_node.action)
            current = current_node.parent
        return tuple(path)


__all__ = ["READY", "RESUME", "UNREFINED", "Entry", "Node", "SearchConfig", "SearchState"]
