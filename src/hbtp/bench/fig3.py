"""Figure 3 of the paper: planning time against the size of the action space, and against |p*|.

(a) RobotHow with its objects cloned ``factor`` times (:mod:`hbtp.domains.scale`; 7329 actions at 1x,
about 62,600 at 3x); each planner plans the first Table I tasks in the full action space: BT
Expansion and OBTEA without hints, HBTP-O and HBTP-S with the records' plans as p̂ (oracle); with
``--space pruned`` all four plan in the records' pruned spaces instead. A run that hits the time
limit counts with the limit as its time (so means are lower bounds). (b) The same runs at 1x,
grouped by the length of the optimal path |p*|.
"""

from __future__ import annotations

from collections.abc import Sequence
from dataclasses import dataclass
from pathlib import Path
from typing import Any, Literal

from tqdm import tqdm

from hbtp.bench.results import ResultsFile, mean, median, write_json
from hbtp.datasets import load_dataset, validate_records
from hbtp.domains import load_scenario
from hbtp.domains.scale import scaled_scenario
from hbtp.planning import Limits, hints_from_record, plan
from hbtp.planning.heuristics import HeuristicName

DATASET = "table1_robothow_100"
KEY = ("scale", "task", "planner", "space", "heuristic")
HINTED = ("hbtp-o", "hbtp-s")


@dataclass(frozen=True)
class Fig3Config:
    scales: tuple[float, ...] = (1.0, 1.5, 2.0, 2.5, 3.0)
    planners: tuple[str, ...] = ("bte", "obtea", "hbtp-o", "hbtp-s")
    space: Literal["full", "pruned"] = "full"
    heuristic: HeuristicName = "none"
    time_limit: float = 5.0
    limit: int | None = 20


def run_fig3(config: Fig3Config, out: Path, *, progress: bool = True) -> dict[str, Any]:
    """Run (or resume) Figure 3 into ``out``; returns the summary (also summary.json, fig3.png)."""
    base = load_scenario("robothow")
    records = load_dataset(DATASET)
    invalid = set(validate_records(records, base.task).invalid_ids)
    records = [r for r in records if r.id not in invalid][: config.limit]
    results = ResultsFile(out / "results.jsonl", KEY)
    keys = [
        (scale, r.id, planner, config.space, config.heuristic)
        for scale in config.scales
        for r in records
        for planner in config.planners
    ]
    bar = tqdm(total=len(keys), desc="fig3", disable=not progress, unit="run")
    for scale in config.scales:
        mine = [k for k in keys if k[0] == scale]
        if all(k in results for k in mine):
            bar.update(len(mine))
            continue
        scenario = scaled_scenario("robothow", scale)
        for record in records:
            for planner in config.planners:
                if (scale, record.id, planner, config.space, config.heuristic) in results:
                    bar.update(1)
                    continue
                hinted = config.space == "pruned" or planner in HINTED
                hints = hints_from_record(record) if hinted else None
                result = plan(
                    scenario.task,
                    record.goal,
                    planner,
                    hints=hints,
                    space=config.space,
                    mutexes=scenario.mutexes,
                    heuristic=config.heuristic,
                    limits=Limits(time_s=config.time_limit),
                )
                results.append(
                    {
                        "scale": scale,
                        "actions": len(scenario.task.actions),
                        "task": record.id,
                        "p_star": len(record.optimal_actions),
                        "planner": planner,
                        "space": config.space,
                        "heuristic": config.heuristic,
                        "action_space": result.stats.action_space,
                        "status": result.status.value,
                        "solved": result.solved,
                        "explored": result.stats.explored,
                        "time_s": round(result.stats.time_s, 6),
                    }
                )
                bar.update(1)
    bar.close()
    summary = summarise(list(results.ordered(keys)), config)
    write_json(out / "summary.json", summary)
    plot_fig3(summary, out / "fig3.png")
    return summary


def summarise(rows: Sequence[dict[str, Any]], config: Fig3Config) -> dict[str, Any]:
    by_size = []
    for scale in config.scales:
        for planner in config.planners:
            mine = [r for r in rows if r["scale"] == scale and r["planner"] == planner]
            if not mine:
                continue
            by_size.append(
                {
                    "scale": scale,
                    "actions": mine[0]["actions"],
                    "planner": planner,
                    "tasks": len(mine),
                    "solved": sum(r["solved"] for r in mine),
                    "mean_time_s": mean([r["time_s"] for r in mine]),
                    "median_time_s": median([r["time_s"] for r in mine]),
                }
            )
    by_length = []
    base = [r for r in rows if r["scale"] == config.scales[0]]
    for planner in config.planners:
        for length in sorted({r["p_star"] for r in base}):
            mine = [r for r in base if r["planner"] == planner and r["p_star"] == length]
            by_length.append(
                {
                    "planner": planner,
                    "p_star": length,
                    "tasks": len(mine),
                    "solved": sum(r["solved"] for r in mine),
                    "mean_time_s": mean([r["time_s"] for r in mine]),
                }
            )
    return {
        "dataset": DATASET,
        "config": {
            "scales": list(config.scales),
            "planners": list(config.planners),
            "space": config.space,
            "heuristic": config.heuristic,
            "time_limit": config.time_limit,
            "tasks": config.limit,
        },
        "by_action_space": by_size,
        "by_path_length": by_length,
    }


def plot_fig3(summary: dict[str, Any], path: Path) -> bool:
    """Time against |A| and against |p*| per planner, if matplotlib (the plot extra) is installed."""
    try:
        import matplotlib

        matplotlib.use("Agg")
        import matplotlib.pyplot as plt
    except ImportError:
        return False
    figure, (left, right) = plt.subplots(1, 2, figsize=(11, 3.8))
    for planner in summary["config"]["planners"]:
        points = [(c["actions"], c["mean_time_s"]) for c in summary["by_action_space"] if c["planner"] == planner]
        left.plot([x for x, _ in points], [y for _, y in points], marker="o", label=planner)
        points = [(c["p_star"], c["mean_time_s"]) for c in summary["by_path_length"] if c["planner"] == planner]
        right.plot([x for x, _ in points], [y for _, y in points], marker="o", label=planner)
    space = summary["config"]["space"]
    left.set(title=f"(a) time vs |A| ({space} space)", xlabel="grounded actions |A|", ylabel="mean time (s)")
    right.set(title="(b) time vs |p*| (1x)", xlabel="optimal path length |p*|", ylabel="mean time (s)")
    for axis in (left, right):
        axis.set_yscale("log")
        axis.legend()
    figure.tight_layout()
    path.parent.mkdir(parents=True, exist_ok=True)
    figure.savefig(path, dpi=110)
    plt.close(figure)
    return True
