"""``hbtp validate-optimal``: OBTEA's D(T) against Fast Downward's optimal cost (the ``validate`` extra)."""

from __future__ import annotations

import json
from collections.abc import Iterable, Iterator
from contextlib import ExitStack
from pathlib import Path
from typing import IO, Any

import click

from hbtp.cli.options import echo_json, output_option
from hbtp.datasets import DATASET_SCENARIO
from hbtp.domains import scenario_names
from hbtp.errors import InputError
from hbtp.files import open_output
from hbtp.validation import COMPARE_TIME_LIMIT, ENGINES, Engine, compare_files, decided, iter_comparisons


def _plan_runs(scenarios: tuple[str, ...], dataset: str | None) -> list[tuple[str, str | None]]:
    """(scenario, dataset) pairs: every chosen scenario with its test set, or the one dataset given."""
    if dataset is None:
        return [(name, None) for name in scenarios or scenario_names()]
    if len(scenarios) > 1:
        raise InputError("--dataset goes with one --scenario")
    scenario = scenarios[0] if scenarios else DATASET_SCENARIO.get(dataset)
    if scenario is None:
        raise InputError(f"give --scenario for the dataset {dataset!r}")
    return [(scenario, dataset)]


def _cost(value: int | None, status: str) -> str:
    return str(value) if value is not None else status


def _line(row: dict[str, Any]) -> str:
    """One record: ``robothow-small 3 OBTEA 82 (unpruned 82) FD 82 match 0.4 ms / 0.34 s``."""
    verdict = _verdict(row["match"], decided(row))
    note = "  declared mutexes change the optimum" if row["mutexes_change_optimum"] else ""
    return (
        f"{row['scenario']:15} {row['record']:>4}  "
        f"OBTEA {_cost(row['obtea_cost'], row['obtea_status']):>8} "
        f"(unpruned {_cost(row['obtea_unpruned_cost'], row['obtea_unpruned_status'])})  "
        f"FD {_cost(row['fd_cost'], row['fd_status']):>8}  {verdict:8}  "
        f"time OBTEA {row['obtea_time_s'] * 1000:.1f} ms (unpruned {row['obtea_unpruned_time_s'] * 1000:.1f} ms) "
        f"FD {row['fd_time_s']:.2f} s  {row['goal']}{note}"
        + (f"\n    {row['fd_message']}" if "fd_message" in row and not row["match"] else "")
    )


def _verdict(match: bool, both_decided: bool) -> str:
    """``match``; ``MISMATCH`` when both answered differently; ``undecided`` when one did not answer
    (a time limit or an error: not checked, so not a match either)."""
    if match:
        return "match"
    return "MISMATCH" if both_decided else "undecided"


def summarize(rows: Iterable[dict[str, Any]]) -> dict[str, Any]:
    """Counts and mean times of comparison rows."""
    rows = list(rows)
    count = len(rows) or 1
    return {
        "records": len(rows),
        "matches": sum(1 for r in rows if r["match"]),
        "mismatches": sum(1 for r in rows if not r["match"]),
        "undecided": sum(1 for r in rows if not decided(r)),
        "mutexes_change_optimum": [f"{r['scenario']}:{r['record']}" for r in rows if r["mutexes_change_optimum"]],
        "obtea_mean_time_s": round(sum(r["obtea_time_s"] for r in rows) / count, 4),
        "obtea_unpruned_mean_time_s": round(sum(r["obtea_unpruned_time_s"] for r in rows) / count, 4),
        "fd_mean_time_s": round(sum(r["fd_time_s"] for r in rows) / count, 4),
    }


def _summary_line(label: str, summary: dict[str, Any]) -> str:
    changed = summary["mutexes_change_optimum"]
    return (
        f"{label}: {summary['records']} records, {summary['matches']} matches, {summary['mismatches']} mismatches"
        f" ({summary['undecided']} undecided: a time limit or an error);"
        f" mean time OBTEA {summary['obtea_mean_time_s'] * 1000:.1f} ms"
        f" (unpruned {summary['obtea_unpruned_mean_time_s'] * 1000:.1f} ms), FD {summary['fd_mean_time_s']:.2f} s; "
        f"declared mutexes change the optimum on {len(changed)}" + (f" ({', '.join(changed)})" if changed else "")
    )


def _open_out(path: Path) -> IO[str]:
    """The JSONL file, opened for writing (rows are written as they come, so a long run keeps its rows)."""
    return open_output(path)


def _rows(
    runs: list[tuple[str, str | None]], time_limit: float, limit: int | None, engine: Engine
) -> Iterator[dict[str, Any]]:
    for scenario, dataset in runs:
        yield from iter_comparisons(scenario, dataset, time_limit=time_limit, limit=limit, engine=engine)


@click.command("validate-optimal")
@click.option(
    "-s",
    "--scenario",
    "scenarios",
    multiple=True,
    type=click.Choice(list(scenario_names())),
    help="Scenario to check (repeatable; default: all four).",
)
@click.option("--dataset", help="A shipped dataset or a dataset file (default: each scenario's Table II test set).")
@click.option(
    "-t", "--time-limit", type=float, default=COMPARE_TIME_LIMIT, show_default=True, help="Seconds per planner run."
)
@click.option("-n", "--limit", type=click.IntRange(min=1), help="Only the first N records of each dataset.")
@click.option(
    "--engine",
    type=click.Choice(list(ENGINES)),
    default="auto",
    show_default=True,
    help="Run Fast Downward through unified-planning, its driver directly, or auto (the driver for big tasks).",
)
@click.option(
    "--pddl",
    "pddl_files",
    nargs=2,
    multiple=True,
    type=click.Path(exists=True, dir_okay=False),
    metavar="DOMAIN PROBLEM",
    help="Check the problem's :goal in these PDDL files instead (repeatable): Fast Downward reads the files itself.",
)
@output_option("-o", "--out", "out_file", help="Write the rows as JSONL.")
@click.option("--json", "as_json", is_flag=True, help="Print rows and summary as one JSON document.")
def validate_optimal(
    scenarios: tuple[str, ...],
    dataset: str | None,
    time_limit: float,
    limit: int | None,
    engine: str,
    pddl_files: tuple[tuple[str, str], ...],
    out_file: str | None,
    as_json: bool,
) -> int:
    """Check that OBTEA's D(T) equals Fast Downward's optimal cost on every record.

    Needs the validate extra (pip install -e '.[validate]'). OBTEA runs with the scenario's mutexes
    and without: the cost without must equal Fast Downward's exactly; records whose optimum the
    declared mutexes change are listed. With --pddl, each problem's :goal is planned from the files
    as hbtp reads them and Fast Downward solves the same files with its own translator; the tree
    must also be verified, and hbtp's ground actions are shown beside the translator's operators.
    Exit code 1 when some record does not match.
    """
    if pddl_files:
        if scenarios or dataset:
            raise InputError("--pddl checks files: give it without --scenario and --dataset")
        return _validate_files(pddl_files, time_limit, out_file, as_json)
    runs = _plan_runs(scenarios, dataset)
    rows: list[dict[str, Any]] = []
    with ExitStack() as stack:
        out: IO[str] | None = None
        if out_file:
            out = stack.enter_context(_open_out(Path(out_file)))
        for row in _rows(runs, time_limit, limit, Engine(engine)):
            rows.append(row)
            if out is not None:
                out.write(json.dumps(row, ensure_ascii=False) + "\n")
                out.flush()
            if not as_json:
                click.echo(_line(row))
    summary = summarize(rows)
    if as_json:
        echo_json({"summary": summary, "rows": rows})
    else:
        for scenario in dict.fromkeys(r["scenario"] for r in rows):
            click.echo(_summary_line(scenario, summarize(r for r in rows if r["scenario"] == scenario)))
        if len(runs) > 1:
            click.echo(_summary_line("all", summary))
    return 0 if summary["mismatches"] == 0 else 1


def _file_line(row: dict[str, Any]) -> str:
    """``p01.pddl  OBTEA 11 (0.02 s)  FD 11 (0.31 s)  match  ground 34 / FD 34 (1.00x)``."""
    verdict = _verdict(row["match"], row["decided"])
    ratio = "-"
    if row["ground_ratio"] is not None:
        ratio = f"{row['ground_ratio']:.2f}x, reachable {row['reachable_ratio']:.2f}x"
    return (
        f"{row['instance']}  OBTEA {_cost(row['obtea_cost'], row['obtea_status'])} ({row['obtea_time_s']:.2f} s"
        f"{', tree verified' if row['tree_verified'] else ''})  FD {_cost(row['fd_cost'], row['fd_status'])} "
        f"({row['fd_time_s']:.2f} s)  {verdict}  ground actions {row['grounded_actions']} "
        f"(of {row['reachable_actions']} reachable) / "
        f"FD operators {row['fd_operators'] if row['fd_operators'] is not None else '-'} ({ratio})"
        + (f"\n    {row['fd_message']}" if "fd_message" in row and not row["match"] else "")
    )


def _validate_files(
    pddl_files: tuple[tuple[str, str], ...], time_limit: float, out_file: str | None, as_json: bool
) -> int:
    rows: list[dict[str, Any]] = []
    with ExitStack() as stack:
        out = stack.enter_context(_open_out(Path(out_file))) if out_file else None
        for domain, problem in pddl_files:
            row = compare_files(Path(domain), Path(problem), time_limit=time_limit)
            rows.append(row)
            if out is not None:
                out.write(json.dumps(row, ensure_ascii=False) + "\n")
                out.flush()
            if not as_json:
                click.echo(_file_line(row))
    unmatched = sum(not row["match"] for row in rows)
    undecided = sum(not row["decided"] for row in rows)
    if as_json:
        summary = {"instances": len(rows), "mismatches": unmatched - undecided, "undecided": undecided}
        echo_json({"summary": summary, "rows": rows})
    else:
        click.echo(
            f"{len(rows)} instance(s), {len(rows) - unmatched} match(es), {unmatched - undecided} mismatch(es), "
            f"{undecided} undecided"
        )
    return 0 if unmatched == 0 else 1


__all__ = ["summarize", "validate_optimal"]
