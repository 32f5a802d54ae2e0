"""The one backward best-first search of BT planning (the paper's Algorithm 1).

Starting from the goal (from each of its disjuncts at once, all at g = 0, so that OBTEA is optimal
over the whole disjunction), a condition ``c`` is expanded by regressing it through every action ``a``
that adds one of its literals and deletes none (``c_a = pre(a) | (c - add(a))``). Conditions are
taken off the open list by priority; every expanded condition becomes a ``Sequence(c, a)`` of the
behavior tree; the search stops when an expanded condition holds in s0.

BT Expansion, OBTEA, HBTP-O and HBTP-S differ only in the *step cost* of an action, a
:class:`~hbtp.planning.costs.StepCosts` value: the full cost, and the reduced cost while the heuristic
path p̂ still owes the action on this search path. With an LLM-free heuristic (``hmax``, ``lm``) the
priority becomes ``g + h`` (A*, so OBTEA stays optimal) for every planner but BT Expansion, and
conditions with an unreachable literal are dropped for every planner.

Speed: actions are indexed by the atoms they add; the best known value per condition is kept
(Algorithm 1, line 11) and stale heap entries are skipped; a condition is pruned when an expanded
subset of it was reached at no higher cost (the g-check keeps this safe under A*); conditions with
mutually exclusive literals are pruned using the domain's mutexes. Under a
:class:`~hbtp.planning.heuristics.Deferred` heuristic (``lmcut``, ``seq``), a condition's costly
estimates are computed when it is taken off the open list, one at a time: as soon as one raises its
priority it is queued again, and the next is computed only if it comes off the list again (lazy
evaluation: a condition whose first estimate puts it beyond the solution's cost never pays for the
others). A condition reached again more cheaply after its expansion is re-opened: expanded again, as a new
branch whose parent was expanded before it (the old branch stays, costlier, and still sound).

Ties are broken by the number of heuristic actions still owed, then by the number of literals false
in s0, then by insertion order, so runs are deterministic.
"""

from __future__ import annotations

import heapq
import logging
import math
import time
from collections.abc import Callable, Iterator, Sequence
from dataclasses import dataclass

from hbtp.collector import collector_paused, search_memory
from hbtp.deadline import TimeLimitReached
from hbtp.domains.mutex import Mutexes
from hbtp.logic.subsets import SubsetIndex
from hbtp.logic.task import Goal, GroundAction, GroundTask, listing
from hbtp.planning.costs import Number, StepCosts
from hbtp.planning.execution import execute_expansions
from hbtp.planning.heuristics import Deferred, Heuristic, HeuristicName, build_heuristic
from hbtp.planning.hints import ResolvedHints
from hbtp.planning.limits import Limits, LimitWatch
from hbtp.planning.result import Expansion, PlanResult, SearchStats, Status
from hbtp.planning.symmetry import Symmetry, find_symmetry

log = logging.getLogger(__name__)


@dataclass(frozen=True)
class SearchConfig:
    """One planner: its step costs, and the optional LLM-free heuristic."""

    name: str
    costs: StepCosts
    heuristic: HeuristicName = "none"
    #: Prune conditions symmetric to one held at no higher g (interchangeable objects, see
    #: :mod:`hbtp.planning.symmetry`): still optimal, a smaller tree. Only without p̂, in the whole space.
    symmetry: bool = False


# An open-list entry: (priority, owed, unmet, order, g, condition, stage), compared left to right:
# the priority, then the number of actions p̂ still owes, the number of literals false in s0, the
# insertion order; then g, the condition and the entry's stage: _READY to expand, _RESUME the
# condition's pending children (see _Search.generate), or _UNREFINED + k (the costly estimates of a
# Deferred heuristic from its k-th on are still to be computed). A plain tuple: a NamedTuple costs
# 0.3 µs more per push.
_Entry = tuple[Number, int, int, int, Number, frozenset[int], int]
_READY, _RESUME, _UNREFINED = 0, 1, 2


class _Node:
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


def release_search_memory() -> None:
    """Free what the last search left parked in the enclosing :func:`~hbtp.collector.searches_frozen`
    (done automatically when the next search starts); nothing outside one."""
    memory = search_memory()
    if memory is not None:
        memory.release()


def search(
    task: GroundTask,
    goal: Goal,
    actions: Sequence[GroundAction],
    config: SearchConfig,
    *,
    mutexes: Mutexes | None = None,
    hints: ResolvedHints | None = None,
    limits: Limits | None = None,
    extra_expansions: int = 0,
) -> PlanResult:
    """Run the backward search for ``goal`` with the action space ``actions``.

    ``extra_expansions`` keeps expanding that many more conditions after the solution is found: a
    larger tree that recovers from more states (|S⁻| still counts the expansions up to the solution).
    """
    release_search_memory()
    started = time.perf_counter()
    limits = limits or Limits()

    def finish(status: Status, message: str) -> PlanResult:
        stats = SearchStats(time_s=time.perf_counter() - started, action_space=len(actions))
        return PlanResult(status, config.name, goal, message=message, stats=stats)

    unsolvable = goal.unsolvable
    if unsolvable is not None:
        return finish(Status.UNSOLVABLE, unsolvable)
    if mutexes is not None:
        clashes = [mutexes.conflict(d) for d in goal.reachable]
        if all(clash is not None for clash in clashes):
            names = "; ".join(" and ".join(task.names(clash)) for clash in clashes if clash is not None)
            return finish(Status.UNSOLVABLE, f"the goal asks for {names}, which cannot hold together")
    memory = search_memory()
    with memory.paused() if memory is not None else collector_paused():
        try:
            run = _Search(task, goal, actions, config, mutexes, hints, LimitWatch(limits, started), extra_expansions)
        except TimeLimitReached as stop:
            return finish(Status.TIMEOUT, str(stop))
        if not run.live_roots():
            heuristic = run.heuristic
            assert heuristic is not None
            dead = sorted({a for d in goal.disjuncts for a in d if math.isinf(heuristic((a,)))})
            names = listing(task.names(dead)) or str(goal)
            return finish(Status.UNSOLVABLE, f"{names} cannot be reached from s0 with this action space")
        result = run.run()
        if memory is not None:
            memory.park(run.release())
        return result


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


class _Search:
    """One run of the search (see the module docstring)."""

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
        # Per action, the atoms mutex with one of its preconditions (everything when two of them are).
        self.clashing: dict[int, frozenset[int]] = {}
        self.everything = frozenset(range(len(task.atoms)))
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
        self.fresh = _UNREFINED if self.deferred is not None else _READY  # the stage of a new condition
        self.check_every = 15 if self.deferred is not None else 255  # pops between time checks, minus 1
        self.reopened = 0
        self.achievers, self.in_space = _achiever_index(task, actions)
        # Achievers of each atom, built when first needed and sorted by a lower bound of how much a
        # child's priority exceeds its parent's g (see adders_of).
        self.adders: dict[int, list[tuple[Number, int]]] = {}

        self.mutexes = mutexes
        self.symmetry = _symmetry(task, goal, actions, config, bool(self.path_index))
        self.orbits: dict[frozenset[int], frozenset[int]] = {}  # canonical image -> the condition holding it
        self.nodes: dict[frozenset[int], _Node] = {}
        self.open: list[_Entry] = []
        self.counter = 0
        self.expanded = SubsetIndex()  # the expanded conditions, valued by their g
        self.expansions: list[Expansion] = []
        self.position: dict[frozenset[int], int] = {}
        self.generated = self.pruned_subset = self.pruned_mutex = self.pruned_dead_end = self.pruned_symmetric = 0
        self.stopped: Status | None = None
        self.extra_expansions = extra_expansions
        self.explored_at_solution = 0

    # ----------------------------------------------------------------- helpers
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

    def clashing_atoms(self, action: GroundAction) -> frozenset[int]:
        """The atoms that a condition regressed through ``action`` may not keep: those mutex with a
        precondition (a condition holds no mutex pair, so the precondition's own atoms never clash
        with what the condition keeps); :attr:`everything` when the precondition holds a mutex pair."""
        assert self.partners is not None
        partners = self.partners
        found = frozenset().union(*(partners[atom] for atom in action.pre))
        return found if found.isdisjoint(action.pre) else self.everything

    def priority(self, condition: frozenset[int], g: Number) -> Number:
        if self.astar and self.heuristic is not None:
            return g + self.heuristic(condition)
        return g

    def push(self, condition: frozenset[int], node: _Node, priority: Number, stage: int) -> None:
        self.counter += 1
        entry: _Entry = (priority, sum(node.owed), len(condition - self.s0), self.counter, node.g, condition, stage)
        heapq.heappush(self.open, entry)

    # -------------------------------------------------------------------- run
    def live_roots(self) -> list[frozenset[int]]:
        """The goal's disjuncts the search expands: those that no mutex rules out and whose
        heuristic value is finite (the others stay in the tree as goal checks)."""
        mutexes, heuristic = self.mutexes, self.heuristic
        return [
            d
            for d in self.goal.reachable
            if (mutexes is None or mutexes.conflict(d) is None) and (heuristic is None or not math.isinf(heuristic(d)))
        ]

    def run(self) -> PlanResult:
        for condition in self.goal.disjuncts:
            root = _Node(0, 0, self.initial_owed, None, None)
            self.nodes[condition] = root
            self.record(condition, root)
        for condition in self.live_roots():
            self.push(condition, self.nodes[condition], self.priority(condition, 0), self.fresh)
        roots = frozenset(self.goal.disjuncts)
        final: frozenset[int] | None = None
        open_list = self.open
        nodes = self.nodes
        expanded = self.expanded
        pops = 0
        check_every = self.check_every
        while open_list and self.stopped is None:
            priority, _owed, _unmet, _order, entry_g, condition, stage = heapq.heappop(open_list)
            pops += 1
            if pops & check_every == 0 and final is None and self.watch.timed_out():
                self.stopped = Status.TIMEOUT
                break
            node = nodes[condition]
            if stage == _RESUME:
                self.generate(condition, node, priority)
                continue
            if node.closed or node.g != entry_g:
                continue  # stale entry
            if condition not in roots and expanded.has_subset(condition, node.g):
                self.pruned_subset += 1
                continue
            if stage >= _UNREFINED and self.refined(condition, node, priority, stage):
                continue
            self.close(condition, node)
            if final is None and condition <= self.s0:
                final = condition
                self.explored_at_solution = len(self.expansions)
            if final is not None:
                # Robustness budget: keep exploring to cover more states, never failing the run.
                if len(self.expansions) - self.explored_at_solution >= self.extra_expansions:
                    break
                if self.watch.check(len(self.expansions), self.generated) is not None:
                    break
                if condition <= self.s0:
                    continue
            else:
                self.stopped = self.watch.check(len(self.expansions), self.generated)
                if self.stopped is not None:
                    break
            self.start_expansion(condition, node, priority)
        if final is not None:
            self.stopped = None
        return self.result(final)

    def refined(self, condition: frozenset[int], node: _Node, priority: Number, stage: int) -> bool:
        """Compute the Deferred heuristic's costly estimates from the one ``stage`` names, one at a
        time; as soon as one raises the priority (``g`` plus the cheap estimate: the heuristic is
        their maximum), queue the condition again with the next estimate still to compute, and say
        so. The others are computed only if the condition is taken off the list again."""
        assert self.deferred is not None
        parts = self.deferred.costly
        for step in range(stage - _UNREFINED, len(parts)):
            value = node.g + parts[step](condition)
            if value > priority:
                rest = step + 1 < len(parts) and not math.isinf(value)
                self.push(condition, node, value, _UNREFINED + step + 1 if rest else _READY)
                return True
        return False

    def close(self, condition: frozenset[int], node: _Node) -> None:
        node.closed = True
        if condition not in self.position or node.reopened:  # the goal's disjuncts are recorded at the start
            self.record(condition, node)

    def record(self, condition: frozenset[int], node: _Node) -> None:
        """Add ``condition`` to the expansion record (the tree) and to the subset index."""
        parent_position = -1 if node.parent is None else self.position[node.parent]
        self.position[condition] = len(self.expansions)
        self.expansions.append(Expansion(condition, node.action, parent_position, node.cost))
        if condition:  # the empty condition holds in s0: it ends the search and prunes nothing
            self.expanded.add(condition, node.g)

    def start_expansion(self, condition: frozenset[int], node: _Node, priority: Number) -> None:
        """Generate the children of a newly expanded condition that fit under ``priority``.

        Actions that p̂ still owes on this path are generated at once (their step is reduced);
        the others come lazily, in order of their bound.
        """
        node.seen = set()
        if self.path_index:
            owed = node.owed
            for action_id, slot in self.path_index.items():
                if owed[slot] > 0:
                    action = self.task.actions[action_id]
                    if not action.add.isdisjoint(condition):
                        node.seen.add(action_id)
                        self.child(condition, node, action)
        lists = [entries for entries in map(self.adders_of, sorted(condition)) if entries]
        if not lists:
            return
        node.pending = iter(lists[0]) if len(lists) == 1 else heapq.merge(*lists)
        self.generate(condition, node, priority)

    def generate(self, condition: frozenset[int], node: _Node, threshold: Number) -> None:
        """Generate children whose bound fits under ``threshold``; queue the rest for later."""
        pending = node.pending
        seen = node.seen
        if pending is None or seen is None:
            return
        limit = threshold - node.g
        actions = self.task.actions
        count = 0
        while True:
            item = node.peek
            if item is None:
                item = next(pending, None)
                if item is None:
                    node.pending = None
                    return
            else:
                node.peek = None
            bound, index = item
            if bound > limit:
                node.peek = item
                self.push(condition, node, node.g + bound, _RESUME)
                return
            if index in seen:
                continue
            seen.add(index)
            self.child(condition, node, actions[index])
            count += 1
            if count & 511 == 0 and self.watch.timed_out():
                self.stopped = Status.TIMEOUT
                return

    def child(self, condition: frozenset[int], node: _Node, action: GroundAction) -> None:
        """Regress ``condition`` through ``action`` and queue the result unless it is pruned."""
        if not condition.isdisjoint(action.delete):
            return
        if self.partners is not None:
            clashing = self.clashing.get(action.index)
            if clashing is None:
                clashing = self.clashing[action.index] = self.clashing_atoms(action)
            if not clashing.isdisjoint(condition) and (
                clashing is self.everything or not clashing & condition <= action.add
            ):
                self.pruned_mutex += 1
                return
        rest = condition - action.add
        result = action.pre | rest
        nogoods = self.nogoods
        if nogoods is not None and _completes_nogood(rest, nogoods, result):
            self.pruned_mutex += 1
            return
        slot = self.path_index.get(action.index)
        owed = node.owed
        if slot is not None and owed[slot] > 0:
            step = self.owed_cost(action)
            owed = (*owed[:slot], owed[slot] - 1, *owed[slot + 1 :])
        else:
            step = self.full_cost(action)
        g = node.g + step
        known = self.nodes.get(result)
        if known is not None and (known.g <= g or (known.closed and self.deferred is None)):
            return
        if self.symmetry is not None and self.symmetric_duplicate(result, g):
            self.pruned_symmetric += 1
            return
        priority = self.priority(result, g)
        if math.isinf(priority) or (
            not self.astar and self.heuristic is not None and math.isinf(self.heuristic(result))
        ):
            self.pruned_dead_end += 1
            return
        new = _Node(g, node.cost + action.cost, owed, condition, action.index)
        if result in self.position:  # expanded before, at a higher g
            new.reopened = True
            if known is not None and known.closed:
                self.reopened += 1
        self.nodes[result] = new
        self.generated += 1
        self.push(result, new, priority, self.fresh)

    def symmetric_duplicate(self, condition: frozenset[int], g: Number) -> bool:
        """Whether a condition symmetric to ``condition`` is held at no higher g (else ``condition``
        becomes its orbit's condition)."""
        assert self.symmetry is not None
        key = self.symmetry.canonical(condition)
        held = self.orbits.get(key)
        if held is not None and held != condition:
            other = self.nodes.get(held)
            if other is not None and other.g <= g:
                return True
        self.orbits[key] = condition
        return False

    def release(self) -> tuple[object, ...]:
        """Hand over the search state, to be freed later (returning costs nothing then)."""
        state = (self.nodes, self.open, self.adders, self.expanded, self.position, self.orbits)
        self.nodes, self.open, self.adders, self.expanded, self.position = {}, [], {}, SubsetIndex(), {}
        self.orbits = {}
        return state

    # ----------------------------------------------------------------- result
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


def _completes_nogood(rest: frozenset[int], nogoods: Sequence[Sequence[frozenset[int]]], child: frozenset[int]) -> bool:
    """Whether the regressed condition holds a nogood that the condition it came from (whose
    ``rest`` it keeps) did not."""
    for atom in child:
        for nogood in nogoods[atom]:
            if nogood <= child and not nogood <= rest:
                return True
    return False
