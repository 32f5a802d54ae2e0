"""``hbtp dataset ...``: list, validate, convert and generate datasets."""

from __future__ import annotations

from collections.abc import Callable
from pathlib import Path
from typing import Any, TypeVar

import click

from hbtp.cli.options import ScenarioSource, checked_output, echo_json, output_option, scenario_options
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
from hbtp.domains.scenarios import Scenario
from hbtp.errors import InputError
from hbtp.files import write_all_atomically
from hbtp.planning import Limits
from hbtp.planning.generate import LEVELS, Sampling, generate_records, statistics
from hbtp.planning.oracle import optimal_cost_function

F = TypeVar("F", bound=Callable[..., Any])


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
@click.argument("dataset_source", metavar="SOURCE")
@scenario_options
@click.option(
    "--check-optimal", is_flag=True, help="Also plan each goal optimally and warn about plans that cost more."
)
@click.option("-t", "--time-limit", type=float, default=30.0, show_default=True, help="Seconds per optimal plan.")
@click.option("--json", "as_json", is_flag=True, help="Print the report as JSON.")
def validate(dataset_source: str, source: ScenarioSource, check_optimal: bool, time_limit: float, as_json: bool) -> int:
    """Check every record of SOURCE (a file or a shipped dataset name) against a scenario
    (--scenario or --pddl; default: the shipped dataset's own).

    Exit code 1 when some record is invalid (warnings alone do not fail).
    """
    name, records = load_records(dataset_source)
    if not source.given and name not in DATASET_SCENARIO:
        raise InputError("give --scenario or --pddl for a dataset file")
    loaded = source.load(DATASET_SCENARIO.get(name))
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
@click.argument("target", type=click.Path(dir_okay=False), callback=checked_output)
def convert(source: str, target: str) -> int:
    """Convert SOURCE to TARGET: .jsonl writes our JSONL format, anything else the reference text format."""
    _, records = load_records(source)
    text = write_jsonl(records) if target.endswith(".jsonl") else write_text(records)
    write_all_atomically({Path(target): text})
    click.echo(f"wrote {len(records)} records to {target}")
    return 0


def write_generated(loaded: Scenario, level: str, count: int, sampling: Sampling, output: str | None) -> int:
    """Sample ``count`` goals of ``level`` in ``loaded``, label them with optimal plans and write
    them (the text format, or JSONL for a ``.jsonl`` output; standard output without one)."""
    records = generate_records(loaded.task, level, count, sampling, loaded.mutexes)
    if not records:
        raise InputError(f"{loaded.name}: no {level} goal found to generate (the domain has none within the limits)")
    text = write_jsonl(records) if output and output.endswith(".jsonl") else write_text(records)
    if output:
        write_all_atomically({Path(output): text})
    else:
        click.echo(text, nl=False)
    figures = statistics(records)
    click.echo(
        f"{len(records)} {level} records{f' written to {output}' if output else ''}: mean |p*| "
        f"{figures['mean_length']:.2f}, mean literals {figures['mean_literals']:.2f}, "
        f"tool use {figures['tool_use']:.0%}",
        err=True,
    )
    return 0


#: Options of the generating commands: ``-n``, ``--seed``, ``--max-expansions``, ``-o``.
def generation_options(default_count: int) -> list[Callable[[F], F]]:
    return [
        click.option("-n", "--count", type=click.IntRange(1, 100_000), default=default_count, show_default=True,
                     help="How many records."),
        click.option("--seed", type=int, default=0, show_default=True, help="Random seed (same seed, same file)."),
        click.option("--max-expansions", type=click.IntRange(1), default=Sampling().max_expansions,
                     show_default=True, help="Bound of each labelling search (a goal past it is skipped)."),
        output_option("-o", "--output",
                      help="File to write (.jsonl: JSONL; else the text format); default: standard output."),
    ]  # fmt: skip


def with_options(options: list[Callable[[F], F]]) -> Callable[[F], F]:
    def decorate(function: F) -> F:
        for option in reversed(options):
            function = option(function)
        return function

    return decorate


@dataset.command("generate")
@scenario_options
@click.option("--level", type=click.Choice(list(LEVELS)), default="easy", show_default=True,
              help="Difficulty: " + "; ".join(f"{k}: {v.description}" for k, v in LEVELS.items()) + ".")  # fmt: skip
@with_options(generation_options(50))
def generate(source: ScenarioSource, level: str, count: int, seed: int, max_expansions: int, output: str | None) -> int:
    """Generate a dataset: sampled reachable goals of a difficulty level, labelled by the optimal
    planner (OBTEA with the landmark heuristic). Deterministic for a seed."""
    return write_generated(source.load(), level, count, Sampling(seed=seed, max_expansions=max_expansions), output)
