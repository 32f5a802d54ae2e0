"""``hbtp dataset ...``: list, validate and convert datasets."""

from __future__ import annotations

from pathlib import Path

import click

from hbtp.cli.options import echo_json, write_files_atomically
from hbtp.datasets import (
    DATASET_SCENARIO,
    dataset_names,
    load_dataset,
    read_dataset_file,
    validate_records,
    write_jsonl,
    write_text,
)
from hbtp.datasets.records import Record
from hbtp.domains import load_scenario
from hbtp.errors import InputError
from hbtp.planning import Limits
from hbtp.planning.oracle import optimal_cost_function


def load_records(source: str) -> tuple[str, list[Record]]:
    """A shipped dataset by name, or a file (reference text format or .jsonl)."""
    if source in dataset_names():
        return source, load_dataset(source)
    if not Path(source).exists():
        raise InputError(f"{source}: no such file, and not a shipped dataset ({', '.join(dataset_names())})")
    return source, read_dataset_file(source)


@click.group()
def dataset() -> None:
    """Work with datasets (the paper's, shipped with hbtp, or your own)."""


@dataset.command("list")
@click.option("--json", "as_json", is_flag=True, help="Print the list as JSON.")
def list_datasets(as_json: bool) -> int:
    """List the shipped datasets and their scenarios."""
    rows = [{"name": n, "scenario": DATASET_SCENARIO[n], "records": len(load_dataset(n))} for n in dataset_names()]
    if as_json:
        echo_json(rows)
    else:
        for row in rows:
            click.echo(f"{row['name']:30} {row['scenario']:16} {row['records']:>4} records")
    return 0


@dataset.command("validate")
@click.argument("source")
@click.option("-s", "--scenario", help="Scenario to check against (default: the shipped dataset's own).")
@click.option(
    "--check-optimal", is_flag=True, help="Also plan each goal optimally and warn about plans that cost more."
)
@click.option("-t", "--time-limit", type=float, default=30.0, show_default=True, help="Seconds per optimal plan.")
@click.option("--json", "as_json", is_flag=True, help="Print the report as JSON.")
def validate(source: str, scenario: str | None, check_optimal: bool, time_limit: float, as_json: bool) -> int:
    """Check every record of SOURCE (a file or a shipped dataset name) against a scenario.

    Exit code 1 when some record is invalid (warnings alone do not fail).
    """
    name, records = load_records(source)
    scenario_name = scenario or DATASET_SCENARIO.get(name)
    if scenario_name is None:
        raise InputError("give --scenario for a dataset file")
    loaded = load_scenario(scenario_name)
    optimal = optimal_cost_function(loaded, Limits(time_s=time_limit)) if check_optimal else None
    report = validate_records(records, loaded.task, dataset=name, optimal_cost=optimal)
    if as_json:
        echo_json(report.to_dict())
    else:
        for issue in report.issues:
            click.echo(f"record {issue.record_id}: {issue.severity}: {issue.code}: {issue.message}")
        click.echo(report.summary())
    return 0 if report.valid else 1


@dataset.command("convert")
@click.argument("source")
@click.argument("target", type=click.Path(dir_okay=False))
def convert(source: str, target: str) -> int:
    """Convert SOURCE to TARGET: .jsonl writes our JSONL format, anything else the reference text format."""
    _, records = load_records(source)
    text = write_jsonl(records) if target.endswith(".jsonl") else write_text(records)
    write_files_atomically({Path(target): text})
    click.echo(f"wrote {len(records)} records to {target}")
    return 0
