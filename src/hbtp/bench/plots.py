"""PNG plots of the benchmarks (matplotlib, the ``plot`` extra; without it no plot is drawn).

Every function takes a benchmark's summary and a path, and returns whether it wrote the picture.
"""

from __future__ import annotations

import logging
from pathlib import Path
from typing import Any

log = logging.getLogger(__name__)

PLANNER_LABELS = {"bte": "BT Expansion", "obtea": "OBTEA", "hbtp-o": "HBTP-O", "hbtp-s": "HBTP-S"}


def _pyplot() -> Any:
    """``matplotlib.pyplot`` with the Agg back-end, or ``None`` without the plot extra."""
    try:
        import matplotlib

        matplotlib.use("Agg")
        import matplotlib.pyplot as plt
    except ImportError:
        log.info("matplotlib is not installed (pip install 'hbtp[plot]'): no plots")
        return None
    return plt


def _save(plt: Any, figure: Any, path: Path) -> bool:
    figure.tight_layout()
    path.parent.mkdir(parents=True, exist_ok=True)
    # No timestamp in the PNG's metadata: the same summary gives the same bytes.
    figure.savefig(path, dpi=110, metadata={"Software": None})
    plt.close(figure)
    return True


def plot_table1(summaries: dict[str, dict[str, Any]], path: Path) -> bool:
    """Explored conditions |S⁻| and mean planning time per planner, one group of bars per setting."""
    plt = _pyplot()
    if plt is None:
        return False
    figure, (left, right) = plt.subplots(1, 2, figsize=(11, 3.8))
    settings = list(summaries)
    planners = list(dict.fromkeys(name for summary in summaries.values() for name in summary["planners"]))
    width = 0.8 / max(1, len(settings))
    for index, setting in enumerate(settings):
        rows = summaries[setting]["planners"]
        xs = [i + index * width for i in range(len(planners))]
        left.bar(xs, [rows.get(p, {}).get("mean_explored") or 0 for p in planners], width, label=setting)
        right.bar(xs, [(rows.get(p, {}).get("mean_time_s") or 0) * 1000 for p in planners], width, label=setting)
    for axis, label in ((left, "explored conditions |S⁻| (solved)"), (right, "mean planning time (ms)")):
        axis.set_xticks([i + width * (len(settings) - 1) / 2 for i in range(len(planners))])
        axis.set_xticklabels([PLANNER_LABELS.get(p, p) for p in planners])
        axis.set_ylabel(label)
        axis.set_yscale("log")
        axis.legend(fontsize=8)
    left.set_title("Table I: search effort")
    right.set_title("Table I: planning time")
    return _save(plt, figure, path)


def plot_table2(summaries: list[dict[str, Any]], path: Path) -> bool:
    """NF / 1F / 3F / final success per scenario, ours beside the paper's."""
    plt = _pyplot()
    if plt is None:
        return False
    figure, axis = plt.subplots(figsize=(10, 3.8))
    columns = ("NF", "1F", "3F", "final")
    names = [s["scenario"] for s in summaries]
    width = 0.8 / len(columns)
    for index, column in enumerate(columns):
        xs = [i + index * width for i in range(len(names))]
        axis.bar(xs, [s[column] or 0 for s in summaries], width, label=f"ours {column}")
        paper = [s["paper"].get(column) for s in summaries]
        axis.scatter(
            [x for x, v in zip(xs, paper, strict=True) if v is not None],
            [v for v in paper if v is not None],
            marker="_",
            s=300,
            color="black",
            label="paper" if index == 0 else None,
        )
    axis.set_xticks([i + width * (len(columns) - 1) / 2 for i in range(len(names))])
    axis.set_xticklabels(names)
    axis.set(
        ylabel="success (%)", ylim=(0, 120), title=f"Table II: success by feedback rounds ({_backends(summaries)})"
    )
    axis.set_yticks(range(0, 101, 20))
    axis.legend(fontsize=8, ncol=5, loc="upper center")
    return _save(plt, figure, path)


def _backends(summaries: list[dict[str, Any]]) -> str:
    return ", ".join(sorted({str(s["backend"]) for s in summaries}))


def plot_robustness(summary: dict[str, Any], path: Path) -> bool:
    """Success under perturbations, full tree against path-only tree, per scenario and p."""
    plt = _pyplot()
    if plt is None:
        return False
    blocks = summary["scenarios"]
    names = list(blocks)
    p_values = [str(p) for p in summary["config"]["p_values"]]
    figure, axes = plt.subplots(1, len(p_values), figsize=(5.5 * len(p_values), 3.8), squeeze=False)
    for axis, p in zip(axes[0], p_values, strict=True):
        for index, tree in enumerate(("full", "path")):
            xs = [i + index * 0.4 for i in range(len(names))]
            values = [100 * (blocks[name]["p"][p][tree]["success_rate"] or 0) for name in names]
            axis.bar(xs, values, 0.4, label=f"{tree} tree")
        axis.set_xticks([i + 0.2 for i in range(len(names))])
        axis.set_xticklabels(names, fontsize=8)
        axis.set(ylabel="runs reaching the goal (%)", ylim=(0, 105), title=f"perturbation p = {p} per tick")
        axis.legend(fontsize=8, loc="lower left")
    return _save(plt, figure, path)


def plot_fig3(summary: dict[str, Any], path: Path) -> bool:
    """Time against |A| and against |p*| per planner, if matplotlib (the plot extra) is installed."""
    plt = _pyplot()
    if plt is None:
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
    return _save(plt, figure, path)


def plot_fig4(summary: dict[str, Any], path: Path) -> bool:
    """The three panels of the paper's Figure 4, if matplotlib (the plot extra) is installed."""
    plt = _pyplot()
    if plt is None:
        return False
    cells = summary["cells"]
    figure, axes = plt.subplots(1, 3, figsize=(13, 3.6))
    panels = [("hbtp-o", "mean_explored", "HBTP-O |S⁻|"), ("hbtp-s", "mean_explored", "HBTP-S |S⁻|")]
    for axis, (planner, field, title) in zip(axes[:2], panels, strict=True):
        for error in summary["config"]["error_rates"]:
            points = [(c["correct"], c[field]) for c in cells if c["planner"] == planner and c["error"] == error]
            axis.plot([x for x, _ in points], [y for _, y in points], marker="o", label=f"ER={error}")
        axis.set(title=title, xlabel="correct rate of p̂", ylabel="explored conditions")
        axis.legend()
    for planner in summary["config"]["planners"]:
        for error in summary["config"]["error_rates"]:
            points = [(c["correct"], c["mean_cost"]) for c in cells if c["planner"] == planner and c["error"] == error]
            axes[2].plot([x for x, _ in points], [y for _, y in points], marker=".", label=f"{planner} ER={error}")
    axes[2].set(title="D(T)", xlabel="correct rate of p̂", ylabel="cost of the executed actions")
    axes[2].legend(fontsize=7)
    return _save(plt, figure, path)
