"""OBTEA against Fast Downward: a record's or a PDDL problem's optimal cost, both ways, in rows."""

from __future__ import annotations

import logging
import time
from collections.abc import Iterator, Mapping
from pathlib import Path
from typing import Any

from hbtp.bt import tree_of
from hbtp.bt.simulate import simulate
from hbtp.bt.verify import verify
from hbtp.datasets import dataset_names, load_dataset, read_dataset_file
from hbtp.datasets.records import Record
from hbtp.domains import Scenario, load_pddl_scenario, load_scenario
from hbtp.domains.mutex import Mutexes
from hbtp.domains.scenarios import ScenarioOptions
from hbtp.errors import InputError
from hbtp.logic.task import Goal, GroundTask
from hbtp.planning import Limits, PlanResult, Status, plan
from hbtp.planning.heuristic_names import HeuristicName
from hbtp.planning.planners import Space
from hbtp.validation.fast_downward import (
    COMPARE_TIME_LIMIT,
    OBTEA_DECIDED,
    Engine,
    ObteaRun,
    RunStatus,
    choose_engine,
    require_extra,
    run_fast_downward,
    run_fast_downward_files,
)

log = logging.getLogger(__name__)


def has_declared_mutexes(mutexes: Mutexes) -> bool:
    """Whether some mutexes are declared rather than proved (they may prune optimal solutions)."""
    return bool(mutexes.nogoods) or any(not group.proved for group in mutexes.groups)


def run_obtea(task: GroundTask, goal: Goal, mutexes: Mutexes | None, time_limit: float) -> ObteaRun:
    """OBTEA on the full action space with the landmark heuristic."""
    limits = Limits(time_s=time_limit)
    result = plan(task, goal, "obtea", space=Space.FULL, mutexes=mutexes, heuristic=HeuristicName.LM, limits=limits)
    return ObteaRun(result.status, result.cost if result.solved else None, result.stats.time_s)


def decided(row: Mapping[str, Any]) -> bool:
    """Whether both OBTEA without mutexes and Fast Downward answered in a :func:`compare_record` row
    (a cost or a proof; not a time limit or an error)."""
    return Status(row["obtea_unpruned_status"]) in OBTEA_DECIDED and RunStatus(row["fd_status"]).decided


def compare_record(
    scenario: Scenario, record: Record, *, time_limit: float = COMPARE_TIME_LIMIT, engine: Engine = Engine.AUTO
) -> dict[str, Any]:
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
    fd = run_fast_downward(task, goal, time_limit=time_limit, engine=engine)
    row: dict[str, Any] = {
        "scenario": scenario.name,
        "record": record.id,
        "goal": str(goal),
        "obtea_cost": pruned.cost,
        "obtea_status": pruned.status.value,
        "obtea_time_s": round(pruned.time_s, 4),
        "obtea_unpruned_cost": plain.cost,
        "obtea_unpruned_status": plain.status.value,
        "obtea_unpruned_time_s": round(plain.time_s, 4),
        "fd_cost": fd.cost,
        "fd_status": fd.status.value,
        "fd_time_s": round(fd.time_s, 4),
        "fd_engine": fd.engine,
        "fd_plan": list(fd.plan),
        "match": plain.status in OBTEA_DECIDED and fd.status.decided and plain.cost == fd.cost,
        "declared_mutexes": has_declared_mutexes(scenario.mutexes),
        "mutexes_change_optimum": pruned.status in OBTEA_DECIDED
        and plain.status in OBTEA_DECIDED
        and pruned.cost != plain.cost,
    }
    if fd.message:
        row["fd_message"] = fd.message
    return row


def compare_files(domain_file: Path, problem_file: Path, *, time_limit: float = COMPARE_TIME_LIMIT) -> dict[str, Any]:
    """OBTEA (landmark heuristic, proved mutexes) on the problem's ``:goal`` as hbtp reads and
    grounds the files, against Fast Downward on the same files (:func:`run_fast_downward_files`).

    ``match`` is true when both decided with the same cost (``None`` for both when unsolvable) and
    OBTEA's tree is verified and reaches the goal in the simulator. The row also has hbtp's ground
    actions for this goal (:meth:`~hbtp.domains.Scenario.for_goal`, what OBTEA searches) and all
    those reachable (what other goals share) beside the translator's operators, which it keeps for
    this goal too (``ground_ratio``, ``reachable_ratio``)."""
    started = time.perf_counter()
    scenario = load_pddl_scenario(domain_file, problem_file, ScenarioOptions(name=Path(problem_file).stem))
    whole, goal = scenario.resolve_goal(scenario.problem_goal())
    scenario = whole.for_goal(goal)
    left = max(time_limit - (time.perf_counter() - started), 0.1)
    result = plan(
        scenario.task,
        goal,
        "obtea",
        heuristic=HeuristicName.NONE,
        mutexes=scenario.mutexes.proved_only(),
        limits=Limits(time_s=left),
    )
    obtea_time = time.perf_counter() - started
    tree_ok = result.solved and _tree_reaches(result, scenario.task, goal)
    fd = run_fast_downward_files(domain_file, problem_file, time_limit=time_limit)
    cost = result.cost if result.solved else None
    decided_both = result.status in OBTEA_DECIDED and fd.status.decided
    actions = len(scenario.task.actions)
    reachable = len(whole.task.actions)
    return {
        "instance": str(problem_file),
        "goal": str(goal),
        "grounded_actions": actions,
        "obtea_status": result.status.value,
        "obtea_cost": cost,
        "obtea_time_s": round(obtea_time, 4),
        "tree_verified": tree_ok,
        "fd_status": fd.status.value,
        "fd_cost": fd.cost,
        "fd_operators": fd.operators,
        "fd_time_s": round(fd.time_s, 4),
        "fd_search": fd.search,
        "reachable_actions": reachable,
        "ground_ratio": round(actions / fd.operators, 3) if fd.operators else None,
        "reachable_ratio": round(reachable / fd.operators, 3) if fd.operators else None,
        "match": decided_both and cost == fd.cost and (cost is None or tree_ok),
        "decided": decided_both,
        **({"fd_message": fd.message} if fd.message else {}),
    }


def _tree_reaches(result: PlanResult, task: GroundTask, goal: Goal) -> bool:
    """Whether the full tree of ``result`` is verified from s0 and its run reaches the goal."""
    tree = tree_of(result, "full")
    return verify(tree, task, goal, from_initial_state=True).ok and simulate(tree, task).reached(goal)


def iter_comparisons(
    scenario_name: str,
    dataset_name: str | None = None,
    *,
    time_limit: float = COMPARE_TIME_LIMIT,
    limit: int | None = None,
    engine: Engine = Engine.AUTO,
) -> Iterator[dict[str, Any]]:
    """Compare every record of ``dataset_name`` (a shipped dataset or a file; default: the scenario's
    Table II test set), one row each, in the paper's action space (the benchmarks' optima it checks)."""
    require_extra()
    scenario = load_scenario(scenario_name, keep_self_placements=True)
    choose_engine(scenario.task, engine)  # an unknown engine fails before any work
    name = dataset_name or scenario.test_set
    if name is None:
        raise InputError(f"scenario {scenario_name!r} has no test set: give a dataset")
    records = _records(name)
    for record in records if limit is None else records[:limit]:
        row = compare_record(scenario, record, time_limit=time_limit, engine=engine)
        log.info("%s record %s: OBTEA %s, FD %s", scenario.name, record.id, row["obtea_unpruned_cost"], row["fd_cost"])
        yield row


def _records(source: str) -> list[Record]:
    """A shipped dataset by name, or a dataset file (reference text format or JSONL)."""
    if source in dataset_names() or not Path(source).is_file():
        return load_dataset(source)  # an unknown name fails here, naming the choices
    return read_dataset_file(source)


def compare_optimal(
    scenario_name: str,
    dataset_name: str | None = None,
    *,
    time_limit: float = COMPARE_TIME_LIMIT,
    limit: int | None = None,
    engine: Engine = Engine.AUTO,
) -> list[dict[str, Any]]:
    """Rows of :func:`compare_record` for the first ``limit`` records (all by default) of a dataset."""
    return list(iter_comparisons(scenario_name, dataset_name, time_limit=time_limit, limit=limit, engine=engine))


__all__ = [
    "compare_files",
    "compare_optimal",
    "compare_record",
    "decided",
    "has_declared_mutexes",
    "iter_comparisons",
    "run_obtea",
]
