"""Re-planning as repair: continue a finished backward search from a new start state.

The backward search (:mod:`hbtp.planning.search`) grows conditions from the goal; a condition's g is
its cost *to the goal*, which does not depend on the start state. Only three things do: the
heuristic (an estimate of the cost from the start state to a condition), the test that ends the
search (a condition that holds in the start state), and the tie-breaks. A :class:`RepairableSearch`
keeps a search alive after it ends and, for a new state s', continues it (:meth:`~RepairableSearch.repair`)
instead of starting over:

1. the heuristic is built again toward s' (:func:`~hbtp.planning.heuristics.build_heuristic` on the
   task started in s');
2. every open condition is queued again at ``g + h'(c)``; those whose h' is infinite are *parked*
   (kept, and queued again at the next repair: a dead end from one state need not be from another);
3. every closed condition generates its children again, lazily, in the order of the new bounds,
   skipping those it generated already (the achievers the old heuristic left out come back); the
   children the old heuristic dropped as dead ends are regressed again;
4. the cheapest closed condition that holds in s' (if any) is the *cover*: the search ends with it as
   soon as no queued condition is cheaper; otherwise it ends, as always, by expanding a condition
   that holds in s'.

Why the answer is the optimal cost from s'. With step costs that are the actions' costs (OBTEA) and a
consistent heuristic (``none``, ``hmax``, ``lm``: :mod:`hbtp.planning.heuristics`), a closed condition's g
is optimal, whatever the heuristic that ordered it, and after steps 2-3 every condition not closed is
either queued at its best g from a closed parent, or is the child of a closed condition still to be
generated (step 3 queues a lower bound of its priority), or is parked with an infinite estimate (it
cannot lie on a plan from s'). So the invariant of A* holds: on every optimal regression path from
the goal to a condition that holds in s', the first condition not closed is queued at its optimal g,
with priority at most the optimum (h' is admissible). Hence the first condition taken off the list
that holds in s', or the cover once nothing cheaper is queued, is optimal; the pruning the search
does (subsets reached at no higher g, proved mutexes) does not depend on the start state. The tree of
the result is every closed condition, cheapest cost to the goal first, so it acts at the optimum from
s' and from every state of the earlier searches. Deferred heuristics (``lmcut``, ``seq``: not
consistent, they re-open conditions) and hint-following step costs (HBTP-O, HBTP-S: their g is not a
cost) cannot be continued: :func:`repairable` says so, and the caller searches from scratch.

Memory: a kept search holds its nodes, open list, subset index and expansion record. It is bounded by
``max_conditions`` (nodes held); :attr:`RepairableSearch.spent` turns true past it, and the owner drops
it (the next re-plan starts a new search). A search stopped by a limit stays consistent (the entry it
held is queued back and step 3 regenerates every closed condition) and may be continued.
"""

from __future__ import annotations

import heapq
import math
import time
from collections.abc import Sequence

from hbtp.collector import collector_paused
from hbtp.deadline import TimeLimitReached
from hbtp.domains.mutex import Mutexes
from hbtp.logic.task import Goal, GroundAction, GroundTask
from hbtp.planning.heuristics import build_heuristic
from hbtp.planning.limits import Limits, LimitWatch
from hbtp.planning.result import PlanResult, SearchStats, Status
from hbtp.planning.search import _Search, goal_verdict, merged
from hbtp.planning.search_state import READY, RESUME, Node, SearchConfig

#: Conditions a kept search may hold before it is dropped (about 0.5 KB each with the open list and
#: the subset index: some 150 MB).
MAX_CONDITIONS = 300_000


def repairable(config: SearchConfig) -> bool:
    """Whether searches of ``config`` can be continued from another state with optimal answers."""
    costs = config.costs
    return config.heuristic.consistent and not costs.follows_hints and costs.orders_by_heuristic and not config.symmetry


class RepairableSearch(_Search):
    """A backward search kept alive to be continued from other start states (see the module docstring).

    Build it with :meth:`start`; then :meth:`repair` for each new state. Not thread-safe: one owner.
    """

    max_conditions = MAX_CONDITIONS

    @classmethod
    def start(
        cls,
        task: GroundTask,
        goal: Goal,
        actions: Sequence[GroundAction],
        config: SearchConfig,
        *,
        mutexes: Mutexes | None = None,
        limits: Limits | None = None,
    ) -> tuple[RepairableSearch | None, PlanResult]:
        """Search from ``task``'s s0 as :func:`~hbtp.planning.search.search` does, and keep the search
        (``None`` when the goal is unsolvable before any search: nothing to continue).

        ``mutexes`` must hold in every state the search is continued from (the proved ones do in every
        reachable state); :func:`repairable` must accept ``config``.
        """
        if not repairable(config):
            raise ValueError(f"{config.name} with {config.heuristic} cannot be continued (see repairable)")
        started = time.perf_counter()
        verdict = goal_verdict(task, goal, mutexes)
        if verdict is not None:
            stats = SearchStats(time_s=time.perf_counter() - started, action_space=len(actions))
            return None, PlanResult(Status.UNSOLVABLE, config.name, goal, message=verdict, stats=stats)
        with collector_paused():
            try:
                run = cls(task, goal, actions, config, mutexes, None, LimitWatch(limits or Limits(), started))
            except TimeLimitReached as stop:
                stats = SearchStats(time_s=time.perf_counter() - started, action_space=len(actions))
                return None, PlanResult(Status.TIMEOUT, config.name, goal, message=str(stop), stats=stats)
            live = set(run.live_roots())
            run.parked = [
                d for d in goal.reachable if d not in live and (mutexes is None or mutexes.conflict(d) is None)
            ]
            run.actions = actions
            run.dropped = []
            if not live:
                run.plant()
                return run, run.finish_unsolved(run.dead_goal())
            return run, run.run()

    # Set by start(): the action space, the parked conditions, the dead-end children (parent, action).
    actions: Sequence[GroundAction]
    parked: list[frozenset[int]]
    dropped: list[tuple[frozenset[int], int]]

    @property
    def spent(self) -> bool:
        """Whether the search holds more than :attr:`max_conditions` conditions (drop it)."""
        return len(self.nodes) > self.max_conditions

    def repair(self, task: GroundTask, goal: Goal, limits: Limits | None = None) -> PlanResult:
        """Continue the search toward ``task``'s s0 (the observed state: ``GroundTask.from_state``)
        for ``goal`` (the same goal resolved in ``task``): the optimal tree from there, or UNSOLVABLE
        when no condition that holds there can be reached (a proof), or a limit."""
        if goal.disjuncts != self.goal.disjuncts:
            raise ValueError("a search continues for its own goal only")
        started = time.perf_counter()
        with collector_paused():
            self.task, self.goal, self.s0 = task, goal, task.initial_state
            self.watch = LimitWatch(limits or Limits(), started)
            self.stopped = None
            self.explored_at_solution = 0
            try:
                self.heuristic = build_heuristic(
                    self.config.heuristic, task, self.actions, goal.literal_ids,
                    scale=float(self.config.costs.scale), deadline=self.watch.as_deadline(),
                )  # fmt: skip
            except TimeLimitReached as stop:  # nothing changed but the target: the search stays usable
                stats = SearchStats(time_s=time.perf_counter() - started, action_space=len(self.actions))
                return PlanResult(Status.TIMEOUT, self.config.name, goal, message=str(stop), stats=stats)
            self.adders = {}
            self._requeue_open()
            self._regenerate_closed()
            self._find_cover()
            if not self.open and self.cover is None:
                return self.finish_unsolved("no condition that holds in the state can be reached (open list emptied)")
            return self.loop()

    def finish_unsolved(self, message: str) -> PlanResult:
        """An UNSOLVABLE result with the search's record and statistics."""
        result = self.result(None)
        return PlanResult(
            Status.UNSOLVABLE, result.planner, result.goal, result.expansions, stats=result.stats, message=message
        )

    def dead_end(self, condition: frozenset[int], action: GroundAction) -> None:
        """Remember the dropped child: another state may reach it."""
        self.pruned_dead_end += 1
        self.dropped.append((condition, action.index))

    def _queue(self, condition: frozenset[int], node: Node) -> None:
        priority = self.priority(condition, node.g)
        if math.isinf(priority):
            self.parked.append(condition)
        else:
            self.push(condition, node, priority, READY)

    def _requeue_open(self) -> None:
        """Queue every open condition (and every parked one) again under the new heuristic."""
        entries, parked = self.open, self.parked
        self.open, self.parked = [], []
        nodes = self.nodes
        for entry in entries:
            condition, g, stage = entry[5], entry[4], entry[6]
            node = nodes[condition]
            if stage == READY and not node.closed and node.g == g:
                self._queue(condition, node)
        for condition in parked:
            node = nodes[condition]
            if not node.closed:
                self._queue(condition, node)
        heapq.heapify(self.open)

    def _regenerate_closed(self) -> None:
        """Let every closed condition generate its children again in the order of the new bounds
        (those generated before are skipped), and regress the dropped dead ends again."""
        for condition, node in self.nodes.items():
            if not node.closed:
                continue
            if node.seen is None:
                node.seen = set()
            lists = [entries for entries in map(self.adders_of, sorted(condition)) if entries]
            node.pending = merged(lists) if lists else None
            node.peek = None if node.pending is None else next(node.pending, None)
            if node.peek is not None:
                self.push(condition, node, node.g + node.peek[0], RESUME)
        dropped, self.dropped = self.dropped, []
        actions = self.task.actions
        for parent, index in dropped:
            self.child(parent, self.nodes[parent], actions[index])

    def _find_cover(self) -> None:
        """The cheapest closed condition that holds in s0, if any (the loop may end with it)."""
        self.cover, self.cover_g = None, math.inf
        s0 = self.s0
        for condition, node in self.nodes.items():
            if node.closed and node.g < self.cover_g and condition <= s0:
                self.cover, self.cover_g = condition, node.g


__all__ = ["MAX_CONDITIONS", "RepairableSearch", "repairable"]
