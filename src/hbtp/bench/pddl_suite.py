"""``hbtp bench pddl DIR``: every domain and instance of a folder of PDDL benchmarks.

A folder ``DIR/<domain>/`` holds ``domain.pddl`` and problem files (every other ``.pddl``); a folder
without ``domain.pddl`` pairs each problem ``X.pddl`` with ``domain_X.pddl``, ``domain-X.pddl`` or
``X-domain.pddl`` (the layouts of the IPC collections). ``DIR`` may also be one such domain folder.

Every instance is run with every planner in the benchmark runner (a time limit per run for loading
and for the search, a hard kill at :func:`~hbtp.bench.runner.hard_limit`): the row holds the seconds
of loading (parsing, grounding, mutexes), the grounded actions, the status, the cost, the planning
seconds, the explored conditions, and whether the tree is verified (the static verifier from s0,
then a run in the simulator that must reach the goal).

Reference optimal costs come from ``DIR/fd_optimal_costs.json`` (``{domain: {instance stem: cost}}``)
or, with ``validate`` (the ``validate`` extra), from Fast Downward (A* + LM-cut, its driver) on the
grounded task for instances the file does not cover. A *mismatch* is a solved instance whose cost
differs from the reference: any difference for the optimal planners, a cost below the optimum for
the others. Mismatches are listed in the summary, the report and the command's output.
"""

from __future__ import annotations

import logging
import time
from collections import Counter
from collections.abc import Sequence
from dataclasses import dataclass, replace
from pathlib import Path
from typing import Any

from hbtp import compiled
from hbtp.bench.plots import PLANNER_LABELS, plot_pddl_coverage
from hbtp.bench.report import _table, write_report
from hbtp.bench.results import JsonObject, ResultsFile, Row, median, optional, read_json, write_json
from hbtp.bench.runner import DEFAULT_EXECUTION, Execution, Work, hard_limit, run_work
from hbtp.bt import tree_of
from hbtp.bt.simulate import simulate
from hbtp.bt.verify import verify
from hbtp.deadline import Deadline, TimeLimitReached
from hbtp.domains import load_pddl_scenario
from hbtp.domains.scenarios import ScenarioOptions
from hbtp.errors import BackendError, HbtpError, InputError
from hbtp.planning import Limits, PlanResult, plan, release_search_memory
from hbtp.planning.heuristic_names import HeuristicName
from hbtp.planning.planners import planner_config

log = logging.getLogger(__name__)

REFERENCE_FILE = "fd_optimal_costs.json"
#: Planners whose cost must equal the optimum (without hints HBTP-O searches as OBTEA does).
OPTIMAL_PLANNERS = ("obtea", "hbtp-o")
#: The pseudo-planner of ``--validate``: Fast Downward on the same files, in the same run.
FAST_DOWNWARD = "fast-downward"
#: The issue's bound on hbtp's ground actions over Fast Downward's translator's operators.
GROUND_RATIO_TARGET = 1.5


@dataclass(frozen=True)
class Instance:
    """One problem file of a domain, with its domain file."""

    domain: str
    name: str  # the problem file's stem
    domain_file: Path
    problem_file: Path


@dataclass(frozen=True)
class PddlConfig:
    planners: tuple[str, ...] = ("obtea",)
    heuristic: HeuristicName = HeuristicName.SEQ
    time_limit: float = 60.0
    validate: bool = False
    #: Symmetry pruning (interchangeable objects: SearchConfig.symmetry) in hbtp's searches.
    symmetry: bool = True


@dataclass(frozen=True, kw_only=True)
class PddlRow(Row):
    """One planner on one instance. ``actions`` is hbtp's ground actions for the goal, or Fast
    Downward's translator's operators (``None``: not reported). A run stopped before it planned
    (killed, an instance hbtp could not load, Fast Downward not run) has no ``actions`` and no
    ``planning_s``; a load error has the ``load_s`` it took and a ``message``."""

    KEY = ("domain", "instance", "planner", "heuristic", "symmetry")

    domain: str
    instance: str
    planner: str
    heuristic: str
    symmetry: bool
    status: str
    time_s: float
    solved: bool = False
    verified: bool = False
    cost: float | None = None
    explored: int | None = None
    reference_cost: float | None = None
    mismatch: bool = False
    actions: int | None = None
    reference_source: str | None = optional()
    message: str | None = optional()
    search: str | None = optional()
    load_s: float | None = optional()
    planning_s: float | None = optional()
    pruned_symmetric: int | None = optional()
    reachable_actions: int | None = optional()


@dataclass(frozen=True)
class PddlRun:
    """One planner on one instance (the spec a worker runs)."""

    instance: Instance
    planner: str
    heuristic: HeuristicName
    time_limit: float
    reference: float | None
    validate: bool
    symmetry: bool = True


def _paired_domain(folder: Path, stem: str) -> Path | None:
    for name in (f"domain_{stem}.pddl", f"domain-{stem}.pddl", f"{stem}-domain.pddl"):
        if (folder / name).is_file():
            return folder / name
    return None


def _folder_instances(folder: Path) -> list[Instance]:
    shared = folder / "domain.pddl"
    found = []
    for problem in sorted(folder.glob("*.pddl")):
        if "domain" in problem.stem.lower():
            continue
        domain = shared if shared.is_file() else _paired_domain(folder, problem.stem)
        if domain is None:
            log.warning("%s: no domain file for it; skipped", problem)
            continue
        found.append(Instance(folder.name, problem.stem, domain, problem))
    return found


def discover(folder: Path) -> list[Instance]:
    """Every instance under ``folder`` (a folder of domain folders, or one domain folder)."""
    if not folder.is_dir():
        raise InputError(f"{folder}: not a folder")
    folders = [folder] if any(folder.glob("*.pddl")) else sorted(p for p in folder.iterdir() if p.is_dir())
    instances = [instance for sub in folders for instance in _folder_instances(sub)]
    if not instances:
        raise InputError(f"{folder}: no PDDL domain with problems found (expected DIR/<domain>/domain.pddl)")
    return instances


def read_references(folder: Path) -> dict[str, dict[str, float]]:
    """``folder/fd_optimal_costs.json`` (``{domain: {instance: cost}}``; for one domain folder, its
    parent's), or nothing."""
    path = folder / REFERENCE_FILE
    if not path.is_file() and any(folder.glob("*.pddl")):  # one domain folder: its parent's file
        path = folder.parent / REFERENCE_FILE
    if not path.is_file():
        return {}
    data = read_json(path)
    if not isinstance(data, dict) or not all(isinstance(v, dict) for v in data.values()):
        raise InputError(f"{path}: expected {{domain: {{instance: cost}}}}")
    return {domain: {name: float(cost) for name, cost in costs.items()} for domain, costs in data.items()}


def verified_tree(result: PlanResult, scenario: Any, goal: Any) -> bool:
    """The full tree passes the static verifier from s0 and, run in the simulator, reaches the goal."""
    if not result.solved:
        return False
    tree = tree_of(result)
    check = verify(tree, scenario.task, goal, from_initial_state=True)
    return check.ok and simulate(tree, scenario.task).reached(goal)


def fast_downward_row(run: PddlRun) -> PddlRow:
    """Fast Downward (A* + LM-cut, its driver) on the instance's files, read and grounded by its own
    translator: a row of the pseudo-planner :data:`FAST_DOWNWARD`, its ``actions`` the translator's
    operators. Its plan is Fast Downward's own (not replayed in hbtp's task), so ``verified`` is
    whether it found one."""
    from hbtp.validation import run_fast_downward_files

    try:
        fd = run_fast_downward_files(run.instance.domain_file, run.instance.problem_file, time_limit=run.time_limit)
    except BackendError as error:
        return replace(_before_planning(run, "error", 0.0), message=str(error)[:300])
    solved = fd.cost is not None
    return replace(
        _before_planning(run, "solved" if solved else fd.status.value, round(fd.time_s, 6)),
        absent=frozenset(),
        solved=solved,
        verified=solved,
        cost=float(fd.cost) if fd.cost is not None else None,
        actions=fd.operators,
        search=fd.search,
        load_s=0.0,
        planning_s=round(fd.time_s, 6),
        message=fd.message[:300] if fd.message else None,
    )


def mismatch(planner: str, cost: float | None, reference: float | None) -> bool:
    """Whether a solved run's cost contradicts the optimum: any difference for an optimal planner,
    a cost below it for the others."""
    if cost is None or reference is None:
        return False
    return abs(cost - reference) > 1e-6 if planner in OPTIMAL_PLANNERS else cost < reference - 1e-6


def run_one(run: PddlRun) -> PddlRow:
    """Load (ground) the instance, plan for its :goal, verify the tree, compare with the reference
    (the row of Fast Downward for :data:`FAST_DOWNWARD`)."""
    if run.planner == FAST_DOWNWARD:
        return fast_downward_row(run)
    started = time.perf_counter()
    try:
        options = ScenarioOptions(name=f"{run.instance.domain}/{run.instance.name}")
        deadline = Deadline(run.time_limit)
        instance = run.instance
        loaded = load_pddl_scenario(instance.domain_file, instance.problem_file, options, deadline=deadline)
        # With the negated twins of the goal's negative literals when it has some.
        whole, goal = loaded.resolve_goal(loaded.problem_goal())
        scenario = whole.for_goal(goal)
    except HbtpError as error:  # a time limit while loading, a file hbtp cannot read or ground
        load = round(time.perf_counter() - started, 6)
        status = "load-timeout" if isinstance(error, TimeLimitReached) else "load-error"
        log.warning("%s/%s: %s", run.instance.domain, run.instance.name, error)
        return replace(_before_planning(run, status, load), message=str(error)[:300], load_s=load)
    load = time.perf_counter() - started
    started = time.perf_counter()
    limits = Limits(time_s=run.time_limit)
    config = planner_config(run.planner, heuristic=run.heuristic, symmetry=run.symmetry)
    result = plan(scenario.task, goal, config, mutexes=scenario.mutexes, limits=limits)
    planning = time.perf_counter() - started
    verified = verified_tree(result, scenario, goal)
    release_search_memory()
    cost = float(result.cost) if result.solved and result.cost is not None else None
    return replace(
        _before_planning(run, result.status.value, round(load + planning, 6)),
        absent=frozenset(),
        solved=result.solved,
        verified=verified,
        cost=cost,
        explored=result.stats.explored,
        pruned_symmetric=result.stats.pruned_symmetric,
        actions=len(scenario.task.actions),
        reachable_actions=len(whole.task.actions),
        load_s=round(load, 6),
        planning_s=round(planning, 6),
        mismatch=mismatch(run.planner, cost, run.reference),
    )


def _symmetry(run: PddlRun) -> bool:
    """Whether the run prunes symmetric conditions (Fast Downward's never does)."""
    return run.symmetry and run.planner != FAST_DOWNWARD


def _before_planning(run: PddlRun, status: str, seconds: float) -> PddlRow:
    """The row of ``run`` ended with ``status`` after ``seconds`` before it planned: its known
    fields, unsolved, without ground actions."""
    return PddlRow(
        domain=run.instance.domain,
        instance=run.instance.name,
        planner=run.planner,
        heuristic=run.heuristic,
        symmetry=_symmetry(run),
        reference_cost=run.reference,
        reference_source=REFERENCE_FILE if run.reference is not None else None,
        status=status,
        time_s=seconds,
        absent=frozenset({"actions"}),
    )


def known(run: PddlRun) -> JsonObject:
    """The JSON fields of a run's row known before it runs."""
    data = _before_planning(run, "", 0.0).to_json()
    for name in ("status", "solved", "time_s"):
        del data[name]
    return data


def run_pddl(folder: Path, config: PddlConfig, out: Path, execution: Execution = DEFAULT_EXECUTION) -> dict[str, Any]:
    """Run (or resume) every instance under ``folder`` with every planner into ``out``."""
    for planner in config.planners:  # an unknown name or a missing solver stops the run before it starts
        planner_config(planner, heuristic=config.heuristic, symmetry=config.symmetry)
    instances = discover(folder)
    references = read_references(folder)
    work = []
    for planner in (*config.planners, *((FAST_DOWNWARD,) if config.validate else ())):
        for instance in instances:
            reference = references.get(instance.domain, {}).get(instance.name)
            spec = PddlRun(
                instance, planner, config.heuristic, config.time_limit, reference, config.validate, config.symmetry
            )
            key = (instance.domain, instance.name, planner, config.heuristic, _symmetry(spec))
            work.append(Work(key, spec, known(spec), stage=f"{planner} {instance.domain}"))
    results = ResultsFile(out / "results.jsonl", PddlRow)
    run_work(run_one, work, results, execution, kill_after=hard_limit(config.time_limit), description="pddl")
    summary = summarise(list(results.ordered(w.key for w in work)), config, folder)
    write_json(out / "summary.json", summary)
    plotted = plot_pddl_coverage(summary, out / "coverage.png")
    write_report(out / "report.md", f"PDDL benchmarks: {folder}", [pddl_section(summary, plotted)])
    return summary


def _planner_stats(rows: Sequence[PddlRow], domains: Sequence[str]) -> dict[str, Any]:
    good = [r for r in rows if r.verified]
    return {
        "instances": len(rows),
        "solved": sum(r.solved for r in rows),
        "verified": len(good),
        "statuses": dict(Counter(r.status for r in rows)),
        "by_domain": {d: sum(r.domain == d for r in good) for d in domains},
        "median_time_s": median(r.time_s for r in good),
        "median_load_s": median(r.load_s for r in good),
        "median_planning_s": median(r.planning_s for r in good),
        "median_explored": median(r.explored for r in good),
        "solve_times": sorted(r.time_s for r in good),
    }


def _fast_downward_rows(rows: Sequence[PddlRow]) -> dict[tuple[str, str], PddlRow]:
    return {(r.domain, r.instance): r for r in rows if r.planner == FAST_DOWNWARD}


def with_fast_downward(rows: Sequence[PddlRow]) -> list[PddlRow]:
    """``rows`` with Fast Downward's cost as the reference of the instances the reference file does
    not cover (and whether it is a mismatch)."""
    by_instance = _fast_downward_rows(rows)
    out: list[PddlRow] = []
    for row in rows:
        fd = by_instance.get((row.domain, row.instance))
        if row.planner != FAST_DOWNWARD and fd is not None and row.reference_cost is None and fd.cost is not None:
            found = mismatch(row.planner, row.cost, fd.cost)
            row = replace(row, reference_cost=fd.cost, reference_source=FAST_DOWNWARD, mismatch=found)
        out.append(row)
    return out


def ground_ratios(rows: Sequence[PddlRow]) -> dict[tuple[str, str], tuple[float, float]]:
    """Per instance (its first hbtp row), hbtp's ground actions for the goal over Fast Downward's
    translator's operators, and its whole reachable grounding's."""
    by_instance = _fast_downward_rows(rows)
    ratios: dict[tuple[str, str], tuple[float, float]] = {}
    for row in rows:
        fd = by_instance.get((row.domain, row.instance))
        if row.planner == FAST_DOWNWARD or fd is None or not row.actions or not fd.actions:
            continue
        reachable = row.actions if row.reachable_actions is None else row.reachable_actions
        ratios.setdefault(
            (row.domain, row.instance), (round(row.actions / fd.actions, 3), round(reachable / fd.actions, 3))
        )
    return ratios


def _grounding(seen: dict[tuple[str, str], tuple[float, float]]) -> dict[str, Any]:
    """hbtp's ground actions (for the goal, and all those reachable) against the translator's
    operators (for the goal), per instance (:func:`ground_ratios`)."""

    def above(part: int) -> list[str]:
        return sorted(f"{d}/{i} {r[part]:.2f}x" for (d, i), r in seen.items() if r[part] > GROUND_RATIO_TARGET)

    return {
        "instances": len(seen),
        "max_ratio": max((r[0] for r in seen.values()), default=None),
        "max_reachable_ratio": max((r[1] for r in seen.values()), default=None),
        "above_target": above(0),
        "reachable_above_target": above(1),
    }


def _mismatch_entry(row: PddlRow) -> dict[str, Any]:
    return {
        "domain": row.domain,
        "instance": row.instance,
        "planner": row.planner,
        "cost": row.cost,
        "reference_cost": row.reference_cost,
        "reference_source": row.reference_source,
    }


def summarise(rows: Sequence[PddlRow], config: PddlConfig, folder: Path) -> dict[str, Any]:
    rows = with_fast_downward(rows)
    domains = list(dict.fromkeys(r.domain for r in rows))
    compared = [r for r in rows if r.planner != FAST_DOWNWARD and r.solved and r.reference_cost is not None]
    return {
        "config": {
            "folder": str(folder),
            "planners": list(config.planners),
            "heuristic": config.heuristic,
            "time_limit": config.time_limit,
            "validate": config.validate,
            "symmetry": config.symmetry,
            "c_extensions": compiled.built(),  # of the process that summarised: a resumed run may mix
        },
        "runs": len(rows),
        "domains": {d: len({r.instance for r in rows if r.domain == d}) for d in domains},
        "planners": {
            p: _planner_stats([r for r in rows if r.planner == p], domains)
            for p in (*config.planners, *((FAST_DOWNWARD,) if config.validate else ()))
        },
        "grounding": _grounding(ground_ratios(rows)),
        "compared": len(compared),
        "mismatches": [_mismatch_entry(r) for r in rows if r.mismatch],
        "unverified": [f"{r.domain}/{r.instance} {r.planner}" for r in rows if r.solved and not r.verified],
    }


def _kernel(config: dict[str, Any]) -> str:
    """Which optional C extensions the runs had (unknown for an older summary)."""
    built = config.get("c_extensions")
    if built is None:
        return "C extensions not recorded"
    missing = sorted(name for name, ok in built.items() if not ok)
    if not missing:
        return f"every C extension built ({', '.join(sorted(built))})"
    return f"in Python: {', '.join(missing)} (C extensions not built)"


def _s(value: float | None) -> str:
    return "–" if value is None else f"{value:.3f}"


def pddl_section(summary: dict[str, Any], plotted: bool = True) -> str:
    """Coverage per planner and domain, median times, and every mismatch with the optimum."""
    config, planners = summary["config"], summary["planners"]
    names = list(planners)
    header = ["domain", "instances", *(PLANNER_LABELS.get(p, p) for p in names)]
    rows = [[d, n, *(planners[p]["by_domain"][d] for p in names)] for d, n in summary["domains"].items()]
    rows.append(["**total**", sum(summary["domains"].values()), *(planners[p]["verified"] for p in names)])
    times = [
        [
            PLANNER_LABELS.get(p, p),
            f"{s['verified']}/{s['instances']}",
            s["solved"],
            _s(s["median_time_s"]),
            _s(s["median_load_s"]),
            _s(s["median_planning_s"]),
            s["median_explored"] if s["median_explored"] is not None else "–",
            ", ".join(f"{k} {v}" for k, v in sorted(s["statuses"].items())),
        ]
        for p, s in planners.items()
    ]
    parts = [
        "## Coverage, cost and time on a folder of PDDL benchmarks",
        f"`{config['folder']}`; heuristic `{config['heuristic']}`, symmetry pruning "
        f"{'on' if config.get('symmetry') else 'off'}, {_kernel(config)}, "
        f"{config['time_limit']:g} s per run (loading and "
        "search each), every solved tree verified (static check from s0, then a run in the simulator). Coverage "
        "counts verified trees; times are medians over them (time = load + planning).",
        _table(header, rows),
        _table(["planner", "verified", "solved", "time s", "load s", "planning s", "explored", "statuses"], times),
    ]
    mismatches = summary["mismatches"]
    parts.append(
        f"**{len(mismatches)} MISMATCH(ES) with the reference optimal cost** "
        f"({summary['compared']} solved runs compared):\n\n"
        + _table(
            ["domain", "instance", "planner", "our cost", "reference", "source"],
            [
                [m["domain"], m["instance"], m["planner"], m["cost"], m["reference_cost"], m["reference_source"]]
                for m in mismatches
            ],
        )
        if mismatches
        else f"No mismatch with the reference optimal costs ({summary['compared']} solved runs compared)."
    )
    grounding = summary.get("grounding") or {}
    if grounding.get("instances"):
        above = grounding["above_target"]
        reachable = grounding["reachable_above_target"]
        parts.append(
            f"Ground actions for the problem's goal over Fast Downward's translator's operators (which it "
            f"keeps for the goal too) on {grounding['instances']} instances: at most {grounding['max_ratio']:.2f}x "
            f"(above {GROUND_RATIO_TARGET}x: {', '.join(above) if above else 'none'}); every reachable ground "
            f"action (the grounding other goals share) at most {grounding['max_reachable_ratio']:.2f}x "
            f"(above {GROUND_RATIO_TARGET}x: {', '.join(reachable) if reachable else 'none'})."
        )
    if summary["unverified"]:
        parts.append(f"**Solved but not verified**: {', '.join(summary['unverified'])}")
    if plotted:
        parts.append("![coverage](coverage.png)")
    return "\n\n".join(parts)


__all__ = ["Instance", "PddlConfig", "discover", "mismatch", "pddl_section", "read_references", "run_pddl"]
