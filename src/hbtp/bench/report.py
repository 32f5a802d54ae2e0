"""Markdown reports of the benchmarks: our numbers beside the paper's and the reference
implementation's (``../shared/reference/reference_results.md`` figures, kept in the bench modules).

Each function turns one benchmark's summary (as written to summary.json) into a Markdown section.
"""

from __future__ import annotations

from collections.abc import Sequence
from pathlib import Path
from typing import Any

from hbtp.bench.plots import PLANNER_LABELS
from hbtp.files import write_atomically

#: The phases of ``bench payoff``'s times (its rows' ``*_s`` fields), in the report's order.
PAYOFF_PHASES = ("total_s", "solve_s", "load_s", "model_s", "planning_s", "verify_s")


def _num(value: Any, digits: int = 2) -> str:
    if value is None:
        return "–"
    if isinstance(value, str):
        return value
    return f"{value:.{digits}f}"


def _ms(seconds: float | None) -> str:
    return "–" if seconds is None else f"{seconds * 1000:.2f}"


def _table(header: Sequence[str], rows: Sequence[Sequence[Any]]) -> str:
    """A Markdown table; ``|`` inside a cell (as in ``|S⁻|``) is escaped."""

    def line(cells: Sequence[Any]) -> str:
        return "| " + " | ".join(str(cell).replace("|", "\\|") for cell in cells) + " |"

    return "\n".join([line(header), "|" + "---|" * len(header), *(line(row) for row in rows)])


def table1_section(summaries: dict[str, dict[str, Any]]) -> str:
    """Table I, one table per setting (e.g. ``pruned``, ``full``, ``full, no hints, lm``)."""
    parts = ["## Table I: the four planners on the 100 Table I tasks (RobotHow, |A| = 7329)"]
    for label, summary in summaries.items():
        config = summary["config"]
        paper, reference = summary["paper"], summary["reference"]
        parts.append(
            f"### {label}\n\nspace `{config['space']}`, hints `{config['hints']}`, heuristic `{config['heuristic']}`, "
            f"{config['time_limit']:g} s per task, {_tasks(summary)} tasks."
        )
        rows = []
        for name, row in summary["planners"].items():
            ours_paper = paper.get(name, {})
            ours_reference = reference.get(name, {})
            rows.append(
                [
                    PLANNER_LABELS.get(name, name),
                    f"{row['solved']}/{row['tasks']}",
                    row["timeouts"],
                    _num(row["mean_explored"]),
                    _num(row["mean_cost"]),
                    _ms(row["mean_time_s"]),
                    _ms(row["median_time_s"]),
                    _paper_cell(ours_paper),
                    _paper_cell(ours_reference, reference=True),
                ]
            )
        parts.append(
            _table(
                ["planner", "solved", "timeouts", "|S⁻|", "D(T)", "mean ms", "median ms", "paper", "reference"], rows
            )
        )
    parts.append("![Table I](table1.png)")
    return "\n\n".join(parts)


def _tasks(summary: dict[str, Any]) -> int:
    return max((row["tasks"] for row in summary["planners"].values()), default=0)


def _paper_cell(figures: dict[str, Any], reference: bool = False) -> str:
    if not figures:
        return "–"
    bits = []
    if "explored" in figures:
        bits.append(f"|S⁻| {figures['explored']}")
    if "cost" in figures:
        bits.append(f"D(T) {figures['cost']}")
    if "timeout_rate" in figures:
        bits.append(f"timeouts {100 * figures['timeout_rate']:.0f}%")
    if reference and "median_time_s" in figures:
        bits.append(f"median {figures['median_time_s'] * 1000:.0f} ms")
    return ", ".join(bits)


def table2_section(summaries: list[dict[str, Any]]) -> str:
    """Table II: problem scale, oracle columns, LLM columns and B-Time, ours then the paper's."""
    if not summaries:
        return "## Table II\n\n(no scenario run)"
    first = summaries[0]
    parts = [
        f"## Table II: LLM reasoning with HBTP (backend `{first['backend']}`, {first['runs']} run(s), "
        f"{first['tasks']} rows per scenario)",
        "NF / 1F / 3F: success with no, at most one, at most three feedback rounds; final: also with the "
        "full-space fallback. |A⁻|, |p̂|, |S⁻|: means over the successful LLM rounds. B-Time: OBTEA in the "
        f"full space without a heuristic, {first.get('b_time_limit', 0):g} s limit (solved/tasks, mean s; "
        "the paper's B-Time has no limit); B-Time lm: the same search with hbtp's landmark heuristic.",
    ]
    rows = [row for s in summaries for row in _table2_rows(s)]
    header = ["scenario", "|A|", "|Q|", "|O|", "|A*|", "|p*|", "NF %", "1F %", "3F %", "final %", "|A⁻|", "|p̂|"]
    header += ["|S⁻|", "plan ms", "LLM s", "B-Time", "B-Time lm"]
    parts.append(_table(header, rows))
    per_run = [s for s in summaries if s.get("NF_per_run")]
    if per_run:
        parts.append(
            "NF per run: " + "; ".join(f"{s['scenario']} {', '.join(map(str, s['NF_per_run']))}" for s in per_run)
        )
    parts.append("![Table II](table2.png)")
    return "\n\n".join(parts)


def _table2_rows(s: dict[str, Any]) -> list[list[Any]]:
    """One scenario's Table II rows: ours, then the paper's (when it has the scenario)."""
    problem = s["problem"]
    rows: list[list[Any]] = [
        [
            f"{s['scenario']} (ours)",
            problem["A"],
            problem["Q"],
            problem["O"],
            _num(s.get("A_star")),
            _num(s.get("p_star")),
            _num(s["NF"]),
            _num(s["1F"]),
            _num(s["3F"]),
            _num(s["final"]),
            _num(s["A_minus"]),
            _num(s["p_hat"]),
            _num(s["explored"]),
            _ms(s["mean_planning_s"]),
            _num(s["mean_llm_s"]),
            _b_time(s, "b"),
            _b_time(s, "b_lm"),
        ]
    ]
    paper = s["paper"]
    if paper:
        rows.append(
            [
                f"{s['scenario']} (paper)",
                paper["A"],
                paper["Q"],
                paper["O"],
                paper["A_star"],
                paper["p_star"],
                paper["NF"],
                paper["1F"],
                paper["3F"],
                "–",
                paper["A_minus"],
                paper["p_hat"],
                paper["explored"],
                _ms(paper["time_s"]),
                "–",
                paper["b_time"],
                "–",
            ]
        )
    return rows


def _b_time(summary: dict[str, Any], prefix: str) -> str:
    tasks = summary.get("b_tasks") or 0
    if not tasks:
        return "–"
    return f"{summary[f'{prefix}_solved']}/{tasks}, {_num(summary[f'{prefix}_mean_time_s'], 3)} s"


def fig3_section(summary: dict[str, Any]) -> str:
    """Figure 3: time against |A| (a) and against |p*| (b)."""
    config = summary["config"]
    rows = [
        [
            c["scale"],
            c["actions"],
            PLANNER_LABELS.get(c["planner"], c["planner"]),
            f"{c['solved']}/{c['tasks']}",
            _ms(c["mean_time_s"]),
            _ms(c["median_time_s"]),
        ]
        for c in summary["by_action_space"]
    ]
    lengths = [
        [
            PLANNER_LABELS.get(c["planner"], c["planner"]),
            c["p_star"],
            f"{c['solved']}/{c['tasks']}",
            _ms(c["mean_time_s"]),
        ]
        for c in summary["by_path_length"]
    ]
    return "\n\n".join(
        [
            f"## Figure 3: planning time against |A| and |p*| ({config['space']} space, heuristic "
            f"{config['heuristic']})",
            f"RobotHow with its objects cloned (scales {', '.join(map(str, config['scales']))}), "
            f"{config['time_limit']:g} s per run (a timed-out run counts with its limit); "
            + (
                "every planner in the records' pruned spaces (which do not grow with the clones). "
                if config["space"] == "pruned"
                else "BT Expansion and OBTEA without hints, HBTP-O and HBTP-S with the records' plans as p̂. "
            )
            + "Paper: BTE and OBTEA grow steeply with |A| and time out; HBTP stays nearly flat.",
            _table(["scale", "|A|", "planner", "solved", "mean ms", "median ms"], rows),
            "(b) by optimal path length |p*| at scale 1:",
            _table(["planner", "|p*|", "solved", "mean ms"], lengths),
            "![Figure 3](fig3.png)",
        ]
    )


def fig4_section(summary: dict[str, Any]) -> str:
    """Figure 4: |S⁻| and D(T) against the correct rate of p̂, per error rate."""
    config = summary["config"]
    rows = [
        [
            PLANNER_LABELS.get(c["planner"], c["planner"]),
            c["error"],
            c["correct"],
            f"{c['solved']}/{c['runs']}",
            _num(c["mean_explored"]),
            _num(c["mean_cost"]),
        ]
        for c in summary["cells"]
    ]
    return "\n\n".join(
        [
            "## Figure 4: error tolerance of HBTP-O and HBTP-S",
            f"Noisy heuristic paths (each optimal action kept with the correct rate; error rate × |p*| wrong "
            f"actions inserted), {config['seeds']} seed(s), pruned spaces of the Table I tasks. Paper: |S⁻| falls "
            "as p̂ gets more right and rises with the error rate; HBTP-O's D(T) stays optimal, HBTP-S's "
            "rises a little with errors.",
            _table(["planner", "error rate", "correct rate", "solved", "|S⁻|", "D(T)"], rows),
            "![Figure 4](fig4.png)",
        ]
    )


def robustness_section(summary: dict[str, Any]) -> str:
    """Perturbations: the full tree against the path-only tree."""
    config = summary["config"]
    rows = []
    for name, block in summary["scenarios"].items():
        for p, entry in block["p"].items():
            for tree in config.get("trees", ["full", "path"]):
                row = entry[tree]
                rows.append(
                    [
                        name,
                        p,
                        tree,
                        _num(100 * row["success_rate"] if row["success_rate"] is not None else None, 1),
                        _num(row["mean_extra_ticks"]),
                        _num(row["mean_extra_cost"]),
                        _num(row["mean_nodes"], 1),
                        _num(row.get("mean_base_ticks"), 1),
                        _num(row.get("mean_condition_checks"), 1),
                        f"{entry['full_better']} / {entry['path_better']}" if tree == "full" else "",
                    ]
                )
    return "\n\n".join(
        [
            "## Robustness: full tree against path-only tree under perturbations",
            f"{config['planner']} with heuristic `{config['heuristic']}`, {config['runs']} perturbed runs per task, "
            f"tree and p, seed {config['seed']}, at most {config['max_ticks']} ticks. Ticks and condition checks "
            "(BTPG's tick count: condition nodes ticked) are those of the undisturbed run. Not in the paper; "
            "the reference outputs the path-only tree.",
            _table(
                [
                    "scenario",
                    "p",
                    "tree",
                    "success %",
                    "extra ticks",
                    "extra cost",
                    "nodes",
                    "ticks",
                    "condition checks",
                    "tasks full > path / path > full",
                ],
                rows,
            ),
            *_replanning_table(summary),
            "![Robustness](robustness.png)",
        ]
    )


def _replanning_table(summary: dict[str, Any]) -> list[str]:
    """With re-planning: the runs whose goal stayed reachable, re-plans and their times."""
    trees = [t for t in summary["config"].get("trees", []) if t.endswith("+replan")]
    if not trees:
        return []
    rows = [
        [
            name,
            p,
            tree,
            f"{entry[tree]['reachable_runs_succeeded']} / {entry[tree]['reachable_runs']}",
            entry[tree]["unsolvable_runs"],
            _num(entry[tree]["mean_replans"]),
            _num(entry[tree]["median_replan_ms"], 2),
            _num(entry[tree]["max_replan_ms"], 1),
            _num(entry[tree].get("median_plan_ms_replanned"), 2),
        ]
        for name, block in summary["scenarios"].items()
        for p, entry in block["p"].items()
        for tree in trees
    ]
    header = ["scenario", "p", "tree", "reached / goal still reachable", "runs unsolvable from their state"]
    header += ["re-plans per run", "median re-plan ms", "max re-plan ms", "median plan ms from s0, same tasks"]
    return [
        "With re-planning (`--replan`: OBTEA with the landmark heuristic from the state the tree fails in; "
        "at most 10 re-plans and 30 s of re-planning per run):",
        _table(header, rows),
    ]


def _s(value: float | None) -> str:
    return "–" if value is None else f"{value:.3f}"


def payoff_section(summary: dict[str, Any]) -> str:
    """The per-cell medians, the guided/LLM-free ratios and where the curves cross."""
    rows = []
    for cell in summary["cells"]:
        for name, stats in cell["configs"].items():
            against = cell["against"].get(name, {})
            rows.append(
                [
                    cell["axis"],
                    cell["cell"],
                    cell["actions"],
                    name,
                    f"{stats['verified']}/{stats['tasks']}",
                    *(_s(stats[f"median_{phase}"]) for phase in PAYOFF_PHASES),
                    _s(against.get("median_ratio_total")),
                    _s(against.get("median_ratio_solve")),
                    against.get("wins_total", "–"),
                    "–" if stats.get("max_peak_mb") is None else stats["max_peak_mb"],
                ]
            )
    header = ["axis", "cell", "|A|", "configuration", "verified", "total s", "solve s", "load s", "model s"]
    header += ["planning s", "verify s", "ratio total", "ratio solve", "wins", "peak MB"]
    cross = [
        [axis, name, measure, ", ".join(c["faster_in"]) or "nowhere", ", ".join(c["crosses"]) or "–"]
        for axis, by_name in summary["crossings"].items()
        for name, by_measure in by_name.items()
        for measure, c in by_measure.items()
    ]
    config = summary["config"]
    return "\n\n".join(
        [
            "## End-to-end time to a verified tree: LLM-guided HBTP against the best LLM-free planner",
            f"{config['tasks']} tasks per cell; LLM-free: OBTEA and HBTP-S with the landmark heuristic, no hints, "
            f"{config['time_limit']:g} s; LLM-guided: HBTP-S rounds of {config['round_time_limit']:g} s, "
            f"{config['feedback_rounds']} feedback rounds, the full-space fallback. Medians over the verified "
            "trees; total = load + model + planning + verification, solve = total without the load; ratios are "
            "medians over the tasks of guided / best LLM-free (below 1: the LLM pays); wins: tasks where "
            "guidance reached a verified tree first; peak MB: the most resident memory of a worker that ran the "
            "configuration (a run's own with --fresh-workers). "
            f"Runs: {summary['runs']}, unverified: {summary['unverified']}.",
            _table(header, rows),
            "Where the curves cross (medians, LLM-guided against best LLM-free):",
            _table(["axis", "configuration", "measure", "guided faster in", "order flips between"], cross),
            "![payoff](payoff.png)",
        ]
    )


def write_report(path: Path, title: str, sections: Sequence[str]) -> None:
    """``report.md``: a title, then the sections."""
    write_atomically(path, f"# {title}\n\n" + "\n\n".join(sections).rstrip() + "\n", create_folders=True)


__all__ = [
    "PAYOFF_PHASES",
    "fig3_section",
    "fig4_section",
    "payoff_section",
    "robustness_section",
    "table1_section",
    "table2_section",
    "write_report",
]
