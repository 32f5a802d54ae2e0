"""``hbtp bench ...``: rerun the paper's experiments."""

from __future__ import annotations

from pathlib import Path
from typing import cast

import click

from hbtp.bench.table1 import Table1Config, run_table1
from hbtp.planning import PLANNERS
from hbtp.planning.heuristics import HEURISTICS, HeuristicName


@click.group()
def bench() -> None:
    """Reproduce the paper's tables (results.jsonl + summary.json; re-running resumes)."""


@bench.command("table1")
@click.option("--space", type=click.Choice(["pruned", "full"]), default="pruned", show_default=True)
@click.option("--planners", default=",".join(PLANNERS), show_default=True, help="Comma-separated planners.")
@click.option("--hints", type=click.Choice(["oracle", "none"]), default="oracle", show_default=True)
@click.option("--heuristic", type=click.Choice(list(HEURISTICS)), default="none", show_default=True)
@click.option("-t", "--time-limit", type=float, default=5.0, show_default=True, help="Seconds per task.")
@click.option("--limit", type=int, help="Only the first N tasks.")
@click.option("-o", "--out", "out_dir", required=True, type=click.Path(file_okay=False))
@click.option("--no-progress", is_flag=True, help="No progress bar.")
def table1(
    space: str,
    planners: str,
    hints: str,
    heuristic: str,
    time_limit: float,
    limit: int | None,
    out_dir: str,
    no_progress: bool,
) -> int:
    """Table I: the four planners on the 100 Table I tasks (RobotHow)."""
    chosen = tuple(p.strip() for p in planners.split(",") if p.strip())
    unknown = [p for p in chosen if p not in PLANNERS]
    if unknown or not chosen:
        raise click.BadParameter(f"unknown planner(s) {', '.join(unknown) or '(none)'}", param_hint="--planners")
    if not time_limit > 0:
        raise click.BadParameter("must be a positive number of seconds", param_hint="--time-limit")
    config = Table1Config(
        space="full" if space == "full" else "pruned",
        planners=chosen,
        hints="none" if hints == "none" else "oracle",
        heuristic=cast(HeuristicName, heuristic),
        time_limit=time_limit,
        limit=limit,
    )
    summary = run_table1(config, Path(out_dir), progress=not no_progress)
    header = f"{'planner':8} {'solved':>7} {'timeouts':>8} {'|S-|':>8} {'D(T)':>8} {'mean ms':>9} {'median ms':>10}"
    click.echo(header)
    for name, row in summary["planners"].items():
        explored = f"{row['mean_explored']:.2f}" if row["mean_explored"] is not None else "-"
        cost = f"{row['mean_cost']:.2f}" if row["mean_cost"] is not None else "-"
        click.echo(
            f"{name:8} {row['solved']:>3}/{row['tasks']:<3} {row['timeouts']:>8} {explored:>8} {cost:>8} "
            f"{(row['mean_time_s'] or 0) * 1000:>9.2f} {(row['median_time_s'] or 0) * 1000:>10.2f}"
        )
    click.echo(f"wrote {Path(out_dir) / 'results.jsonl'} and {Path(out_dir) / 'summary.json'}")
    return 0
