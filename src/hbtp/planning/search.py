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
import itertools
import logging
import math
import time
from collections.abc import Iterator, Sequence

from hbtp.collector import collector_paused, search_memory
from hbtp.deadline import TimeLimitReached
from hbtp.domains.mutex import Mutexes
from hbtp.logic.task import Goal, GroundAction, GroundTask, listing
from hbtp.planning.costs import Number
from hbtp.planning.hints import ResolvedHints
from hbtp.planning.limits import Limits, LimitWatch
from hbtp.planning.result import Expansion, PlanResult, SearchStats, Status
from hbtp.planning.search_state import READY, RESUME, UNREFINED, Entry, Node, SearchConfig, SearchState

log = logging.getLogger(__name__)


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

    verdict = goal_verdict(task, goal, mutexes)
    if verdict is not None:
        return finish(Status.UNSOLVABLE, verdict)
    memory = search_memory()
    with memory.paused() if memory is not None else collector_paused():
        try:
            run = _Search(task, goal, actions, config, mutexes, hints, LimitWatch(limits, started), extra_expansions)
        except TimeLimitReached as stop:
            return finish(Status.TIMEOUT, str(stop))
        if not run.live_roots():
            return finish(Status.UNSOLVABLE, run.dead_goal())
        result = run.run()
        if memory is not None:
            memory.park(run.release())
        return result


def goal_verdict(task: GroundTask, goal: Goal, mutexes: Mutexes | None) -> str | None:
    """Why ``goal`` is unsolvable before any search (its literals, or mutexes in every disjunct), or ``None``."""
    if goal.unsolvable is not None:
        return goal.unsolvable
    if mutexes is not None:
        clashes = [mutexes.conflict(d) for d in goal.reachable]
        if all(clash is not None for clash in clashes):
            names = "; ".join(" and ".join(task.names(clash)) for clash in clashes if clash is not None)
            return f"the goal asks for {names}, which cannot hold together"
    return None


class _Search(SearchState):
    """One run of the search (see the module docstring): the open list, expansion and regression."""

    #: A closed condition that holds in s0 and its g (:mod:`hbtp.planning.repair` sets them when it
    #: continues a search from a new state): the loop ends with it once no entry is cheaper.
    cover: frozenset[int] | None = None
    cover_g: Number = math.inf

    def dead_goal(self) -> str:
        """Why no disjunct of the goal is live (the heuristic proves each a dead end)."""
        heuristic = self.heuristic
        assert heuristic is not None
        dead = sorted({a for d in self.goal.disjuncts for a in d if math.isinf(heuristic((a,)))})
        names = listing(self.task.names(dead)) or str(self.goal)
        return f"{names} cannot be reached from s0 with this action space"

    def priority(self, condition: frozenset[int], g: Number) -> Number:
        if self.astar and self.heuristic is not None:
            return g + self.heuristic(condition)
        return g

    def push(self, condition: frozenset[int], node: Node, priority: Number, stage: int) -> None:
        self.counter += 1
        entry: Entry = (priority, sum(node.owed), len(condition - self.s0), self.counter, node.g, condition, stage)
        heapq.heappush(self.open, entry)

    def run(self) -> PlanResult:
        self.plant()
        for condition in self.live_roots():
            self.push(condition, self.nodes[condition], self.priority(condition, 0), self.fresh)
        return self.loop()

    def plant(self) -> None:
        """Record the goal's disjuncts (the tree's goal checks) as the roots, at g = 0."""
        for condition in self.goal.disjuncts:
            root = Node(0, 0, self.initial_owed, None, None)
            self.nodes[condition] = root
            self.record(condition, root)

    def loop(self) -> PlanResult:
        """Take conditions off the open list until one that holds in s0 is expanded (or a limit)."""
        roots = frozenset(self.goal.disjuncts)
        final: frozenset[int] | None = None
        cover_g = self.cover_g
        covered = self.cover is not None  # only a repair has one (a plain search keeps its old course)
        open_list = self.open
        nodes = self.nodes
        expanded = self.expanded
        pops = 0
        check_every = self.check_every
        while open_list and self.stopped is None:
            priority, owed, unmet, order, entry_g, condition, stage = heapq.heappop(open_list)
            pops += 1
            if covered and priority >= cover_g and final is None:  # nothing left is cheaper than the cover
                heapq.heappush(open_list, (priority, owed, unmet, order, entry_g, condition, stage))
                final = self.cover
                self.explored_at_solution = len(self.expansions)
                break
            if pops & check_every == 0 and final is None and self.watch.timed_out():
                heapq.heappush(open_list, (priority, owed, unmet, order, entry_g, condition, stage))
                self.stopped = Status.TIMEOUT
                break
            node = nodes[condition]
            if stage == RESUME:
                self.generate(condition, node, priority)
                continue
            if node.closed or node.g != entry_g:
                continue  # stale entry
            if condition not in roots and expanded.has_subset(condition, node.g):
                self.pruned_subset += 1
                continue
            if stage >= UNREFINED and self.refined(condition, node, priority, stage):
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
        if final is None and self.stopped is None and self.cover is not None:  # the open list emptied
            final = self.cover
            self.explored_at_solution = len(self.expansions)
        if final is not None:
            self.stopped = None
        return self.result(final)

    def refined(self, condition: frozenset[int], node: Node, priority: Number, stage: int) -> bool:
        """Compute the Deferred heuristic's costly estimates from the one ``stage`` names, one at a
        time; as soon as one raises the priority (``g`` plus the cheap estimate: the heuristic is
        their maximum), queue the condition again with the next estimate still to compute, and say
        so. The others are computed only if the condition is taken off the list again."""
        assert self.deferred is not None
        parts = self.deferred.costly
        for step in range(stage - UNREFINED, len(parts)):
            value = node.g + parts[step](condition)
            if value > priority:
                rest = step + 1 < len(parts) and not math.isinf(value)
                self.push(condition, node, value, UNREFINED + step + 1 if rest else READY)
                return True
        return False

    def close(self, condition: frozenset[int], node: Node) -> None:
        node.closed = True
        if condition not in self.position or node.reopened:  # the goal's disjuncts are recorded at the start
            self.record(condition, node)

    def record(self, condition: frozenset[int], node: Node) -> None:
        """Add ``condition`` to the expansion record (the tree) and to the subset index."""
        parent_position = -1 if node.parent is None else self.position[node.parent]
        self.position[condition] = len(self.expansions)
        self.expansions.append(Expansion(condition, node.action, parent_position, node.cost))
        if condition:  # the empty condition holds in s0: it ends the search and prunes nothing
            self.expanded.add(condition, node.g)

    def start_expansion(self, condition: frozenset[int], node: Node, priority: Number) -> None:
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
        known = self.adders
        lists = []
        for atom in sorted(condition):
            entries = known.get(atom)
            if entries is None:
                entries = self.adders_of(atom)
            if entries:
                lists.append(entries)
        if not lists:
            return
        node.pending = merged(lists)
        self.generate(condition, node, priority)

    def generate(self, condition: frozenset[int], node: Node, threshold: Number) -> None:
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
                self.push(condition, node, node.g + bound, RESUME)
                return
            if index in seen:
                continue
            seen.add(index)
            self.child(condition, node, actions[index])
            count += 1
            if count & 511 == 0 and self.watch.timed_out():
                self.stopped = Status.TIMEOUT
                return

    def child(self, condition: frozenset[int], node: Node, action: GroundAction) -> None:
        """Regress ``condition`` through ``action`` and queue the result unless it is pruned."""
        if not condition.isdisjoint(action.delete):
            return
        if self.partners is not None and self.clashes(condition, action):
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
            self.dead_end(condition, action)
            return
        new = Node(g, node.cost + action.cost, owed, condition, action.index)
        if result in self.position:  # expanded before, at a higher g
            new.reopened = True
            if known is not None and known.closed:
                self.reopened += 1
        self.nodes[result] = new
        self.generated += 1
        self.push(result, new, priority, self.fresh)

    def dead_end(self, condition: frozenset[int], action: GroundAction) -> None:
        """``condition`` regressed through ``action`` is a dead end for the heuristic (dropped)."""
        self.pruned_dead_end += 1

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


#: Achievers a condition merges at most by sorting them at once (beyond: lazily, by heapq.merge).
_SORTED_MERGE = 64


def merged(lists: list[list[tuple[Number, int]]]) -> Iterator[tuple[Number, int]]:
    """The entries of the sorted ``lists`` in one sorted stream: a few, sorted at once (cheaper than a
    generator per entry); many, merged lazily (the search may take only the first of thousands). The
    entries are distinct pairs or equal ones, so both give the same order."""
    if len(lists) == 1:
        return iter(lists[0])
    if sum(map(len, lists)) <= _SORTED_MERGE:
        return iter(sorted(itertools.chain.from_iterable(lists)))
    return heapq.merge(*lists)


def _completes_nogood(rest: frozenset[int], nogoods: Sequence[Sequence[frozenset[int]]], child: frozenset[int]) -> bool:
    """Whether the regressed condition holds a nogood that the condition it came from (whose
    ``rest`` it keeps) did not."""
    for atom in child:
        for nogood in nogoods[atom]:
            if nogood <= child and not nogood <= rest:
                return True
    return False


__all__ = ["SearchConfig", "goal_verdict", "merged", "release_search_memory", "search"]
