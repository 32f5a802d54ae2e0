"""LLM-free heuristics, computed from the initial state once per action space.

Both are admissible and consistent for the backward search, so OBTEA ordered by ``g + h`` is A* and
stays optimal. A condition holding a literal that is unreachable even in the delete relaxation gets
``inf``: it is a dead end.

``hmax`` (Bonet & Geffner): the cost of the most expensive literal of a condition in the delete
relaxation. Consistent because every literal an action adds costs at most its cost plus its most
expensive precondition, and the preconditions are part of the regressed condition.

``lm`` (fact landmarks with a static cost partition): ``LM(l)`` is the set of atoms every relaxed
plan for ``l`` makes true (the usual fixpoint ``LM(l) = {l} ∪ ⋂_{a adds l} ⋃_{p ∈ pre(a)} LM(p)``).
Every plan reaching condition ``c`` must add each atom of ``L(c) = ⋃_{l ∈ c} LM(l) - s0``; each
action's cost is split evenly among its relevant add effects (atoms some precondition or the goal
needs), and ``cost(f)`` is the cheapest share of an achiever of ``f``. Then
``h(c) = ceil(Σ_{f ∈ L(c)} cost(f))`` is admissible (a plan pays each action at most once across its
shares; plan costs are whole numbers) and consistent, since ``L(c) ⊆ L(regress(c, a)) ∪ add(a)`` and
the shares of ``a`` add up to at most its cost. The combined heuristic is ``max(hmax, lm)``.

``lmcut``: ``max(hmax, lm, h², LM-cut)`` (:mod:`hbtp.planning.pairs`, :mod:`hbtp.planning.lmcut`), the
strongest and costliest. h² (the costliest pair of atoms, deletes included) is consistent, so it
joins the cheap part; it is left out on tasks with more atoms than
:data:`~hbtp.planning.pairs.MAX_ATOMS`. LM-cut is admissible but not consistent, so it is
:class:`Deferred`: the open list is ordered by ``max(hmax, lm, h²)`` and a condition's LM-cut is
computed when it is first taken off the list (it goes back with the higher value if LM-cut raises
it), and the search re-opens a condition it reaches again more cheaply, which keeps OBTEA optimal.

``seq``: ``lmcut`` and the state equation (:mod:`hbtp.planning.flow`), a linear program that counts
how often each action must run; its costly parts are the state equation, then LM-cut, evaluated
lazily by the search (LM-cut is not computed for a condition the state equation proves unreachable,
or puts beyond the priority at which it was taken off the list until it comes off again). It needs
HiGHS (the ``lp`` extra).
"""

from __future__ import annotations

import heapq
import math
from array import array
from collections.abc import Callable, Collection, Iterable, Iterator, Mapping, Sequence
from typing import Protocol, overload

from hbtp import compiled as extensions
from hbtp.deadline import Deadline
from hbtp.logic.relevance import relevant_to
from hbtp.logic.tables import TaskTable
from hbtp.logic.task import GroundAction, GroundTask
from hbtp.planning.flow import StateEquation
from hbtp.planning.heuristic_names import HeuristicName
from hbtp.planning.lmcut import LmCut
from hbtp.planning.pairs import COMPILED, PairCosts, cheap_kernel, pair_costs

_SETUP = "setting up the heuristic"


class Heuristic(Protocol):
    """An estimate of the cost of reaching a condition from s0 (``inf``: never)."""

    def __call__(self, condition: Iterable[int]) -> float: ...

    def precondition_bound(self, action: GroundAction) -> float:
        """A lower bound of the estimate of any condition that holds ``action``'s precondition (the
        search orders an atom's achievers by it; ``inf``: the precondition is a dead end)."""
        ...


def hmax_table(
    task: GroundTask,
    actions: Sequence[GroundAction],
    costs: Mapping[int, float] | None = None,
    deadline: Deadline | None = None,
) -> list[float]:
    """For each atom id, its h_max cost from s0 with ``actions`` (``inf`` if never reachable).

    ``costs`` overrides action costs by action index (the discounted costs of HBTP). Past
    ``deadline`` it raises :class:`~hbtp.deadline.TimeLimitReached`.
    """
    return _explore(task, actions, costs, deadline)[0]


def _consumers(task: GroundTask, actions: Sequence[GroundAction]) -> Sequence[Sequence[int]]:
    """For each atom id, the indices of the actions of ``actions`` whose precondition holds it (the
    task's own table, shared by every s0, when ``actions`` are all of them)."""
    if len(actions) == len(task.actions):
        return task.consumers
    users: list[list[int]] = [[] for _ in task.atoms]
    for action in actions:
        for atom in action.pre:
            users[atom].append(action.index)
    return users


def _explore(
    task: GroundTask,
    actions: Sequence[GroundAction],
    costs: Mapping[int, float] | None = None,
    deadline: Deadline | None = None,
    users: Sequence[Sequence[int]] | None = None,
) -> tuple[list[float], list[int]]:
    """:func:`hmax_table`, and the indices of the actions whose precondition became reachable, in
    the order it did (by increasing h_max of the precondition). ``users``: :func:`_consumers`, if
    the caller has it."""
    cost = [math.inf] * len(task.atoms)
    everything = task.actions
    waiting: dict[int, int] | list[int] = (
        [len(a.pre) for a in everything] if len(actions) == len(everything) else {a.index: len(a.pre) for a in actions}
    )
    if users is None:
        users = _consumers(task, actions)
    for atom in task.initial_state:
        cost[atom] = 0.0
    # Only the s0 atoms some action of the space needs are taken off the heap (the others would fire
    # nothing, and no action can reach one at less than 0); sorted, the list is already a heap.
    heap = [(0.0, atom) for atom in sorted(task.initial_state) if users[atom]]
    fired: list[int] = []

    def relax(action: GroundAction, pre_cost: float) -> None:
        fired.append(action.index)
        value = pre_cost + (costs[action.index] if costs is not None else action.cost)
        for atom in action.add:
            if value < cost[atom]:
                cost[atom] = value
                heapq.heappush(heap, (value, atom))

    for action in actions:
        if not action.pre:
            relax(action, 0.0)
    done = [False] * len(task.atoms)
    pops = 0
    while heap:
        value, atom = heapq.heappop(heap)
        pops += 1
        if deadline is not None and pops & 1023 == 0:
            deadline.check(_SETUP)
        if done[atom] or value > cost[atom]:
            continue
        done[atom] = True
        for index in users[atom]:
            waiting[index] -= 1
            if waiting[index] == 0:
                action = everything[index]
                relax(action, value)  # the last precondition reached is the costliest
    return cost, fired


def landmark_table(
    task: GroundTask,
    actions: Sequence[GroundAction],
    reachable: Sequence[float],
    deadline: Deadline | None = None,
    order: Sequence[int] | None = None,
    users: Sequence[Sequence[int]] | None = None,
) -> Landmarks:
    """For each atom id, its fact landmarks from s0 (``None`` when unreachable).

    The greatest fixpoint of ``LM(f) = {f} | ⋂ over the achievers a of f of ⋃ LM(pre(a))`` (``LM``
    of an s0 atom: itself), reached from "every atom" downwards: one pass over the usable actions
    in order of their h_max (``order``, the indices :func:`_explore` gives, saves sorting them),
    then only the actions whose precondition's landmarks changed. The sets are small (about five
    atoms in RobotHow at every size), so they are kept as frozensets: a union or an intersection
    costs what the sets hold, not what the world holds (as bit masks over every atom they took the
    square of the atoms in time and memory: 10 GB for RobotHow grown to 282,835 atoms). ``users``:
    :func:`_consumers`, if the caller has it."""
    table: list[frozenset[int] | None] = [None] * len(task.atoms)
    for atom in task.initial_state:
        table[atom] = frozenset((atom,))
    if order is None:
        usable = [a for a in actions if all(not math.isinf(reachable[p]) for p in a.pre)]
        usable.sort(key=lambda a: (max((reachable[p] for p in a.pre), default=0.0), a.index))
        order = [a.index for a in usable]
    if users is None:
        users = _consumers(task, actions)
    everything = task.actions
    queued = dict.fromkeys(order, True)
    pending = list(reversed(order))  # popped from the end: the first pass in order
    steps = 0
    empty: frozenset[int] = frozenset()
    while pending:
        index = pending.pop()
        queued[index] = False
        steps += 1
        if deadline is not None and steps & 255 == 0:
            deadline.check(_SETUP)
        action = everything[index]
        parts = []
        for p in action.pre:
            part = table[p]
            if part is None:
                break
            parts.append(part)
        else:
            needed = empty.union(*parts)
            for atom in action.add:
                old, new = table[atom], needed if atom in needed else needed | {atom}
                if old is None:
                    table[atom] = new
                elif not old <= new:
                    table[atom] = old & new
                else:
                    continue
                for user in users[atom]:
                    if queued.get(user) is False:
                        queued[user] = True
                        pending.append(user)
    return Landmarks(table)


class Landmarks(Sequence["frozenset[int] | None"]):
    """By atom id, its landmarks (``None``: unreachable), and the C kernel's form of them."""

    def __init__(self, sets: list[frozenset[int] | None]) -> None:
        self.sets = sets
        self.lists: tuple[bytes, bytes] | None = None

    @overload
    def __getitem__(self, index: int) -> frozenset[int] | None: ...

    @overload
    def __getitem__(self, index: slice) -> Sequence[frozenset[int] | None]: ...

    def __getitem__(self, index: int | slice) -> frozenset[int] | Sequence[frozenset[int] | None] | None:
        return self.sets[index]

    def __len__(self) -> int:
        return len(self.sets)

    def span_lists(self) -> tuple[bytes, bytes]:
        """Every atom's landmarks as the C kernel reads them (made once)."""
        if self.lists is None:
            self.lists = span_lists(self.sets)
        return self.lists


def span_lists(parts: Sequence[Collection[int] | None]) -> tuple[bytes, bytes]:
    """Per-atom sets of atoms as the C kernel reads them: ``spans``, int32 ``[begin, end)`` per atom
    into ``items`` (``begin`` -1 for ``None``), and ``items``, int32, each set's atoms lowest first."""
    spans, items = array("i"), array("i")
    for part in parts:
        if part is None:
            spans.extend((-1, -1))
        else:
            begin = len(items)
            items.extend(sorted(part))
            spans.extend((begin, len(items)))
    return spans.tobytes(), items.tobytes()


def landmark_costs(
    task: GroundTask,
    actions: Sequence[GroundAction],
    relevant: Collection[int],
    costs: Mapping[int, float] | None = None,
) -> list[float]:
    """``cost(f)``: the cheapest share of an achiever of ``f`` (an action's cost split evenly among its
    add effects that are ``relevant``: needed by some precondition or by the goal)."""
    share = [math.inf] * len(task.atoms)
    for action in actions:
        adds = [q for q in action.add if q in relevant]
        if not adds:
            continue
        value = (costs[action.index] if costs is not None else action.cost) / len(adds)
        for atom in adds:
            if value < share[atom]:
                share[atom] = value
    return share


#: The per-task tables of the heuristics: what holds for the whole action space is kept with the task.
_SHARES: TaskTable[tuple[frozenset[int], list[float]]] = TaskTable("landmark cost shares", state_free=True)
_FULL_PAIRS: TaskTable[PairCosts | None] = TaskTable("h² of the whole action space (None: too large)")
_FULL_LMCUT: TaskTable[LmCut] = TaskTable("LM-cut over the whole action space")


def _shares(task: GroundTask, actions: Sequence[GroundAction]) -> tuple[frozenset[int], list[float]]:
    """The atoms some precondition of ``actions`` holds, and :func:`landmark_costs` for them."""
    pre_atoms: frozenset[int] = frozenset().union(*(a.pre for a in actions)) if actions else frozenset()
    return pre_atoms, landmark_costs(task, actions, pre_atoms)


class SpaceAnalysis:
    """What the heuristics need from an action space, independent of the goal (cached)."""

    def __init__(self, task: GroundTask, actions: Sequence[GroundAction], deadline: Deadline | None = None) -> None:
        self.actions = actions
        users = _consumers(task, actions)
        self.hmax, order = _explore(task, actions, deadline=deadline, users=users)
        self.landmarks = landmark_table(task, actions, self.hmax, deadline, order, users)
        if len(actions) == len(task.actions):  # the same for every s0: kept for re-planning
            self.pre_atoms, self.shares = _SHARES.of(task, lambda: _shares(task, actions))
        else:
            self.pre_atoms, self.shares = _shares(task, actions)
        # For each action, the landmarks of its precondition that s0 lacks (None: a dead end),
        # computed when the search first asks (it asks for few of the actions).
        self.pre_landmarks = PreconditionLandmarks(task, actions, self.landmarks)


class PreconditionLandmarks(Mapping[int, "frozenset[int] | None"]):
    """By action index: the landmarks of the action's precondition that s0 lacks (``None``: a dead
    end), each computed when first asked for."""

    def __init__(
        self, task: GroundTask, actions: Sequence[GroundAction], landmarks: Sequence[frozenset[int] | None]
    ) -> None:
        self.task = task
        self.indices = frozenset(a.index for a in actions)
        self.landmarks = landmarks.sets if isinstance(landmarks, Landmarks) else landmarks
        self.known: dict[int, frozenset[int] | None] = {}

    def __getitem__(self, index: int) -> frozenset[int] | None:
        if index in self.known:
            return self.known[index]
        if index not in self.indices:
            raise KeyError(index)
        parts = [self.landmarks[p] for p in self.task.actions[index].pre]
        value: frozenset[int] | None = None
        if all(part is not None for part in parts):
            value = frozenset().union(*parts) - self.task.initial_state  # type: ignore[arg-type]
        self.known[index] = value
        return value

    def __iter__(self) -> Iterator[int]:
        return iter(sorted(self.indices))

    def __len__(self) -> int:
        return len(self.indices)


#: How many analyses of pruned action spaces a task keeps (the most recent ones): a planner comparison
#: searches one pruned space several times, and its analysis costs about as much as the search.
_RECENT_SPACES = 16
_FULL_ANALYSIS: TaskTable[SpaceAnalysis] = TaskTable("the analysis of the whole action space")
_RECENT_ANALYSES: TaskTable[dict[tuple[int, ...], SpaceAnalysis]] = TaskTable("analyses of recent pruned spaces")


def analyse_space(task: GroundTask, actions: Sequence[GroundAction], deadline: Deadline | None = None) -> SpaceAnalysis:
    """The analysis of ``actions`` in ``task``, kept with the task: the full space's, and the
    :data:`_RECENT_SPACES` most recent pruned spaces'.

    Past ``deadline`` it raises :class:`~hbtp.deadline.TimeLimitReached` (and keeps nothing)."""
    if len(actions) == len(task.actions):
        return _FULL_ANALYSIS.of(task, lambda: SpaceAnalysis(task, actions, deadline))
    recent = _RECENT_ANALYSES.of(task, dict)
    key = tuple(a.index for a in actions)
    analysis = recent.get(key)
    if analysis is None:
        analysis = SpaceAnalysis(task, actions, deadline)
        if len(recent) >= _RECENT_SPACES:
            recent.pop(next(iter(recent)))
        recent[key] = analysis
    return analysis


class HMax:
    """``max(hmax(l) for l in c)`` over a table of atom costs."""

    def __init__(self, table: Sequence[float]) -> None:
        self.table = table

    def __call__(self, condition: Iterable[int]) -> float:
        table = self.table
        return max((table[a] for a in condition), default=0.0)

    def precondition_bound(self, action: GroundAction) -> float:
        return self(action.pre)


class LandmarkSum:
    """``max(hmax, ceil(Σ cost(f) for f in L(c)))`` (see the module docstring); ``hmax`` may be omitted.

    ``pre_landmarks`` holds, by action index, the landmarks of each action's precondition that s0
    lacks (``None``: a dead end), as :class:`SpaceAnalysis` computes them. ``compiled``: after
    :data:`~hbtp.compiled.WARM_UP` conditions, answer in C (where the extension is built).
    """

    def __init__(
        self,
        landmarks: Sequence[frozenset[int] | None],
        share: Sequence[float],
        initial_state: frozenset[int],
        pre_landmarks: Mapping[int, frozenset[int] | None],
        hmax: Sequence[float] | None = None,
        compiled: bool = COMPILED,
    ) -> None:
        self.landmarks = landmarks
        # The plain list behind a Landmarks table: read per condition, indexing it is most of the cost.
        self.sets: Sequence[frozenset[int] | None] = landmarks.sets if isinstance(landmarks, Landmarks) else landmarks
        self.share = share
        self.initial_state = initial_state
        self.pre_landmarks = pre_landmarks
        self.hmax = hmax
        self.kernel = cheap_kernel(compiled)
        self.tables: tuple[bytes, bytes, bytes, bytearray, bytes | None] | None = None  # the C kernel's
        self.calls = 0

    def __call__(self, condition: Iterable[int]) -> float:
        if self.tables is not None:
            return float(self.kernel.landmark_sum(self.tables, condition))  # type: ignore[union-attr]
        self.calls += 1
        if self.calls > extensions.WARM_UP and self.kernel is not None:
            self.tables = self.compiled_tables()
        parts = [self.sets[atom] for atom in condition]
        if not parts:
            return 0.0
        if None in parts:
            return math.inf
        needed = frozenset().union(*parts) - self.initial_state  # type: ignore[arg-type]
        total = float(math.ceil(sum(map(self.share.__getitem__, needed)) - 1e-9))
        if self.hmax is not None:
            return max(total, max(map(self.hmax.__getitem__, condition)))
        return total

    def compiled_tables(self) -> tuple[bytes, bytes, bytes, bytearray, bytes | None]:
        """What the C kernel reads: the landmarks' spans and atoms, the shares (0 in s0), its scratch
        marks and the h_max table."""
        landmarks = self.landmarks
        spans, atoms = landmarks.span_lists() if isinstance(landmarks, Landmarks) else span_lists(landmarks)
        s0 = self.initial_state
        share = array("d", (0.0 if f in s0 else float(value) for f, value in enumerate(self.share))).tobytes()
        hmax = None if self.hmax is None else array("d", self.hmax).tobytes()
        return spans, atoms, share, bytearray(4 * (len(landmarks) + 1)), hmax

    def precondition_bound(self, action: GroundAction) -> float:
        """The landmark part of the estimate for ``action``'s precondition (an action of the space)."""
        landmarks = self.pre_landmarks[action.index]
        if landmarks is None:
            return math.inf
        share = self.share
        return float(math.ceil(sum(share[f] for f in landmarks) - 1e-9))


class Deferred:
    """A cheap consistent heuristic that orders the open list, and costly admissible ones that the
    search evaluates one at a time when it takes a condition off the list (see the module
    docstring): the heuristic's value is the largest of them all. The search re-opens conditions
    under it."""

    def __init__(self, cheap: Heuristic, *costly: Callable[[frozenset[int]], float]) -> None:
        if not costly:
            raise ValueError("a deferred heuristic needs a costly part")
        self.cheap = cheap
        self.costly = costly

    def __call__(self, condition: Iterable[int]) -> float:
        return self.cheap(condition)

    def precondition_bound(self, action: GroundAction) -> float:
        return self.cheap.precondition_bound(action)

    def refine(self, condition: frozenset[int]) -> float:
        """The largest costly estimate of ``condition`` (the search already holds the cheap one, a
        condition's priority, so only these are computed; one that is ``inf`` ends the others)."""
        best = 0.0
        for part in self.costly:
            best = max(best, part(condition))
            if math.isinf(best):
                break
        return best


def build_heuristic(
    name: HeuristicName,
    task: GroundTask,
    actions: Sequence[GroundAction],
    goal: Collection[int],
    *,
    scale: float = 1.0,
    discounts: Mapping[int, float] | None = None,
    deadline: Deadline | None = None,
) -> Heuristic | None:
    """The heuristic ``name`` (``none``, ``hmax``, ``lm``, ``lmcut``) for this action space.

    Action costs are multiplied by ``scale``, and the actions in ``discounts`` (by index) cost what
    it says instead: the step costs of HBTP. With changed costs, ``lm`` uses the landmark sum alone
    (still admissible and consistent for those costs) and ``hmax`` is recomputed. Past ``deadline``
    it raises :class:`~hbtp.deadline.TimeLimitReached`.
    """
    if name == HeuristicName.NONE:
        return None
    analysis = analyse_space(task, actions, deadline)
    discounts = discounts or {}
    plain = scale == 1.0 and not discounts
    if name == HeuristicName.HMAX:
        if plain:
            return HMax(analysis.hmax)
        costs = {a.index: discounts.get(a.index, a.cost * scale) for a in actions}
        return HMax(hmax_table(task, actions, costs, deadline))
    # Shares: cached for the space (relevant = atoms some precondition needs), scaled, then patched
    # for goal atoms no precondition needs and for discounted actions (their values only go down).
    share = list(analysis.shares) if scale == 1.0 else [x * scale for x in analysis.shares]
    relevant = analysis.pre_atoms | frozenset(goal)
    in_space = None if len(actions) == len(task.actions) else {a.index for a in actions}
    affected = set(discounts)
    for atom in frozenset(goal) - analysis.pre_atoms:
        affected.update(i for i in task.achievers[atom] if in_space is None or i in in_space)
    for index in sorted(affected):
        action = task.actions[index]
        adds = [q for q in action.add if q in relevant]
        if adds:
            value = discounts.get(index, action.cost * scale) / len(adds)
            for atom in adds:
                if value < share[atom]:
                    share[atom] = value
    hmax = analysis.hmax if plain else None
    cheap = LandmarkSum(analysis.landmarks, share, task.initial_state, analysis.pre_landmarks, hmax)
    if name == HeuristicName.LM:
        return cheap
    step_cost = None if plain else (lambda a: discounts.get(a.index, a.cost * scale))
    return _deferred(name, task, actions, goal, cheap, step_cost, deadline)


def _deferred(
    name: HeuristicName,
    task: GroundTask,
    actions: Sequence[GroundAction],
    goal: Collection[int],
    cheap: Heuristic,
    step_cost: Callable[[GroundAction], float] | None,
    deadline: Deadline | None,
) -> Heuristic:
    """``lmcut`` or ``seq`` over ``cheap`` (``step_cost``: the changed action costs, if any)."""
    space = _lmcut_space(task, actions, goal)
    plain = step_cost is None
    changed = None if step_cost is None else {a.index: step_cost(a) for a in space}
    if plain and len(actions) == len(task.actions):  # the whole space's h², kept with the task for every goal
        pairs = _FULL_PAIRS.of(task, lambda: pair_costs(task, actions, None, deadline))
    else:
        pairs = pair_costs(task, space, changed, deadline)
    if plain and len(space) == len(task.actions):  # kept with the task: its table serves every goal
        lmcut = _FULL_LMCUT.of(task, lambda: LmCut(task, space, None, deadline))
    else:
        lmcut = LmCut(task, space, changed, deadline)
    if name == HeuristicName.LMCUT:
        return Deferred(_with_pairs(cheap, pairs), lmcut)
    equation = StateEquation(task, space, pairs, changed, deadline)
    return Deferred(_with_pairs(cheap, pairs), equation, lmcut)


def _with_pairs(cheap: Heuristic, pairs: PairCosts | None) -> Heuristic:
    """The larger of ``cheap`` and h² (both consistent, so their maximum is), or ``cheap`` alone for a
    task too large for h²."""
    return cheap if pairs is None else Larger(cheap, pairs)


class Larger:
    """The larger of two heuristics' estimates."""

    def __init__(self, first: Heuristic, second: Heuristic) -> None:
        self.first = first
        self.second = second

    def __call__(self, condition: Iterable[int]) -> float:
        atoms = condition if isinstance(condition, (frozenset, set, list, tuple)) else list(condition)
        return max(self.first(atoms), self.second(atoms))

    def precondition_bound(self, action: GroundAction) -> float:
        return max(self.first.precondition_bound(action), self.second.precondition_bound(action))


def _lmcut_space(task: GroundTask, actions: Sequence[GroundAction], goal: Collection[int]) -> Sequence[GroundAction]:
    """The actions LM-cut reads for a search of ``goal``. On a condition made of the goal's atoms and
    the preconditions of their achievers, LM-cut reads only the actions relevant to the goal (h_max,
    zones and cuts stay among them): the others give the same values and only cost time. When they
    are few, the whole space's LM-cut, kept with the task for every goal, is cheaper than a new one."""
    relevant = relevant_to(task, goal)
    space = [a for a in actions if a.index in relevant]
    return actions if len(space) * 4 > len(actions) * 3 else space
