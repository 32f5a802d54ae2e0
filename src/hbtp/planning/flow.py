"""The state equation (Bonet, 2013) from s0 to a regressed condition, as a linear program.

A plan from s0 to a state that holds a condition ``c`` applies each action ``a`` some number of times
``Y_a``. Each application changes each atom ``f`` by a known amount, or within a known range:

- ``f`` added and not a precondition: +1 when ``f`` is false wherever ``a`` applies (it forms an h²
  mutex with a precondition), else 0 or +1;
- ``f`` deleted and not added: -1 when ``f`` is a precondition, 0 when it forms an h² mutex with one
  (it is false already), else -1 or 0;
- any other atom: 0.

So ``f`` ends at ``s0(f)`` plus the sum of its changes, and that value must lie in what ``c`` allows:
exactly 1 for an atom of ``c``, 0 for an atom that forms an h² mutex with an atom of ``c`` (no reachable
state holds both), 0 or 1 otherwise. The cheapest ``Y >= 0`` (as real numbers) that satisfies every
atom costs at most the plan, so it is an admissible estimate of reaching ``c``; no such ``Y`` means
no plan reaches ``c`` (``inf``). Unlike the delete relaxation it counts: a condition in which a lift
carries one passenger by its counter and two by the passengers boarded has no solution, nor does one
that needs more packages delivered than were picked up. Those are the spurious conditions of
regression that no pair of atoms reveals.

Each condition only changes the rows' bounds (read from per-atom tables made once), so one program
per action space serves every condition, each solve starting from the previous one's basis. It is
solved by hbtp's own dual simplex in C (:mod:`hbtp.planning._simplex`, optional like the other
extensions), which keeps the basis inverse dense: a solve takes a few microseconds where HiGHS, with
its fixed cost of about 100 µs, takes hundreds (depot p03: 10 against 315 µs, the same values). A
program of more than :data:`DENSE_ROWS` rows, a solve the simplex gives up on (numerical trouble,
or too many pivots), and an install without the extension use HiGHS (the ``lp`` extra,
``highspy``), on one thread. With whole action costs the estimate is rounded up (plan costs are
whole numbers).

A condition proved unreachable leaves a *core*: the atoms of it that set the bounds of the rows its
proof of infeasibility (the solver's dual ray, a Farkas certificate) combines. The same proof holds
for every condition that contains the core, which is answered ``inf`` without the solver (on
elevators and transport, a third to a half of the conditions the search asks about). A core is kept
only once the solver has confirmed it unreachable on its own; otherwise the whole condition is kept.
"""

from __future__ import annotations

import math
import os
import sys
from collections.abc import Iterable, Mapping, Sequence
from typing import Any

from hbtp import compiled as extensions
from hbtp.deadline import Deadline
from hbtp.errors import InputError
from hbtp.logic.subsets import SubsetIndex
from hbtp.logic.task import GroundAction, GroundTask
from hbtp.planning.pairs import PairCosts, mask_bytes

_INSTALL = "the state-equation heuristic (seq) needs HiGHS: pip install 'hbtp[lp]' (highspy)"
_SETUP = "setting up the state equation"
#: Slack for the solver's rounding when whole costs are rounded up.
_EPSILON = 1e-6
#: A row takes part in a proof of infeasibility when its multiplier in the dual ray is above this.
_RAY_EPSILON = 1e-9
#: The largest program (in rows) given to the dual simplex in C: its basis inverse is dense (m² doubles).
DENSE_ROWS = 1000

_EXTENSION = extensions.SIMPLEX
_compiled = extensions.extension(_EXTENSION)

#: Whether the state equation's programs are solved in C (the optional extension is built).
COMPILED = _compiled is not None
_OPTIMAL, _INFEASIBLE = 0, 1  # the C simplex's statuses (2: it gave up)


class StateEquation:
    """``h^SEQ(s0 → c)`` over an action space (costs by action index may be overridden), using the h²
    mutexes of ``pairs`` (without them every atom outside ``c`` may end either way). ``compiled``:
    solve with the dual simplex in C (where the extension is built: :data:`COMPILED`), else HiGHS."""

    def __init__(
        self,
        task: GroundTask,
        actions: Sequence[GroundAction],
        pairs: PairCosts | None,
        costs: Mapping[int, float] | None = None,
        deadline: Deadline | None = None,
        compiled: bool = COMPILED,
    ) -> None:
        import numpy as np

        self._np = np
        count = len(task.atoms)
        self.together = _reachable_pairs(pairs, count)
        cost = [float(costs[a.index] if costs is not None else a.cost) for a in actions]
        self.whole = all(c.is_integer() for c in cost)
        low, high = _changes(actions, count, self.together)
        if deadline is not None:
            deadline.check(_SETUP)
        s0 = np.zeros(count)
        s0[list(task.initial_state)] = 1.0
        self.highs, rows, matrix = _model(np, low, high, cost)
        kernel = extensions.kernel(
            _compiled, _EXTENSION, compiled=compiled, slower="the state equation", instead="is solved by HiGHS"
        )
        #: The program in the C simplex (None: HiGHS solves every condition).
        self.program = None if kernel is None or len(rows.atom) > DENSE_ROWS else kernel.Program(*matrix)
        self.proof_in_c = False  # whether the last proof of infeasibility came from the C simplex
        self.status = _solver().HighsModelStatus
        # What a condition changes is precomputed per atom, so a call only indexes small arrays.
        static = [f for f in range(count) if not low[f] and not high[f]]
        self.impossible = _impossible(np, static, s0, self.together)
        start = s0[rows.atom]
        #: Each row's bounds when the condition holds no atom and allows every atom.
        self.lower_base = np.where(rows.has_lower, -start, -np.inf)
        self.upper_base = np.where(rows.has_upper, 1.0 - start, np.inf)
        #: Per atom, the row its final value bounds from below (-1: none).
        self.lower_row = np.full(count, -1, dtype=np.int64)
        self.lower_row[rows.atom[rows.has_lower]] = np.flatnonzero(rows.has_lower)
        #: ``allowed[p, r]``: whether a reachable state may hold ``p`` with row ``r``'s atom true.
        self.allowed = None if self.together is None else self.together[:, rows.atom]
        self.index = rows.index
        #: The cores of the conditions proved unreachable (see the module docstring).
        self.cores = SubsetIndex()
        #: How many conditions a stored core answered.
        self.answered_by_core = 0

    def __call__(self, condition: Iterable[int]) -> float:
        atoms = condition if isinstance(condition, frozenset) else frozenset(condition)
        if not self.impossible.isdisjoint(atoms):
            return math.inf
        if self.cores.has_subset(atoms):
            self.answered_by_core += 1
            return math.inf
        value = self._solve(atoms)
        if math.isinf(value):
            self.cores.add(self._core(atoms))
        return value

    def _solve(self, atoms: frozenset[int]) -> float:
        np = self._np
        listed = list(atoms)
        row_lower = self.lower_base.copy()
        hits = self.lower_row[listed]
        row_lower[hits[hits >= 0]] += 1.0
        if self.allowed is None:
            row_upper = self.upper_base
        else:  # an atom that forms an h² mutex with an atom of the condition ends false
            row_upper = self.upper_base - ~np.logical_and.reduce(self.allowed[listed], axis=0)
        self.proof_in_c = False
        if self.program is not None:
            status, value = self.program.solve(row_lower, row_upper)
            if status == _INFEASIBLE:
                self.proof_in_c = True
                return math.inf
            if status == _OPTIMAL:
                return self._rounded(value)
        highs = self.highs
        highs.changeRowsBounds(len(self.index), self.index, row_lower, row_upper)
        highs.run()
        status = highs.getModelStatus()
        if status == self.status.kInfeasible:
            return math.inf
        if status != self.status.kOptimal:  # the solver gave up: no information, which is admissible
            return 0.0
        return self._rounded(float(highs.getObjectiveValue()))

    def _rounded(self, value: float) -> float:
        value = max(0.0, value)
        return float(math.ceil(value - _EPSILON)) if self.whole else value

    def _ray(self) -> Any:
        """The row multipliers of the last proof of infeasibility (None: the solver found none)."""
        np = self._np
        if self.proof_in_c:
            assert self.program is not None
            return np.frombuffer(self.program.ray(), dtype=float)
        *_status, found, ray = self.highs.getDualRay()  # (status,) found, ray: the form varies by version
        return np.asarray(ray) if found else None

    def _core(self, atoms: frozenset[int]) -> frozenset[int]:
        """The atoms of ``atoms`` (just proved unreachable) that its proof uses: for each row of the
        dual ray, the atom that raised its lower bound and the first that lowered its upper bound
        (an h² mutex). Kept when the solver proves it unreachable too; else ``atoms`` itself."""
        np = self._np
        ray = self._ray()
        if ray is None:
            return atoms
        used = np.abs(ray) > _RAY_EPSILON
        listed = sorted(atoms)
        rows = self.lower_row[listed]
        core = {p for p, r in zip(listed, rows.tolist(), strict=True) if r >= 0 and used[r]}
        if self.allowed is not None:
            blocked = ~self.allowed[listed][:, used]  # [condition's atom, used row]: a mutex
            lowered = blocked.any(axis=0)
            core.update(listed[i] for i in blocked.argmax(axis=0)[lowered].tolist())
        smaller = frozenset(core)
        if smaller != atoms and not math.isinf(self._solve(smaller)):
            return atoms
        return smaller


def _impossible(np: Any, static: list[int], s0: Any, together: Any) -> frozenset[int]:
    """The atoms no reachable condition holds, judged by the atoms no action changes: a static atom
    false in s0, and an atom that forms an h² mutex with a static atom true in s0."""
    found = {f for f in static if not s0[f]}
    true = [f for f in static if s0[f]]
    if together is not None and true:
        found.update(np.flatnonzero(~np.logical_and.reduce(together[:, true], axis=1)).tolist())
    return frozenset(found)


def _reachable_pairs(pairs: PairCosts | None, count: int) -> Any:
    """``together[p, q]``: whether some reachable state may hold ``p`` and ``q`` (a numpy bool matrix;
    ``None`` without h²)."""
    if pairs is None:
        return None
    import numpy as np

    size = (count + 7) // 8
    rows = b"".join(mask_bytes(history[-1][1] if history else 0, count) for history in pairs.history)
    bits = np.unpackbits(np.frombuffer(rows, dtype=np.uint8).reshape(count, size), axis=1, bitorder="little")
    return bits[:, :count].astype(bool)


def _changes(
    actions: Sequence[GroundAction], count: int, together: Any
) -> tuple[list[dict[int, int]], list[dict[int, int]]]:
    """Per atom, the least and the most each action (by its slot) changes it by (only the nonzero)."""
    low: list[dict[int, int]] = [{} for _ in range(count)]
    high: list[dict[int, int]] = [{} for _ in range(count)]

    def false_before(atom: int, action: GroundAction) -> bool:
        return together is not None and any(not together[atom, p] for p in action.pre)

    for slot, action in enumerate(actions):
        for atom in action.add - action.pre:
            high[atom][slot] = 1
            if false_before(atom, action):
                low[atom][slot] = 1
        for atom in action.delete - action.add:
            if atom in action.pre:
                low[atom][slot] = high[atom][slot] = -1
            elif not false_before(atom, action):
                low[atom][slot] = -1
    return low, high


class _Rows:
    """The program's rows: the atom of each, and which of its bounds it carries."""

    def __init__(self, np: Any, atom: list[int], has_lower: list[bool], has_upper: list[bool]) -> None:
        self.atom = np.array(atom, dtype=np.int64)
        self.has_lower = np.array(has_lower, dtype=bool)
        self.has_upper = np.array(has_upper, dtype=bool)
        self.index = np.arange(len(atom), dtype=np.int32)


def _model(
    np: Any, low: list[dict[int, int]], high: list[dict[int, int]], cost: list[float]
) -> tuple[Any, _Rows, tuple[Any, ...]]:
    """The HiGHS model: one column per action (its count), and per changed atom one row (``low ==
    high``: its change is known) or two (the least change bounds the final value from above, the
    most from below). Also the arguments of the C simplex's program: the same columns."""
    highspy = _solver()
    columns: list[list[tuple[int, float]]] = [[] for _ in cost]
    atoms: list[int] = []
    has_lower: list[bool] = []
    has_upper: list[bool] = []

    def row(atom: int, coefficients: dict[int, int], lower: bool, upper: bool) -> None:
        for slot, value in coefficients.items():
            columns[slot].append((len(atoms), float(value)))
        atoms.append(atom)
        has_lower.append(lower)
        has_upper.append(upper)

    for atom, (least, most) in enumerate(zip(low, high, strict=True)):
        if least == most:
            if least:
                row(atom, least, True, True)
        else:
            row(atom, least, False, True)
            row(atom, most, True, False)
    lp = highspy.HighsLp()
    lp.num_col_ = len(cost)
    lp.num_row_ = len(atoms)
    lp.col_cost_ = np.array(cost, dtype=float)
    lp.col_lower_ = np.zeros(len(cost))
    lp.col_upper_ = np.full(len(cost), highspy.kHighsInf)
    lp.row_lower_ = np.full(len(atoms), -highspy.kHighsInf)
    lp.row_upper_ = np.full(len(atoms), highspy.kHighsInf)
    lp.a_matrix_.format_ = highspy.MatrixFormat.kColwise
    start = np.cumsum([0, *map(len, columns)]).astype(np.int32)
    index = np.array([r for column in columns for r, _ in column], dtype=np.int32)
    value = np.array([v for column in columns for _, v in column], dtype=float)
    lp.a_matrix_.start_, lp.a_matrix_.index_, lp.a_matrix_.value_ = start, index, value
    highs = _new_solver(highspy)
    highs.setOptionValue("output_flag", False)
    # One thread halves the solver's fixed cost per run (its task scheduler). That scheduler is global
    # to the process: if another part of it started HiGHS with more threads, keep its setting.
    highs.setOptionValue("threads", 1)
    highs.passModel(lp)
    if highs.run() == highspy.HighsStatus.kError:
        highs.setOptionValue("threads", 0)
    program = (
        len(cost),
        len(atoms),
        start.tobytes(),
        index.tobytes(),
        value.tobytes(),
        np.array(cost, dtype=float).tobytes(),
    )
    return highs, _Rows(np, atoms, has_lower, has_upper), program


def require_solver() -> None:
    """Check that HiGHS can be imported (:class:`~hbtp.errors.InputError` saying how to install it)."""
    _solver()


def _solver() -> Any:
    """The ``highspy`` module, or an error that says how to install it."""
    try:
        import highspy
    except ImportError:
        raise InputError(_INSTALL) from None
    return highspy


def _new_solver(highspy: Any) -> Any:
    """A new HiGHS solver, made with standard output closed: the first one of a process prints
    HiGHS's banner there (closing it every time keeps no state of our own; solvers are few)."""
    sys.stdout.flush()
    saved = os.dup(1)
    null = os.open(os.devnull, os.O_WRONLY)
    try:
        os.dup2(null, 1)
        return highspy.Highs()
    finally:
        os.dup2(saved, 1)
        os.close(saved)
        os.close(null)
