"""PNG plots of the benchmarks (matplotlib, the ``plot`` extra; without it no plot is drawn).

Every function takes a benchmark's summary and a path, and returns whether it wrote the picture.
"""

from __future__ import annotations

import io
import logging
from collections.abc import Sequence
from dataclasses import dataclass
from pathlib import Path
from typing import Any

from hbtp.files import write_atomically

log = logging.getLogger(__name__)

PLANNER_LABELS = {
    "bte": "BT Expansion",
    "obtea": "OBTEA",
    "hbtp-o": "HBTP-O",
    "hbtp-s": "HBTP-S",
    "fast-downward": "Fast Downward (A* + LM-cut)",
}
HEURISTIC_LABELS = {"none": "no heuristic", "lm": "landmark heuristic (lm)", "hmax": "h_max heuristic"}
#: Series on one panel get distinct markers (drawn smaller one after the other) and line styles, so
#: that lines on top of each other all stay visible.
MARKERS = ("o", "s", "^", "D", "v", "P", "X", "*")
LINE_STYLES = ("-", "--", "-.", ":")


@dataclass(frozen=True)
class Series:
    """One line: its label is ``prefix + variant`` (``ER=`` and ``0.5``)."""

    prefix: str
    variant: str
    xs: tuple[float, ...]
    ys: tuple[float | None, ...]

    @property
    def label(self) -> str:
        return self.prefix + self.variant


def merge_identical(series: Sequence[Series]) -> list[tuple[int, str, Series]]:
    """Each distinct line once, as (index of its first series, label, series); lines with exactly the
    same points would hide each other, so they are drawn once and labelled with every variant:
    ``ER=0/0.5/1 (identical)``, a line per prefix."""
    groups: dict[tuple[tuple[float, ...], tuple[float | None, ...]], list[int]] = {}
    for index, line in enumerate(series):
        groups.setdefault((line.xs, line.ys), []).append(index)
    merged = []
    for indices in groups.values():
        lines = [series[i] for i in indices]
        if len(lines) == 1:
            label = lines[0].label
        else:
            variants: dict[str, list[str]] = {}
            for line in lines:
                variants.setdefault(line.prefix, []).append(line.variant)
            label = "\n= ".join(prefix + "/".join(names) for prefix, names in variants.items()) + " (identical)"
        merged.append((indices[0], label, lines[0]))
    return merged


def _draw(axis: Any, series: Sequence[Series], size: float = 7.0) -> None:
    """Plot ``series`` on ``axis``: identical ones merged; the others with distinct markers, line
    styles and marker sizes (the later ones smaller, so that points on top of each other all show).
    A series keeps its colour and marker from panel to panel."""
    for index, label, line in merge_identical(series):
        axis.plot(
            line.xs,
            [float("nan") if y is None else y for y in line.ys],
            color=f"C{index % 10}",
            marker=MARKERS[index % len(MARKERS)],
            linestyle=LINE_STYLES[index % len(LINE_STYLES)],
            markersize=max(3.0, size - 1.2 * (index % 4)),
            label=label,
        )


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
    # No timestamp in the PNG's metadata: the same summary gives the same bytes.
    picture = io.BytesIO()
    figure.savefig(picture, format="png", dpi=110, metadata={"Software": None})
    plt.close(figure)
    write_atomically(path, picture.getvalue(), create_folders=True)
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
    trees = summary["config"].get("trees", ["full", "path"])
    width = 0.8 / len(trees)
    figure, axes = plt.subplots(1, len(p_values), figsize=(5.5 * len(p_values), 3.8), squeeze=False)
    for axis, p in zip(axes[0], p_values, strict=True):
        for index, tree in enumerate(trees):
            xs = [i + index * width for i in range(len(names))]
            values = [100 * (blocks[name]["p"][p][tree]["success_rate"] or 0) for name in names]
            axis.bar(xs, values, width, label=f"{tree} tree")
        axis.set_xticks([i + 0.4 - width / 2 for i in range(len(names))])
        axis.set_xticklabels(names, fontsize=8)
        # The legend sits in the free band above 100 %, clear of the bars.
        axis.set(ylabel="runs reaching the goal (%)", ylim=(0, 120), title=f"perturbation p = {p} per tick")
        axis.set_yticks(range(0, 101, 20))
        axis.legend(fontsize=8, loc="upper center", ncol=len(trees))
    return _save(plt, figure, path)


def fig3_title(config: dict[str, Any]) -> str:
    """What a Figure 3 plot shows: ``full space, no heuristic`` or ``pruned spaces, landmark ...``."""
    space = "pruned spaces (the records')" if config["space"] == "pruned" else "full space"
    heuristic = config.get("heuristic", "none")
    return f"Figure 3: {space}, {HEURISTIC_LABELS.get(heuristic, f'heuristic {heuristic}')}"


def plot_fig3(summary: dict[str, Any], path: Path) -> bool:
    """Time against |A| and against |p*| per planner, if matplotlib (the plot extra) is installed."""
    plt = _pyplot()
    if plt is None:
        return False
    figure, (left, right) = plt.subplots(1, 2, figsize=(11, 4.1))
    by_size, by_length = [], []
    for planner in summary["config"]["planners"]:
        name = PLANNER_LABELS.get(planner, planner)
        points = [(c["actions"], c["mean_time_s"]) for c in summary["by_action_space"] if c["planner"] == planner]
        by_size.append(Series("", name, tuple(x for x, _ in points), tuple(y for _, y in points)))
        points = [(c["p_star"], c["mean_time_s"]) for c in summary["by_path_length"] if c["planner"] == planner]
        by_length.append(Series("", name, tuple(x for x, _ in points), tuple(y for _, y in points)))
    _draw(left, by_size)
    _draw(right, by_length)
    figure.suptitle(fig3_title(summary["config"]))
    left.set(title="(a) time vs |A|", xlabel="grounded actions |A|", ylabel="mean time (s)")
    right.set(title="(b) time vs |p*| (scale 1)", xlabel="optimal path length |p*|", ylabel="mean time (s)")
    for axis in (left, right):
        axis.set_yscale("log")
        axis.legend(fontsize=8)
    return _save(plt, figure, path)


def plot_fig4(summary: dict[str, Any], path: Path) -> bool:
    """The three panels of the paper's Figure 4, if matplotlib (the plot extra) is installed.

    Lines with the same values (HBTP-O's optimal D(T) at every error rate) are drawn once with all
    their labels; the others get distinct markers and line styles, so none hides another.
    """
    plt = _pyplot()
    if plt is None:
        return False
    cells = summary["cells"]
    config = summary["config"]

    def series(planner: str, field: str, prefix: str) -> list[Series]:
        lines = []
        for error in config["error_rates"]:
            points = [(c["correct"], c[field]) for c in cells if c["planner"] == planner and c["error"] == error]
            lines.append(Series(prefix, f"{error:g}", tuple(x for x, _ in points), tuple(y for _, y in points)))
        return lines

    figure, axes = plt.subplots(1, 3, figsize=(15, 3.8), width_ratios=(1, 1, 1.3))
    for axis, planner in zip(axes[:2], ("hbtp-o", "hbtp-s"), strict=True):
        _draw(axis, series(planner, "mean_explored", "ER="))
        axis.set(title=f"{PLANNER_LABELS[planner]} |S⁻|", xlabel="correct rate of p̂", ylabel="explored conditions")
        axis.legend(fontsize=8)
    _draw(
        axes[2],
        [
            line
            for planner in config["planners"]
            for line in series(planner, "mean_cost", f"{PLANNER_LABELS.get(planner, planner)} ER=")
        ],
    )
    axes[2].set(title="D(T)", xlabel="correct rate of p̂", ylabel="cost of the executed actions")
    # Beside the panel: inside it would cover the lines, which fill the D(T) range.
    axes[2].legend(fontsize=7, loc="upper left", bbox_to_anchor=(1.02, 1.0), borderaxespad=0)
    return _save(plt, figure, path)


def plot_payoff(summary: dict[str, Any], path: Path) -> bool:
    """``bench payoff``: median time to a verified tree per configuration, against |A| (the grown
    worlds: with the load, and without it), the Table II sets and the generated levels, if matplotlib
    is installed."""
    plt = _pyplot()
    if plt is None:
        return False
    cells = summary["cells"]
    names = list(dict.fromkeys(name for c in cells for name in c["configs"]))

    def series(axis: str, measure: str) -> list[Series]:
        chosen = [c for c in cells if c["axis"] == axis]
        xs = tuple(float(c["actions"] or 0) if axis == "size" else float(i) for i, c in enumerate(chosen))
        return [
            Series("", name, xs, tuple(c["configs"].get(name, {}).get(f"median_{measure}") for c in chosen))
            for name in names
        ]

    figure, axes = plt.subplots(2, 2, figsize=(12, 8.4))
    panels = (
        ("size", "total_s", "(a) RobotHow grown: load + model + planning + verification", "grounded actions |A|"),
        ("size", "solve_s", "(b) the same without the load (world kept loaded)", "grounded actions |A|"),
        ("set", "total_s", "(c) Table II sets (by mean |p*|), with the load", "test set"),
        ("level", "total_s", "(d) generated RobotHow tasks, with the load", "difficulty level"),
    )
    for axis, (kind, measure, title, xlabel) in zip(axes.flat, panels, strict=True):
        _draw(axis, series(kind, measure))
        axis.set(title=title, xlabel=xlabel, ylabel="median seconds to a verified tree")
        if kind != "size":
            labels = [c["cell"] for c in cells if c["axis"] == kind]
            axis.set_xticks(range(len(labels)), labels)
        axis.set_yscale("log")
        axis.legend(fontsize=7)
    figure.suptitle("When does the LLM pay? LLM-guided HBTP against LLM-free planning")
    return _save(plt, figure, path)


def plot_pddl_coverage(summary: dict[str, Any], path: Path) -> bool:
    """``bench pddl``: instances solved (verified) within t seconds (load + planning), per planner."""
    plt = _pyplot()
    if plt is None:
        return False
    figure, axis = plt.subplots(figsize=(7, 4.6))
    limit = float(summary["config"]["time_limit"])
    for index, (planner, stats) in enumerate(summary["planners"].items()):
        times = [max(t, 1e-3) for t in stats["solve_times"]]
        xs = [1e-3, *times, 2 * limit]
        ys = [0, *range(1, len(times) + 1), len(times)]
        label = f"{PLANNER_LABELS.get(planner, planner)} ({len(times)}/{stats['instances']})"
        axis.step(xs, ys, where="post", color=f"C{index % 10}", linestyle=LINE_STYLES[index % 4], label=label)
    total = max((s["instances"] for s in summary["planners"].values()), default=0)
    axis.axhline(total, color="grey", linewidth=0.8, linestyle=":")
    axis.set_xscale("log")
    axis.set(
        title=f"Coverage over time (heuristic {summary['config']['heuristic']}, {limit:g} s per run)",
        xlabel="seconds (load + planning)",
        ylabel="instances solved (verified tree)",
    )
    axis.legend(fontsize=8, loc="upper left")
    return _save(plt, figure, path)
