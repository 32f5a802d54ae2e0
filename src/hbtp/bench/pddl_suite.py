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
from collections.abc import Sequence
from dataclasses import dataclass
from pathlib import Path
from typing import Any

from hbtp import compiled
from hbtp.bench.plots import PLANNER_LABELS, plot_pddl_coverage
from hbtp.bench.report import _table, write_report
from hbtp.bench.results import ResultsFile, median, read_json, write_json
from hbtp.bench.runner import DEFAULT_EXECUTION, Execution, Work, hard_limit, run_work
from hbtp.bt import tree_of
from hbtp.bt.simulate import simulate
from hbtp.bt.verify import verify
from hbtp.deadline import Deadline, TimeLimitReached
from hbtp.domains import load_pddl_scenario
from hbtp.domains.scenarios import ScenarioOptions
from hbtp.errors import BackendError, HbtpError, InputError
from hbtp.planning import Limits, PlanResult, plan, release_search_memory
from hbtp.planning.heuristics import HeuristicName
from hbtp.planning.planners import planner_config

log = logging.getLogger(__name__)

KEY = ("domain", "instance", "planner", "heuristic", "symmetry")
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
    heuristic: HeuristicName = "seq"
    time_limit: float = 60.0
    validate: bool = False
    #: Symmetry pruning (interchangeable objects: SearchConfig.symmetry) in hbtp's searches.
    symmetry: bool = True


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


def fast_downward_row(run: PddlRun) -> dict[str, Any]:
    """Fast Downward (A* + LM-cut, its driver) on the instance's files, read and grounded by its own
    translator: a row of the pseudo-planner :data:`FAST_DOWNWARD`, its ``actions`` the translator's
    operators. Its plan is Fast Downward's own (not replayed in hbtp's task), so ``verified`` is
    whether it found one."""
    from hbtp.validation import run_fast_downward_files

    row = known(run)
    try:
        fd = run_fast_downward_files(run.instance.domain_file, run.instance.problem_file, time_limit=run.time_limit)
    except BackendError as error:
        return {**row, "status": "error", "solved": False, "message": str(error)[:300], "time_s": 0.0}
    solved = fd.cost is not None
    return {
        **row,
        "status": "solved" if solved else fd.status.value,
        "solved": solved,
        "verified": solved,
        "cost": float(fd.cost) if fd.cost is not None else None,
        "actions": fd.operators,
        "search": fd.search,
        "load_s": 0.0,
        "planning_s": round(fd.time_s, 6),
        "time_s": round(fd.time_s, 6),
        "mismatch": False,
        **({"message": fd.message[:300]} if fd.message else {}),
    }


def mismatch(planner: str, cost: float | None, reference: float | None) -> bool:
    """Whether a solved run's cost contradicts the optimum: any difference for an optimal planner,
    a cost below it for the others."""
    if cost is None or reference is None:
        return False
    return abs(cost - reference) > 1e-6 if planner in OPTIMAL_PLANNERS else cost < reference - 1e-6


def run_one(run: PddlRun) -> dict[str, Any]:
    """Load (ground) the instance, plan for its :goal, verify the tree, compare with the reference
    (the row of Fast Downward for :data:`FAST_DOWNWARD`)."""
    if run.planner == FAST_DOWNWARD:
        return fast_downward_row(run)
    row = known(run)
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
        load = time.perf_counter() - started
        status = "load-timeout" if isinstance(error, TimeLimitReached) else "load-error"
        log.warning("%s/%s: %s", run.instance.domain, run.instance.name, error)
        return {
            **row,
            "status": status,
            "solved": False,
            "verified": False,
            "message": str(error)[:300],
            "load_s": round(load, 6),
            "time_s": round(load, 6),
        }
    load = time.perf_counter() - started
    started = time.perf_counter()
    limits = Limits(time_s=run.time_limit)
    config = planner_config(run.planner, heuristic=run.heuristic, symmetry=run.symmetry)
    result = plan(scenario.task, goal, config, mutexes=scenario.mutexes, limits=limits)
    planning = time.perf_counter() - started
    verified = verified_tree(result, scenario, goal)
    release_search_memory()
    cost = float(result.cost) if result.solved and result.cost is not None else None
    return {
        **row,
        "status": result.status.value,
        "solved": result.solved,
        "verified": verified,
        "cost": cost,
        "explored": result.stats.explored,
        "pruned_symmetric": result.stats.pruned_symmetric,
        "actions": len(scenario.task.actions),
        "reachable_actions": len(whole.task.actions),
        "load_s": round(load, 6),
        "planning_s": round(planning, 6),
        "time_s": round(load + planning, 6),
        "mismatch": mismatch(run.planner, cost, row.get("reference_cost")),
    }


def known(run: PddlRun) -> dict[str, Any]:
    fields: dict[str, Any] = {
        "domain": run.instance.domain,
        "instance": run.instance.name,
        "planner": run.planner,
        "heuristic": run.heuristic,
        "symmetry": run.symmetry and run.planner != FAST_DOWNWARD,
        "reference_cost": run.reference,
        "cost": None,
        "explored": None,
        "verified": False,
        "mismatch": False,
    }
    if run.reference is not None:
        fields["reference_source"] = REFERENCE_FILE
    return fields


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
            key = (instance.domain, instance.name, planner, config.heuristic, known(spec)["symmetry"])
            work.append(Work(key, spec, known(spec), stage=f"{planner} {instance.domain}"))
    results = ResultsFile(out / "results.jsonl", KEY)
    run_work(run_one, work, results, execution, kill_after=hard_limit(config.time_limit), description="pddl")
    summary = summarise(list(results.ordered(w.key for w in work)), config, folder)
    write_json(out / "summary.json", summary)
    plotted = plot_pddl_coverage(summary, out / "coverage.png")
    write_report(out / "report.md", f"PDDL benchmarks: {folder}", [pddl_section(summary, plotted)])
    return summary


def _planner_stats(rows: Sequence[dict[str, Any]], domains: Sequence[str]) -> dict[str, Any]:
    good = [r for r in rows if r.get("verified")]
    statuses: dict[str, int] = {}
    for row in rows:
        statuses[row["status"]] = statuses.get(row["status"], 0) + 1
    return {
        "instances": len(rows),
        "solved": sum(bool(r.get("solved")) for r in rows),
        "verified": len(good),
        "statuses": statuses,
        "by_domain": {d: sum(r["domain"] == d for r in good) for d in domains},
        "median_time_s": median([r["time_s"] for r in good]),
        "median_load_s": median([r["load_s"] for r in good]),
        "median_planning_s": median([r["planning_s"] for r in good]),
        "median_explored": median([r["explored"] for r in good if r.get("explored") is not None]),
        "solve_times": sorted(r["time_s"] for r in good),
    }


def with_fast_downward(rows: Sequence[dict[str, Any]]) -> list[dict[str, Any]]:
    """``rows`` with Fast Downward's cost as the reference of the instances the reference file does
    not cover, and each hbtp row's ground actions for the goal over the translator's operators
    (``ground_ratio``), and its whole reachable grounding's (``reachable_ratio``)."""
    by_instance = {(r["domain"], r["instance"]): r for r in rows if r["planner"] == FAST_DOWNWARD}
    out: list[dict[str, Any]] = []
    for row in rows:
        fd = by_instance.get((row["domain"], row["instance"]))
        if row["planner"] == FAST_DOWNWARD or fd is None:
            out.append(row)
            continue
        row = dict(row)
        if row.get("reference_cost") is None and fd.get("cost") is not None:
            row.update(reference_cost=fd["cost"], reference_source=FAST_DOWNWARD)
            row["mismatch"] = mismatch(row["planner"], row.get("cost"), row["reference_cost"])
        if row.get("actions") and fd.get("actions"):
            row["ground_ratio"] = round(row["actions"] / fd["actions"], 3)
            row["reachable_ratio"] = round(row.get("reachable_actions", row["actions"]) / fd["actions"], 3)
        out.append(row)
    return out


def _grounding(rows: Sequence[dict[str, Any]]) -> dict[str, Any]:
    """hbtp's ground actions (for the goal, and all those reachable) against the translator's
    operators (for the goal), per instance (the first planner's rows)."""
    seen: dict[tuple[str, str], tuple[float, float]] = {}
    for row in rows:
        if row.get("ground_ratio") is not None:
            seen.setdefault((row["domain"], row["instance"]), (row["ground_ratio"], row["reachable_ratio"]))

    def above(part: int) -> list[str]:
        return sorted(f"{d}/{i} {r[part]:.2f}x" for (d, i), r in seen.items() if r[part] > GROUND_RATIO_TARGET)

    return {
        "instances": len(seen),
        "max_ratio": max((r[0] for r in seen.values()), default=None),
        "max_reachable_ratio": max((r[1] for r in seen.values()), default=None),
        "above_target": above(0),
        "reachable_above_target": above(1),
    }


def summarise(rows: Sequence[dict[str, Any]], config: PddlConfig, folder: Path) -> dict[str, Any]:
    rows = with_fast_downward(rows)
    domains = list(dict.fromkeys(r["domain"] for r in rows))
    mismatches = [
        {k: r.get(k) for k in ("domain", "instance", "planner", "cost", "reference_cost", "reference_source")}
        for r in rows
        if r.get("mismatch")
    ]
    compared = [
        r for r in rows if r["planner"] != FAST_DOWNWARD and r.get("solved") and r.get("reference_cost") is not None
    ]
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
        "domains": {d: len({r["instance"] for r in rows if r["domain"] == d}) for d in domains},
        "planners": {
            p: _planner_stats([r for r in rows if r["planner"] == p], domains)
            for p in (*config.planners, *((FAST_DOWNWARD,) if config.validate else ()))
        },
        "grounding": _grounding(rows),
        "compared": len(compared),
        "mismatches": mismatches,
        "unverified": [
            f"{r['domain']}/{r['instance']} {r['planner']}" for r in rows if r.get("solved") and not r.get("verified")
        ],
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
