"""LM-cut (Helmert & Domshlak, 2009) from s0 to a regressed condition.

The backward search asks how much reaching a condition ``c`` from s0 costs at least. LM-cut answers
with disjunctive action landmarks found one at a time in the delete relaxation: compute h_max with
the current costs; every action's *precondition choice* is its costliest precondition; the *goal
zone* is the atoms from which ``c``'s costliest atom is reached by zero-cost achievers; the *cut* is
the actions that add an atom of the zone from an atom reachable from s0 without entering it. Every
plan for ``c`` uses an action of the cut, so its cheapest cost ``m`` is added to the estimate and
taken off every action of the cut (a cost partitioning); this repeats until h_max of ``c`` is 0.

The estimate is admissible but not consistent: the search that uses it re-opens conditions it
reaches again more cheaply, and evaluates it only for conditions it takes off the open list
(:class:`~hbtp.planning.heuristics.Deferred`).

Speed: s0 is the same for every condition, so the first round's h_max, the actions' precondition
values and choices come from a table made once; later rounds update h_max incrementally from the
actions whose cost dropped (only values that go down, in increasing order). The state after a round
depends only on the atoms the rounds so far cut for (the condition's costliest atom each time, the
lowest id among ties), so the states are kept in a tree by those atoms, up to a memory budget:
conditions of one search mostly share their costliest atoms, and reuse each other's rounds. The cut
is read off the goal zone's achievers: instead of a forward search from s0 around the zone, each
precondition choice below the zone's h_max is known to be reached outside it, and the others are
decided by a short search backwards (:meth:`_Round._cut_actions`). An action without a precondition
gets an artificial one that holds in s0.

A round is made in C when the optional extension ``hbtp.planning._lmcut`` is built (it is whenever a C
compiler is found at install): the same steps over flat arrays, with the same values to the last bit.
Without it the rounds run here, in Python, several times slower (:data:`COMPILED` says which).
"""

from __future__ import annotations

import heapq
import math
from array import array
from collections.abc import Iterable, Mapping, MutableSequence, Sequence

from hbtp import compiled as extensions
from hbtp.deadline import Deadline
from hbtp.logic.task import GroundAction, GroundTask

_INF = math.inf
_SETUP = "setting up LM-cut"
_EXTENSION = extensions.LMCUT
_compiled = extensions.extension(_EXTENSION)

#: Whether LM-cut's rounds run in C (the optional extension is built).
COMPILED = _compiled is not None

#: How many list slots the table of states after cuts may hold (8 bytes each: 64 MB, plus the values).
_TABLE_SLOTS = 8_000_000


class LmCut:
    """``h^LM-cut(s0 → c)`` over an action space (costs by action index may be overridden)."""

    def __init__(
        self,
        task: GroundTask,
        actions: Sequence[GroundAction],
        costs: Mapping[int, float] | None = None,
        deadline: Deadline | None = None,
        compiled: bool = COMPILED,
    ) -> None:
        """``compiled``: make the rounds in C (only where the extension is built: :data:`COMPILED`)."""
        self.kernel = extensions.kernel(_compiled, _EXTENSION, compiled=compiled, slower="LM-cut")
        true = len(task.atoms)  # the artificial atom that holds in s0
        self.pre: list[tuple[int, ...]] = [tuple(sorted(a.pre)) or (true,) for a in actions]
        self.add: list[tuple[int, ...]] = [tuple(sorted(a.add)) for a in actions]
        self.cost: list[float] = [float(costs[a.index] if costs is not None else a.cost) for a in actions]
        self.whole = all(c.is_integer() for c in self.cost)
        self.users: list[list[int]] = [[] for _ in range(true + 1)]
        self.achievers: list[list[int]] = [[] for _ in range(true + 1)]
        for i, (pre, add) in enumerate(zip(self.pre, self.add, strict=True)):
            for p in pre:
                self.users[p].append(i)
            for q in add:
                self.achievers[q].append(i)
        if deadline is not None:
            deadline.check(_SETUP)
        self.initial = (*sorted(task.initial_state), true)
        self.hmax, self.value = self._explore()
        self.choice = [self._choice(i, self.hmax, self.value[i]) for i in range(len(self.pre))]
        self.rows = _rows(self.pre, self.add, self.users, self.achievers) if self.kernel is not None else ()
        first = (
            _Round(self, array("d", self.hmax), array("d", self.value), array("i", self.choice), array("d", self.cost))
            if self.kernel is not None
            else _Round(self, self.hmax, self.value, self.choice, self.cost)
        )
        # The states after each sequence of cuts met so far, by the atoms cut for: a condition
        # whose costliest atoms come in the same order as an earlier one's reuses its rounds.
        self.root = _Step(first, 0.0, {})
        self.size = 2 * len(self.hmax) + 3 * len(self.pre)  # list slots per kept state
        self.room = _TABLE_SLOTS

    def _explore(self) -> tuple[list[float], list[float]]:
        """h_max of every atom from s0 with the original costs, and each action's precondition value."""
        hmax = [_INF] * len(self.users)
        waiting = [len(p) for p in self.pre]
        value = [_INF] * len(self.pre)
        heap = [(0.0, p) for p in self.initial]
        for p in self.initial:
            hmax[p] = 0.0
        done = [False] * len(self.users)
        users, add, cost = self.users, self.add, self.cost
        while heap:
            v, p = heapq.heappop(heap)
            if done[p]:
                continue
            done[p] = True
            for i in users[p]:
                waiting[i] -= 1
                if waiting[i] == 0:
                    value[i] = v
                    reached = v + cost[i]
                    for q in add[i]:
                        if reached < hmax[q]:
                            hmax[q] = reached
                            heapq.heappush(heap, (reached, q))
        return hmax, value

    def _choice(self, action: int, hmax: Sequence[float], value: float) -> int:
        """The action's precondition choice: its first precondition of the highest h_max (-1: never
        applicable)."""
        if value == _INF:
            return -1
        return next(p for p in self.pre[action] if hmax[p] == value)

    def __call__(self, condition: Iterable[int]) -> float:
        goal = sorted(condition)
        if any(self.hmax[p] == _INF for p in goal):
            return _INF
        step = self.root
        total = 0.0
        while True:
            hmax = step.state.hmax
            top, atom = 0.0, -1
            for p in goal:
                if hmax[p] > top:
                    top, atom = hmax[p], p
            if atom < 0:
                break
            following = step.next.get(atom) if step.next is not None else None
            if following is None:
                following = self._cut(step, atom)
            total += following.gained
            step = following
        return float(math.ceil(total - 1e-9)) if self.whole else total

    def _cut(self, step: _Step, atom: int) -> _Step:
        """The state after the cut for ``atom`` from ``step``'s, kept in the table while it has room
        (from a state that is not kept, the cut is made in place)."""
        if step.next is None:
            return _Step(step.state, step.state.cut(atom), None)
        state = step.state.copy()
        gained = state.cut(atom)
        if self.room < self.size:
            return _Step(state, gained, None)
        self.room -= self.size
        following = step.next[atom] = _Step(state, gained, {})
        return following


def _rows(*tables: Sequence[Sequence[int]]) -> tuple[array[int], ...]:
    """Each table (a list of tuples of ints) as compressed rows: the start of every row, then the
    items, for the C rounds."""
    flat: list[array[int]] = []
    for table in tables:
        start = array("i", [0])
        items = array("i")
        for row in table:
            items.extend(row)
            start.append(len(items))
        flat += (start, items)
    return tuple(flat)


class _Step:
    """A state of an evaluation after some cuts, what the last cut added, and (when the state is
    kept in the table) the states after one more cut, by the atom cut for."""

    __slots__ = ("gained", "next", "state")

    def __init__(self, state: _Round, gained: float, following: dict[int, _Step] | None) -> None:
        self.state = state
        self.gained = gained
        self.next = following


class _Round:
    """The mutable state of one evaluation: h_max, precondition values and choices, and costs."""

    __slots__ = ("choice", "cost", "hmax", "lm", "value")

    def __init__(
        self,
        lm: LmCut,
        hmax: MutableSequence[float],
        value: MutableSequence[float],
        choice: MutableSequence[int],
        cost: MutableSequence[float],
    ) -> None:
        self.lm = lm
        self.hmax = hmax
        self.value = value
        self.choice = choice
        self.cost = cost

    def copy(self) -> _Round:
        return _Round(self.lm, self.hmax[:], self.value[:], self.choice[:], self.cost[:])

    def cut(self, top: int) -> float:
        """Find the cut for the goal's costliest atom ``top``, take its cost off its actions, update
        h_max, and return that cost."""
        rows, kernel = self.lm.rows, self.lm.kernel
        if kernel is not None:
            return float(kernel.cut(*rows, self.hmax, self.value, self.choice, self.cost, top))
        zone = self._goal_zone(top)
        cut = self._cut_actions(zone, self.hmax[top])
        cost = self.cost
        m = min(cost[i] for i in cut)
        changed: list[tuple[float, int]] = []
        hmax, value, add = self.hmax, self.value, self.lm.add
        for i in cut:
            cost[i] -= m
            reached = value[i] + cost[i]
            for q in add[i]:
                if reached < hmax[q]:
                    hmax[q] = reached
                    changed.append((reached, q))
        heapq.heapify(changed)
        self._lower(changed)
        return m

    def _goal_zone(self, top: int) -> set[int]:
        """The atoms from which ``top`` is reached through zero-cost achievers' precondition choices."""
        zone = {top}
        stack = [top]
        achievers, cost, choice = self.lm.achievers, self.cost, self.choice
        while stack:
            q = stack.pop()
            for i in achievers[q]:
                if cost[i] == 0.0:
                    p = choice[i]
                    if p >= 0 and p not in zone:
                        zone.add(p)
                        stack.append(p)
        return zone

    def _cut_actions(self, zone: set[int], top: float) -> list[int]:
        """The cut, found from the zone's achievers: an achiever is in it when its precondition
        choice is outside the zone and reached from s0 without entering it. That holds for every
        atom of h_max below the zone's (``top``: the atoms that gave it its h_max all lie below, and
        the zone's atoms all have h_max ``top`` or more); for the others, a search backwards over
        achievers' precondition choices, outside the zone, looks for one below."""
        achievers, choice, hmax = self.lm.achievers, self.choice, self.hmax
        cut: dict[int, None] = {}
        known: dict[int, bool] = {}  # atoms at or above top, outside the zone: reached or not
        for q in zone:
            for i in achievers[q]:
                p = choice[i]
                if p < 0 or p in zone or i in cut:
                    continue
                if hmax[p] < top:
                    cut[i] = None
                    continue
                reached = known.get(p)
                if reached is None:
                    reached = self._reached_outside(p, zone, top, known)
                if reached:
                    cut[i] = None
        return list(cut)

    def _reached_outside(self, atom: int, zone: set[int], top: float, known: dict[int, bool]) -> bool:
        """Whether ``atom`` (outside the zone, h_max at least ``top``) is reached from s0 without
        entering ``zone``: whether a chain of achievers' precondition choices outside the zone leads
        back to an atom of h_max below ``top``. Searches that find none mark what they saw."""
        achievers, choice, hmax = self.lm.achievers, self.choice, self.hmax
        seen = {atom}
        stack = [atom]
        while stack:
            for i in achievers[stack.pop()]:
                p = choice[i]
                if p < 0 or p in zone or p in seen:
                    continue
                if hmax[p] < top or known.get(p):
                    known[atom] = True
                    return True
                if p not in known:
                    seen.add(p)
                    stack.append(p)
        for p in seen:
            known[p] = False
        return False

    def _lower(self, heap: list[tuple[float, int]]) -> None:
        """Propagate lowered h_max values (a heap of them) to the actions that use the atoms."""
        lm = self.lm
        users, pre, add = lm.users, lm.pre, lm.add
        hmax, value, choice, cost = self.hmax, self.value, self.choice, self.cost
        pop, push = heapq.heappop, heapq.heappush
        while heap:
            v, q = pop(heap)
            if v != hmax[q]:
                continue
            for i in users[q]:
                if choice[i] != q:  # the costliest precondition is another one, unchanged
                    continue
                needs = pre[i]
                if len(needs) == 1:
                    best = v
                else:
                    best, arg = -1.0, -1
                    for p in needs:
                        if hmax[p] > best:
                            best, arg = hmax[p], p
                    choice[i] = arg
                if best < value[i]:
                    value[i] = best
                    reached = best + cost[i]
                    for q2 in add[i]:
                        if reached < hmax[q2]:
                            hmax[q2] = reached
                            push(heap, (reached, q2))
