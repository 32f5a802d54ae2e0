"""``hbtp bench robustness``: the full tree against the path-only tree under perturbations."""

from __future__ import annotations

from dataclasses import dataclass
from pathlib import Path
from typing import Any

import click

from hbtp.bench.robustness import MAX_TICKS, REPLANNED, SCENARIOS, RobustnessConfig, run_robustness
from hbtp.bench.runner import Execution
from hbtp.cli.bench_commands import execution_options, out_dir_option
from hbtp.cli.options import comma_choices, comma_numbers, option_group
from hbtp.cli.run_command import exit_codes
from hbtp.planning import PLANNERS
from hbtp.planning.heuristic_names import DEFAULT_HEURISTIC, HEURISTICS, HeuristicName, heuristic_named


def _figure(value: float | None, percent: bool = False) -> str:
    if value is None:
        return "-"
    return f"{100 * value:.1f}%" if percent else f"{value:+.2f}"


@dataclass(frozen=True)
class Replanning:
    """The re-planning asked for: whether at all, by repair, in the hints' space first, checked."""

    replan: bool
    repair: bool
    hints: bool
    check: bool


def _replanning(replan: bool | None, full_space: bool, check_replans: bool) -> Replanning:
    return Replanning(replan is not None, replan is not False, not full_space, check_replans)


#: The re-planning options, handed to :func:`_config` as ``replanning: Replanning``.
replanning_options = option_group(
    "replanning",
    _replanning,
    click.option(
        "--replan",
        "replan",
        flag_value=True,
        default=None,
        help="Also run each tree with re-planning from the state it fails in (rows full+replan, path+replan): "
        "each re-plan searches the record's hints' space first (widened by the objects the state changed), "
        "then the full space, continuing the last search there (repair).",
    ),
    click.option(
        "--replan-from-scratch",
        "replan",
        flag_value=False,
        help="As --replan, with a new search for each re-plan (for comparison).",
    ),
    click.option(
        "--replan-full-space",
        "full_space",
        is_flag=True,
        help="Re-plans search the full space only (the optimal tree from the state), not the hints' space first.",
    ),
    click.option(
        "--check-replans",
        is_flag=True,
        help="Check every re-plan the hints' space answered against a fresh search of the full space "
        "(the optimum from its state).",
    ),
)


def _config(
    p_text: str,
    runs: int,
    seed: int,
    scenario_text: str,
    planner: str,
    heuristic: HeuristicName,
    max_ticks: int,
    robust: int,
    limit: int | None,
    replanning: Replanning,
) -> RobustnessConfig:
    chosen = comma_choices(scenario_text, SCENARIOS, "--scenarios", "scenario")
    if runs < 1:
        raise click.BadParameter("must be at least 1", param_hint="--runs")
    if max_ticks < 1:
        raise click.BadParameter("must be at least 1", param_hint="--max-ticks")
    return RobustnessConfig(
        p_values=comma_numbers(p_text, "--p"),
        runs=runs,
        seed=seed,
        scenarios=chosen,
        limit=limit,
        max_ticks=max_ticks,
        planner=planner,
        heuristic=heuristic,
        robust=robust,
        replan=replanning.replan,
        repair=replanning.repair,
        replan_hints=replanning.hints,
        check_replans=replanning.check,
    )


#: What to run, handed to the command as one ``config: RobustnessConfig`` argument.
robustness_options = option_group(
    "config",
    _config,
    click.option("--p", "p_text", default="0.1,0.2", show_default=True, help="Comma-separated probabilities per tick."),
    click.option("--runs", type=int, default=20, show_default=True, help="Perturbed runs per task, tree and p."),
    click.option("--seed", type=int, default=0, show_default=True, help="Seed of the random events."),
    click.option(
        "--scenarios",
        "scenario_text",
        default=",".join(SCENARIOS),
        show_default=True,
        help="Comma-separated scenarios.",
    ),
    click.option(
        "--planner",
        type=click.Choice(list(PLANNERS)),
        default="hbtp-s",
        show_default=True,
        help="Planner of the trees.",
    ),
    click.option(
        "--heuristic",
        type=click.Choice(list(HEURISTICS)),
        default=DEFAULT_HEURISTIC.value,
        show_default=True,
        callback=lambda _context, _parameter, value: heuristic_named(value),
        help="LLM-free heuristic.",
    ),
    click.option(
        "--max-ticks", type=int, default=MAX_TICKS, show_default=True, help="Ticks per run before it counts as failed."
    ),
    click.option(
        "--robust", type=click.IntRange(0), default=0, show_default=True, help="Extra expansions after each solution."
    ),
    click.option("--limit", type=int, help="Only the first N tasks of each test set."),
    replanning_options,
)


def _echo_replanning(summary: dict[str, Any], config: RobustnessConfig) -> None:
    """The re-planning figures: runs reached of those still reachable, budget hits, re-plan and plan
    times (all, and those that searched), re-plans the hints' space answered, those recalled (answered
    before from the same state), and, checked, how many found the optimum."""
    how = ("from scratch" if not config.repair else "repair") + (", hints first" if config.replan_hints else "")
    click.echo(
        f"re-planning ({how}): {'scenario':15} {'p':>4} {'tree':11} {'reached':>13} {'budget':>6} "
        f"{'median replan ms':>16} {'searched':>8} {'max replan ms':>13} {'plan ms, same tasks':>19} {'hints/all':>10} "
        f"{'recalled':>8} {'optimal':>7}"
    )
    for name, block in summary["scenarios"].items():
        for p, entry in block["p"].items():
            for kind in REPLANNED:
                row = entry[kind]
                reached = f"{row['reachable_runs_succeeded']}/{row['reachable_runs']}"
                answered = f"{row['pruned_replans']}/{row['replans']}"
                optimal = "-" if row["optimal_replans"] is None else str(row["optimal_replans"])
                click.echo(
                    f"re-planning ({how}): {name:15} {p:>4} {kind:11} {reached:>13} {row['budget_runs']:>6} "
                    f"{_ms(row['median_replan_ms']):>16} {_ms(row['median_searched_replan_ms']):>8} "
                    f"{_ms(row['max_replan_ms']):>13} {_ms(row['median_plan_ms_replanned']):>19} {answered:>10} "
                    f"{row['recalled_replans'] or 0:>8} {optimal:>7}"
                )


def _ms(value: float | None) -> str:
    """Milliseconds to two places below 10 ms (re-plans of a fraction of one), else to one."""
    return "-" if value is None else f"{value:.2f}" if value < 10 else f"{value:.1f}"


@click.command("robustness")
@out_dir_option
@robustness_options
@execution_options
@exit_codes
def robustness(out_dir: str, config: RobustnessConfig, execution: Execution) -> int:
    """Full tree vs path-only tree on the Table II test sets, with random external events."""
    summary = run_robustness(config, Path(out_dir), execution)
    click.echo(
        f"{'scenario':15} {'p':>4} {'tree':5} {'success':>8} {'extra ticks':>12} {'extra cost':>11} "
        f"{'nodes':>7}  full>path  path>full"
    )
    for name, block in summary["scenarios"].items():
        for p, entry in block["p"].items():
            for kind in config.trees:
                row = entry[kind]
                better = f"{entry['full_better']:>9}  {entry['path_better']:>9}" if kind == "full" else ""
                nodes = f"{row['mean_nodes']:.1f}" if row["mean_nodes"] is not None else "-"
                click.echo(
                    f"{name:15} {p:>4} {kind:11} {_figure(row['success_rate'], True):>8} "
                    f"{_figure(row['mean_extra_ticks']):>12} {_figure(row['mean_extra_cost']):>11} {nodes:>7}  {better}"
                )
    if config.replan:
        _echo_replanning(summary, config)
    click.echo(f"wrote {Path(out_dir) / 'results.jsonl'} and {Path(out_dir) / 'summary.json'}")
    return 0


__all__ = ["robustness"]
