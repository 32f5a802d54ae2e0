"""h²: the cost from s0 of every pair of atoms (Haslum & Geffner), as a heuristic of the backward search.

``h²(c)`` is the cost of the costliest pair of atoms of ``c`` (an atom is the pair with itself), in
the fixpoint of

- ``h²({p, q}) = 0`` for ``p, q`` in s0;
- an action ``a`` adding ``p`` and ``q``: ``h²({p, q}) <= cost(a) + h²(pre(a))``;
- an action adding ``p`` and neither adding nor deleting ``q``: ``h²({p, q}) <= cost(a) + h²(pre(a) | {q})``.

It is admissible for the cost of reaching a state that holds ``c`` from s0, and consistent for
regression: a pair of ``regress(c, a) = pre(a) | (c - add(a))`` costs at most ``h²(c) - cost(a)``
by the rules above (regression keeps only actions that delete no atom of ``c``). Unlike h_max and
LM-cut it sees deletes: a pair no plan from s0 can make true together costs ``inf`` (the h² mutexes),
and a pair one action must destroy and another restore costs both.

The fixpoint is computed like Dijkstra's algorithm over cost levels, with the pairs of each atom as
a bit mask: at each level, the new pairs of an atom are added to its mask, and the actions whose
precondition lost a pair reach, for each atom ``q`` in the intersection of the masks of their
precondition atoms, the pairs of ``q`` with their add effects one action cost later. The work
grows with the number of pairs that hold, so tasks with more atoms than :data:`MAX_ATOMS` are not
given h² (:func:`pair_costs` returns ``None``).
"""

from __future__ import annotations

import heapq
import math
from collections.abc import Iterable, Mapping, Sequence
from types import ModuleType

from hbtp import compiled as extensions
from hbtp.deadline import Deadline
from hbtp.logic.task import GroundAction, GroundTask

_EXTENSION = extensions.CHEAP
_compiled = extensions.extension(_EXTENSION)

#: Whether h² and the landmark sum of a condition are computed in C (the optional extension is built).
COMPILED = _compiled is not None


def cheap_kernel(compiled: bool) -> ModuleType | None:
    """The C kernel of h² and the landmark sum if ``compiled`` is asked for (see
    :func:`hbtp.compiled.kernel`)."""
    return extensions.kernel(
        _compiled, _EXTENSION, compiled=compiled, slower="the cheap estimate of a condition (h² and the landmark sum)"
    )


def mask_bytes(mask: int, count: int) -> bytes:
    """A bit mask over ``count`` atoms as the C kernels and numpy read it: little-endian bytes."""
    return mask.to_bytes((count + 7) // 8, "little")


#: The largest task (in atoms) whose pair costs are computed: the table grows with the square of the
#: atoms (RobotHow, 4,914 atoms, would take seconds; IPC instances have hundreds).
MAX_ATOMS = 2000

_SETUP = "computing h² pair costs"


class PairCosts:
    """``h²`` of a condition, from the level at which each atom's pairs were reached.

    ``history[p]`` lists ``(level, mask)``: the atoms ``q`` with ``h²({p, q}) <= level`` (``p``
    itself when ``h²(p) <= level``), at each level where that set grew.

    ``compiled``: after :data:`~hbtp.compiled.WARM_UP` conditions, answer in C from a table of every
    pair's h² (where the extension is built: :data:`COMPILED`).
    """

    def __init__(self, history: Sequence[Sequence[tuple[float, int]]], compiled: bool = COMPILED) -> None:
        self.history = history
        self.bits = [1 << atom for atom in range(len(history))]
        self.known: dict[int, float] = {}
        self.kernel = cheap_kernel(compiled)
        self.table: bytes | None = None  # h² of each pair, n * n doubles (made in C after the warm-up)
        self.calls = 0

    def __call__(self, condition: Iterable[int]) -> float:
        if self.table is not None:
            return float(self.kernel.pair_cost(self.table, len(self.history), condition))  # type: ignore[union-attr]
        self.calls += 1
        if self.calls > extensions.WARM_UP and self.kernel is not None:
            self.table = self.pair_table()
        atoms = condition if isinstance(condition, (frozenset, set, list, tuple)) else list(condition)
        mask = sum(map(self.bits.__getitem__, atoms))  # the atoms are distinct: the sum is their union
        history = self.history
        best = 0.0
        for atom in atoms:
            for level, pairs in history[atom]:
                if pairs & mask == mask:
                    if level > best:
                        best = level
                    break
            else:
                return math.inf
        return best

    def precondition_bound(self, action: GroundAction) -> float:
        value = self.known.get(action.index)
        if value is None:
            value = self.known[action.index] = self(action.pre)
        return value

    def pair_table(self) -> bytes:
        """h² of every pair of atoms, as the C kernel reads it (its table, made there)."""
        assert self.kernel is not None
        count = len(self.history)
        rows = (
            ([level for level, _ in entries], b"".join(mask_bytes(mask, count) for _, mask in entries))
            for entries in self.history
        )
        table: bytes = self.kernel.pair_table(count, rows)
        return table


def pair_costs(
    task: GroundTask,
    actions: Sequence[GroundAction],
    costs: Mapping[int, float] | None = None,
    deadline: Deadline | None = None,
) -> PairCosts | None:
    """h² from s0 with ``actions`` (``costs`` overrides action costs by index), or ``None`` when the
    task has more than :data:`MAX_ATOMS` atoms. Past ``deadline`` it raises
    :class:`~hbtp.deadline.TimeLimitReached`."""
    if len(task.atoms) > MAX_ATOMS:
        return None
    return PairCosts(_Fixpoint(task, actions, costs, deadline).run())


class _Fixpoint:
    """The level-by-level computation of :func:`pair_costs` (internal)."""

    def __init__(
        self,
        task: GroundTask,
        actions: Sequence[GroundAction],
        costs: Mapping[int, float] | None,
        deadline: Deadline | None,
    ) -> None:
        self.deadline = deadline
        self.actions = actions
        self.cost = [float(costs[a.index] if costs is not None else a.cost) for a in actions]
        self.pre = [_mask(a.pre) for a in actions]
        self.add = [_mask(a.add) for a in actions]
        self.kept = [~(_mask(a.add) | _mask(a.delete)) for a in actions]
        self.users: list[list[int]] = [[] for _ in task.atoms]
        for slot, action in enumerate(actions):
            for atom in action.pre:
                self.users[atom].append(slot)
        self.rows = [0] * len(task.atoms)
        self.history: list[list[tuple[float, int]]] = [[] for _ in task.atoms]
        # Per action, the atoms q already paired with its adds (-1: its precondition not reached yet).
        self.used = [-1] * len(actions)
        self.pending: dict[float, dict[int, int]] = {}
        self.levels: list[float] = []
        s0 = _mask(task.initial_state)
        self.pending[0.0] = {}  # level 0 exists even when s0 is empty (actions without precondition)
        self.levels.append(0.0)
        for atom in task.initial_state:
            self.schedule(0.0, atom, s0)

    def schedule(self, level: float, atom: int, pairs: int) -> None:
        bucket = self.pending.get(level)
        if bucket is None:
            bucket = self.pending[level] = {}
            heapq.heappush(self.levels, level)
        bucket[atom] = bucket.get(atom, 0) | pairs

    def run(self) -> list[list[tuple[float, int]]]:
        free = [slot for slot, action in enumerate(self.actions) if not action.pre]  # fired at every level
        steps = 0
        while self.levels:
            level = heapq.heappop(self.levels)
            changed = self.apply(level, self.pending.pop(level))
            touched = set(free)
            for atom in changed:
                touched.update(self.users[atom])
            for slot in sorted(touched):
                self.fire(level, slot)
                steps += 1
                if self.deadline is not None and steps & 1023 == 0:
                    self.deadline.check(_SETUP)
        return self.history

    def apply(self, level: float, bucket: dict[int, int]) -> set[int]:
        """Add the pairs reached at ``level`` (both ways round); the atoms whose pairs grew."""
        rows = self.rows
        changed: set[int] = set()
        for atom, pairs in bucket.items():
            new = pairs & ~rows[atom]
            if not new:
                continue
            rows[atom] |= new
            changed.add(atom)
            bit = 1 << atom
            while new:
                low = new & -new
                other = low.bit_length() - 1
                new ^= low
                if not rows[other] & bit:
                    rows[other] |= bit
                    changed.add(other)
        for atom in changed:
            history = self.history[atom]
            if history and history[-1][0] == level:
                history[-1] = (level, rows[atom])
            else:
                history.append((level, rows[atom]))
        return changed

    def fire(self, level: float, slot: int) -> None:
        """What action ``slot`` reaches from the pairs known at ``level``, one action cost later."""
        rows = self.rows
        action = self.actions[slot]
        used = self.used[slot]
        if used < 0:
            pre = self.pre[slot]
            if any(rows[p] & pre != pre for p in action.pre):
                return
            used = 0
            for atom in action.add:
                self.schedule(level + self.cost[slot], atom, self.add[slot])
        reachable = -1
        for atom in action.pre:
            reachable &= rows[atom]
        if reachable < 0:  # no precondition: every atom reached so far
            reachable = 0
            for atom, row in enumerate(rows):
                if row >> atom & 1:
                    reachable |= 1 << atom
        new = reachable & self.kept[slot] & ~used
        self.used[slot] = used | new
        if new:
            for atom in action.add:
                self.schedule(level + self.cost[slot], atom, new)


def _mask(atoms: Iterable[int]) -> int:
    mask = 0
    for atom in atoms:
        mask |= 1 << atom
    return mask
