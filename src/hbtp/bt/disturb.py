"""Execution under perturbations: seeded random external events, and robustness statistics.

Before each tick, with probability ``p``, an external event changes the state. Events are derived
from the action models alone (no predicate names), in three kinds chosen uniformly among those
possible:

* ``undo``: flip one literal that the last action changed: re-add a literal it deleted (that held
  before it) or delete a literal it added;
* ``make-true``: make true an atom that some action can add;
* ``make-false``: make false an atom that holds and that some action deletes.

Every event is then closed under the domain's invariants, so the state stays consistent:

* making ``x`` true removes the atoms that are mutex with ``x`` (:attr:`Mutexes.partners`): moving
  an object somewhere removes it from where it was;
* *exactly-one* groups stay filled: a mutex group that holds exactly one atom in s0 and whose every
  deleting action adds another group atom holds exactly one atom in every reachable state (an
  induction over the actions, like the mutex proof). When an event empties such a group, the
  state gets a replacement: an atom of the group that an action deleting the lost atom adds
  (closing what was opened, say), chosen at random;
* an event that would break a declared nogood, or that changes nothing, is drawn again (up to
  ``max_attempts`` times, then the tick passes undisturbed).

Everything is driven by one seeded :class:`random.Random` per run, so the runs are deterministic.
"""

from __future__ import annotations

import logging
import random
import statistics
from collections.abc import Sequence
from dataclasses import dataclass, field
from typing import Any

from hbtp.bt.nodes import Node
from hbtp.bt.simulate import DEFAULT_MAX_TICKS, compile_tree, simulate
from hbtp.domains.mutex import Mutexes
from hbtp.errors import InputError
from hbtp.logic.execution import Event, Run
from hbtp.logic.tables import TaskTable
from hbtp.logic.task import Goal, GoalIds, GroundTask, State

log = logging.getLogger(__name__)

KINDS = ("undo", "make-true", "make-false")
MAX_ATTEMPTS = 20


@dataclass
class EventModel:
    """What events a task allows: built once per task and mutexes (see :func:`event_model`)."""

    task: GroundTask
    mutexes: Mutexes
    addable: tuple[int, ...]
    deletable: frozenset[int]
    exactly_one: dict[int, tuple[frozenset[int], ...]]  # atom -> the exactly-one groups it is in
    deleters: dict[int, tuple[int, ...]]  # atom -> actions deleting it
    _repairs: dict[tuple[int, frozenset[int]], tuple[int, ...]] = field(default_factory=dict)

    @classmethod
    def build(cls, task: GroundTask, mutexes: Mutexes) -> EventModel:
        if mutexes.atom_count != len(task.atoms):
            raise InputError(f"the mutexes have {mutexes.atom_count} atoms, task {task.name!r} has {len(task.atoms)}")
        addable: set[int] = set()
        deleters: dict[int, list[int]] = {}
        for action in task.actions:
            addable |= action.add
            for atom in action.delete:
                deleters.setdefault(atom, []).append(action.index)
        groups = exactly_one_groups(task, mutexes)
        by_atom: dict[int, list[frozenset[int]]] = {}
        for group in groups:
            for atom in group:
                by_atom.setdefault(atom, []).append(group)
        return cls(
            task,
            mutexes,
            tuple(sorted(addable)),
            frozenset(deleters),
            {atom: tuple(gs) for atom, gs in by_atom.items()},
            {atom: tuple(ids) for atom, ids in deleters.items()},
        )

    def repairs(self, lost: int, group: frozenset[int]) -> tuple[int, ...]:
        """Atoms of ``group`` that an action deleting ``lost`` adds (else the whole group), sorted."""
        key = (lost, group)
        found = self._repairs.get(key)
        if found is None:
            actions = self.task.actions
            direct = {atom for i in self.deleters.get(lost, ()) for atom in actions[i].add & group} - {lost}
            found = tuple(sorted(direct or (group - {lost})))
            self._repairs[key] = found
        return found


def exactly_one_groups(task: GroundTask, mutexes: Mutexes) -> tuple[frozenset[int], ...]:
    """The mutex groups that hold exactly one atom in every reachable state.

    Proof by induction: s0 holds exactly one atom of the group, at most one holds anywhere (the
    group is a mutex group), and every action that deletes a group atom adds one.
    """
    result: list[frozenset[int]] = []
    for group in mutexes.groups:
        if len(group.atoms & task.initial_state) != 1:
            continue
        if all(action.add & group.atoms for action in task.actions if action.delete & group.atoms):
            result.append(group.atoms)
    return tuple(result)


_EVENTS: TaskTable[EventModel] = TaskTable("the disturbance model (keyed by the mutexes)")


def event_model(task: GroundTask, mutexes: Mutexes) -> EventModel:
    """The :class:`EventModel` of a task and its mutexes, kept with the task."""
    return _EVENTS.of(task, lambda: EventModel.build(task, mutexes), key=mutexes)


class RandomDisturbance:
    """A :class:`hbtp.logic.execution.Disturbance`: with probability ``p`` per tick, a random event."""

    def __init__(
        self,
        model: EventModel,
        p: float,
        rng: random.Random,
        *,
        kinds: Sequence[str] = KINDS,
        max_attempts: int = MAX_ATTEMPTS,
    ) -> None:
        check_probability(p)
        unknown = [k for k in kinds if k not in KINDS]
        if unknown or not kinds:
            raise InputError(f"unknown event kind(s) {unknown or '(none)'}; choose from {', '.join(KINDS)}")
        self.model = model
        self.p = p
        self.rng = rng
        self.kinds = tuple(kinds)
        self.max_attempts = max_attempts

    def __call__(self, tick: int, state: State, last_action: int | None, before_last: State | None) -> Event | None:
        if self.p <= 0 or self.rng.random() >= self.p:
            return None
        for _ in range(self.max_attempts):
            event = self.draw(state, last_action, before_last)
            if event is not None:
                return event
        log.debug("tick %d: no consistent event found in %d attempts", tick, self.max_attempts)
        return None

    def draw(self, state: State, last_action: int | None, before_last: State | None) -> Event | None:
        """One attempt: a kind, a target, the closed event (``None`` when it is not acceptable)."""
        model = self.model
        rng = self.rng
        undo = self._undo_options(state, last_action, before_last) if "undo" in self.kinds else []
        falsifiable = sorted(state & model.deletable) if "make-false" in self.kinds else []
        available = [
            kind
            for kind, possible in (("undo", undo), ("make-true", model.addable), ("make-false", falsifiable))
            if kind in self.kinds and possible
        ]
        if not available:
            return None
        kind = rng.choice(available)
        if kind == "undo":
            atom, make_true = rng.choice(undo)
            return self.close(kind, state, {atom} if make_true else set(), set() if make_true else {atom})
        if kind == "make-true":
            atom = rng.choice(model.addable)
            if atom in state:
                return None
            return self.close(kind, state, {atom}, set())
        atom = rng.choice(falsifiable)
        return self.close(kind, state, set(), {atom})

    def _undo_options(self, state: State, last_action: int | None, before_last: State | None) -> list[tuple[int, bool]]:
        if last_action is None:
            return []
        action = self.model.task.actions[last_action]
        deleted = action.delete if before_last is None else action.delete & before_last
        added = action.add if before_last is None else action.add - before_last
        options = [(atom, True) for atom in sorted(deleted) if atom not in state]
        options += [(atom, False) for atom in sorted(added) if atom in state]
        return options

    def close(self, kind: str, state: State, add: set[int], remove: set[int]) -> Event | None:
        """The event that makes ``add`` true and ``remove`` false, closed under the invariants."""
        model = self.model
        partners = model.mutexes.partners
        new = set(state) - remove
        for atom in add:
            new -= partners[atom]
        new |= add
        lost = sorted(state - new)
        for atom in lost:
            for group in model.exactly_one.get(atom, ()):
                if group & new:
                    continue
                options = [z for z in model.repairs(atom, group) if z not in remove and not partners[z] & new]
                if not options:
                    return None
                new.add(self.rng.choice(options))
        result = frozenset(new)
        if result == state or model.mutexes.conflict(result) is not None:
            return None
        return Event(kind, result - state, state - result)


def check_probability(p: float) -> None:
    if not 0.0 <= p <= 1.0:
        raise InputError(f"the perturbation probability must be in [0, 1], not {p}")


def run_seed(seed: int, index: int) -> str:
    """The seed of run ``index``: a string, so that :class:`random.Random` hashes it the same way
    in every process."""
    return f"hbtp-disturb/{seed}/{index}"


def seeded_disturbances(
    task: GroundTask, mutexes: Mutexes, p: float, runs: int, seed: int = 0, kinds: Sequence[str] = KINDS
) -> list[RandomDisturbance]:
    """The disturbances of ``runs`` runs: run ``i`` draws from ``random.Random(run_seed(seed, i))``,
    so every engine and configuration run with the same seed meets the same random numbers."""
    check_probability(p)
    if runs < 0:
        raise InputError(f"the number of runs must not be negative, not {runs}")
    model = event_model(task, mutexes)
    return [RandomDisturbance(model, p, random.Random(run_seed(seed, i)), kinds=kinds) for i in range(runs)]


def disturbed_runs(
    tree: Node,
    task: GroundTask,
    mutexes: Mutexes,
    p: float,
    runs: int,
    seed: int = 0,
    *,
    max_ticks: int = DEFAULT_MAX_TICKS,
    state: State | None = None,
    trace: bool = False,
    kinds: Sequence[str] = KINDS,
) -> list[Run]:
    """``runs`` seeded runs of ``tree`` under perturbations of probability ``p`` per tick.

    Run ``i`` draws its events from ``random.Random(run_seed(seed, i))``, so two trees run with
    the same seed meet the same random numbers (not necessarily the same events: the events
    depend on the state).
    """
    policy = compile_tree(tree, task)
    return [
        simulate(tree, task, state, max_ticks=max_ticks, disturbance=disturbance, trace=trace, policy=policy)
        for disturbance in seeded_disturbances(task, mutexes, p, runs, seed, kinds)
    ]


def _mean(values: Sequence[float]) -> float | None:
    return round(statistics.fmean(values), 6) if values else None


def perturbation_stats(
    tree: Node,
    task: GroundTask,
    goal: GoalIds,
    mutexes: Mutexes,
    p: float,
    runs: int,
    seed: int = 0,
    max_ticks: int = DEFAULT_MAX_TICKS,
) -> dict[str, Any]:
    """Robustness of ``tree`` from s0 under perturbations (see :func:`disturbed_runs`).

    A run succeeds when the root returns SUCCESS and the goal holds. ``success_rate`` is over all
    runs; ``mean_ticks``, ``mean_cost`` and the ``mean_extra_*`` figures (minus the undisturbed
    run's ticks and cost) are over the successful runs (``None`` when none succeeded, and the
    extras also when the undisturbed run fails). ``mean_events`` is the mean number of events per
    run.
    """
    goal = goal if isinstance(goal, Goal) else frozenset(goal)
    base = simulate(tree, task, max_ticks=max_ticks)
    results = disturbed_runs(tree, task, mutexes, p, runs, seed, max_ticks=max_ticks)
    return {"p": p, "seed": seed, **summarise_runs(base, results, goal)}


def summarise_runs(base: Run, results: Sequence[Run], goal: GoalIds) -> dict[str, Any]:
    """The figures of :func:`perturbation_stats` for an undisturbed run and disturbed runs."""
    base_ok = base.reached(goal)
    good = [run for run in results if run.reached(goal)]
    return {
        "runs": len(results),
        "successes": len(good),
        "success_rate": round(len(good) / len(results), 6) if results else None,
        "mean_ticks": _mean([run.ticks for run in good]),
        "mean_extra_ticks": _mean([run.ticks - base.ticks for run in good]) if base_ok else None,
        "mean_cost": _mean([run.cost for run in good]),
        "mean_extra_cost": _mean([run.cost - base.cost for run in good]) if base_ok else None,
        "mean_events": _mean([run.events for run in results]),
        "limit_hits": sum(run.hit_limit for run in results),
        "base_reached": base_ok,
        "base_ticks": base.ticks,
        "base_cost": base.cost,
    }


__all__ = [
    "KINDS",
    "EventModel",
    "RandomDisturbance",
    "check_probability",
    "disturbed_runs",
    "event_model",
    "exactly_one_groups",
    "perturbation_stats",
    "run_seed",
    "seeded_disturbances",
    "summarise_runs",
]
