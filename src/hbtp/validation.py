"""Check OBTEA's optimality against Fast Downward (the optional ``validate`` extra).

A record's goal is exported with :func:`~hbtp.domains.pddl_writer.write_grounded` (the exact task
the planners search, as STRIPS + action costs), read by unified-planning and solved by Fast
Downward's optimal configuration (A* with LM-cut). Its cost must equal OBTEA's D(T).

Fast Downward is GPL: it is only used here, imported lazily, and only when the ``validate`` extra is
installed (``pip install -e '.[validate]'``). Its driver writes into the working directory, so each
call runs with a fresh temporary directory as the working directory (which makes the call
unsuitable for threads: the working directory belongs to the process).

Declared mutexes (RobotHow, RobotHow-Small) prune conditions that Fast Downward does not know
about, so every record is planned twice, with the scenario's mutexes and with ``mutexes=None``: the
second cost must match Fast Downward exactly, and a record whose optimum changes with the
mutexes is reported.
"""

from __future__ import annotations

import contextlib
import functools
import logging
import tempfile
import time
import warnings
from collections.abc import Iterator
from dataclasses import dataclass
from pathlib import Path
from typing import Any

from hbtp.datasets import load_dataset
from hbtp.datasets.records import Record
from hbtp.domains import Scenario, load_scenario, write_grounded
from hbtp.domains.mutex import Mutexes
from hbtp.errors import BackendError, InputError
from hbtp.logic.task import Goal, GroundAction, GroundTask
from hbtp.planning import Limits, plan

log = logging.getLogger(__name__)

INSTALL_HINT = "install the validate extra: pip install -e '.[validate]'"
ENGINE = "fast-downward-opt"


@dataclass(frozen=True)
class FastDownwardRun:
    """One Fast Downward run.

    ``status`` is ``optimal`` (``cost`` and ``plan`` set), ``unsolvable`` (proved), ``timeout`` or
    ``error`` (``message`` says why). ``plan`` holds hbtp's action names (``Walk(apple)``);
    ``time_s`` is the whole call: export, parsing and the planner.
    """

    status: str
    cost: int | None = None
    plan: tuple[str, ...] = ()
    time_s: float = 0.0
    message: str = ""


@dataclass(frozen=True)
class ObteaRun:
    """OBTEA's outcome on one goal: ``cost`` is D(T) (``None`` unless solved)."""

    status: str
    cost: int | None
    time_s: float


# ------------------------------------------------------------ Fast Downward
def _require_extra() -> None:
    """Import unified-planning and its Fast Downward engine, or say how to install them."""
    try:
        import unified_planning.shortcuts  # noqa: F401
        import up_fast_downward  # noqa: F401
    except ImportError as error:
        raise BackendError(f"Fast Downward is not available ({error}); {INSTALL_HINT}") from None


@functools.cache
def _environment() -> Any:
    """A private unified-planning environment: quiet, and lenient about shared names.

    RoboWaiter has objects ``On``/``Off`` and a predicate ``On``: PDDL (and Fast Downward) keep
    objects and predicates apart, but unified-planning refuses a shared name unless
    ``error_used_name`` is off (its writer then renames for the planner).
    """
    from unified_planning.environment import Environment

    environment = Environment()
    environment.credits_stream = None
    environment.error_used_name = False
    return environment


def _solve_pddl(domain_file: Path, problem_file: Path, time_limit: float) -> Any:
    """Read the files with unified-planning and solve them with Fast Downward; the raw result."""
    from unified_planning.io import PDDLReader

    environment = _environment()
    with warnings.catch_warnings():
        warnings.filterwarnings("ignore", message=r"Name .* already defined", category=UserWarning)
        problem = PDDLReader(environment).parse_problem(str(domain_file), str(problem_file))
        with environment.factory.OneshotPlanner(name=ENGINE) as planner:
            return planner.solve(problem, timeout=time_limit)


def run_fast_downward(task: GroundTask, goal: Goal, *, time_limit: float = 60.0) -> FastDownwardRun:
    """Solve ``goal`` optimally with Fast Downward; its plan is replayed in ``task`` to check it."""
    _require_extra()
    started = time.perf_counter()
    domain_text, problem_text = write_grounded(task, goal, rename_keywords=True)
    with tempfile.TemporaryDirectory(prefix="hbtp-fd-") as folder, contextlib.chdir(folder):
        domain_file, problem_file = Path(folder, "domain.pddl"), Path(folder, "problem.pddl")
        domain_file.write_text(domain_text, encoding="utf-8")
        problem_file.write_text(problem_text, encoding="utf-8")
        try:
            result = _solve_pddl(domain_file, problem_file, time_limit)
        except Exception as error:  # unified-planning raises many unrelated types
            return FastDownwardRun(
                "error", time_s=time.perf_counter() - started, message=f"{type(error).__name__}: {error}"
            )
    return _interpret(result, task, goal, time.perf_counter() - started)


def _interpret(result: Any, task: GroundTask, goal: Goal, elapsed: float) -> FastDownwardRun:
    """Turn unified-planning's result into a :class:`FastDownwardRun`."""
    from unified_planning.engines import PlanGenerationResultStatus as Status

    if result.status == Status.SOLVED_OPTIMALLY:
        names = [instance.action.name for instance in result.plan.actions]
        return _replay(task, goal, names, elapsed)
    if result.status == Status.UNSOLVABLE_PROVEN:
        return FastDownwardRun("unsolvable", time_s=elapsed)
    if result.status == Status.TIMEOUT:
        return FastDownwardRun("timeout", time_s=elapsed, message="Fast Downward reached the time limit")
    logs = " ".join(m.message.strip() for m in result.log_messages or () if m.message.strip())
    return FastDownwardRun("error", time_s=elapsed, message=f"{result.status.name}: {logs[-500:]}")


def _replay(task: GroundTask, goal: Goal, names: list[str], elapsed: float) -> FastDownwardRun:
    """Map Fast Downward's (lowercased) action names back to ``task`` and execute the plan from s0."""
    by_name = _actions_by_lowercase_name(task)
    try:
        actions = [by_name[name.lower()] for name in names]
    except KeyError as missing:
        return FastDownwardRun("error", time_s=elapsed, message=f"Fast Downward's plan has unknown action {missing}")
    state, applied = task.execute(actions)
    readable = tuple(action.name for action in actions)
    if applied < len(actions) or not goal.ids <= state:
        message = f"Fast Downward's plan does not reach the goal in hbtp's task: {', '.join(readable)}"
        return FastDownwardRun("error", plan=readable, time_s=elapsed, message=message)
    return FastDownwardRun("optimal", sum(a.cost for a in actions), readable, elapsed)


def _actions_by_lowercase_name(task: GroundTask) -> dict[str, GroundAction]:
    table = {action.signature.underscored.lower(): action for action in task.actions}
    if len(table) != len(task.actions):
        raise InputError(f"{task.name}: action names that differ only in case cannot be checked with Fast Downward")
    return table


def fast_downward_cost(task: GroundTask, goal: Goal, *, time_limit: float = 60.0) -> int | None:
    """Fast Downward's optimal cost of ``goal`` in ``task``; ``None`` when it proves the goal unsolvable.

    Raises :class:`~hbtp.errors.BackendError` when the ``validate`` extra is missing, on a timeout
    and on any other failure.
    """
    run = run_fast_downward(task, goal, time_limit=time_limit)
    if run.status in ("optimal", "unsolvable"):
        return run.cost
    raise BackendError(f"Fast Downward failed ({run.status}): {run.message}")


# ------------------------------------------------------------- comparison
def has_declared_mutexes(mutexes: Mutexes) -> bool:
    """Whether some mutexes are declared rather than proved (they may prune optimal solutions)."""
    return bool(mutexes.nogoods) or any(not group.proved for group in mutexes.groups)


def run_obtea(task: GroundTask, goal: Goal, mutexes: Mutexes | None, time_limit: float) -> ObteaRun:
    """OBTEA on the full action space with the landmark heuristic."""
    result = plan(task, goal, "obtea", space="full", mutexes=mutexes, heuristic="lm", limits=Limits(time_s=time_limit))
    return ObteaRun(result.status.value, result.cost if result.solved else None, result.stats.time_s)


def _decided(status: str) -> bool:
    return status in ("solved", "optimal", "unsolvable")


def compare_record(scenario: Scenario, record: Record, *, time_limit: float = 60.0) -> dict[str, Any]:
    """Compare OBTEA (with the scenario's mutexes and without) and Fast Downward on one record.

    ``match`` is true when both decided and OBTEA without mutexes costs exactly what Fast Downward
    does (``None`` for both when the goal is unsolvable). ``mutexes_change_optimum`` flags a record
    whose D(T) differs with the scenario's mutexes (only declared ones can do that);
    ``declared_mutexes`` says whether the scenario has any.
    """
    task = scenario.task
    goal = task.resolve_goal(record.goal)
    pruned = run_obtea(task, goal, scenario.mutexes, time_limit)
    plain = run_obtea(task, goal, None, time_limit)
    fd = run_fast_downward(task, goal, time_limit=time_limit)
    decided = _decided(plain.status) and _decided(fd.status)
    row: dict[str, Any] = {
        "scenario": scenario.name,
        "record": record.id,
        "goal": str(goal),
        "obtea_cost": pruned.cost,
        "obtea_status": pruned.status,
        "obtea_time_s": round(pruned.time_s, 4),
        "obtea_unpruned_cost": plain.cost,
        "obtea_unpruned_status": plain.status,
        "obtea_unpruned_time_s": round(plain.time_s, 4),
        "fd_cost": fd.cost,
        "fd_status": fd.status,
        "fd_time_s": round(fd.time_s, 4),
        "fd_plan": list(fd.plan),
        "match": decided and plain.cost == fd.cost,
        "declared_mutexes": has_declared_mutexes(scenario.mutexes),
        "mutexes_change_optimum": _decided(pruned.status) and _decided(plain.status) and pruned.cost != plain.cost,
    }
    if fd.message:
        row["fd_message"] = fd.message
    return row


def iter_comparisons(
    scenario_name: str, dataset_name: str | None = None, *, time_limit: float = 60.0, limit: int | None = None
) -> Iterator[dict[str, Any]]:
    """Compare every record of ``dataset_name`` (default: the scenario's Table II test set), one row each."""
    _require_extra()
    scenario = load_scenario(scenario_name)
    name = dataset_name or scenario.test_set
    if name is None:
        raise InputError(f"scenario {scenario_name!r} has no test set: give a dataset")
    records = load_dataset(name)
    for record in records[:limit] if limit is not None else records:
        row = compare_record(scenario, record, time_limit=time_limit)
        log.info("%s record %s: OBTEA %s, FD %s", scenario.name, record.id, row["obtea_unpruned_cost"], row["fd_cost"])
        yield row


def compare_optimal(
    scenario_name: str, dataset_name: str | None = None, *, time_limit: float = 60.0, limit: int | None = None
) -> list[dict[str, Any]]:
    """Rows of :func:`compare_record` for the first ``limit`` records (all by default) of a dataset."""
    return list(iter_comparisons(scenario_name, dataset_name, time_limit=time_limit, limit=limit))


__all__ = [
    "INSTALL_HINT",
    "FastDownwardRun",
    "ObteaRun",
    "compare_optimal",
    "compare_record",
    "fast_downward_cost",
    "has_declared_mutexes",
    "iter_comparisons",
    "run_fast_downward",
    "run_obtea",
]
