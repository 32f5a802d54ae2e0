"""``hbtp export``: convert a saved tree (hbtp JSON or BehaviorTree.CPP XML) to another format.

Register it in :mod:`hbtp.cli` with ``cli.add_command(export_command)``. ``hbtp plan --export FILE``
can reuse :func:`export_options` and :func:`write_export`.
"""

from __future__ import annotations

import json
from collections.abc import Callable
from pathlib import Path
from typing import Any, TypeVar

import click

from hbtp.bt.export import FORMATS, export_tree, format_from_extension, read_tree, write_export
from hbtp.cli.options import ScenarioSource, scenario_options
from hbtp.errors import InputError

F = TypeVar("F", bound=Callable[..., Any])

FORMAT_HELP = "; ".join(f"{fmt.name}: {fmt.description} ({'/'.join(fmt.extensions)})" for fmt in FORMATS.values())


def export_options(function: F) -> F:
    """``--export FILE`` and ``--format NAME`` (for ``hbtp plan``): pass them to :func:`write_export`."""
    function = click.option(
        "--format",
        "export_format",
        type=click.Choice(list(FORMATS)),
        help="Format of --export (default: from its extension).",
    )(function)
    function = click.option(
        "--export",
        "export_file",
        type=click.Path(dir_okay=False),
        help="Also export the tree to FILE (.xml BT.CPP, .py py_trees, .dot, .svg, .png, .mmd, .json, .txt).",
    )(function)
    return function


def _document_metadata(path: str) -> dict[str, Any]:
    """The scenario and goal recorded in an hbtp JSON tree (empty for anything else)."""
    if Path(path).suffix.lower() == ".xml":
        return {}
    try:
        document = json.loads(Path(path).read_text(encoding="utf-8"))
    except (OSError, UnicodeDecodeError, json.JSONDecodeError):
        return {}  # read_tree reports the problem
    return document if isinstance(document, dict) else {}


@click.command("export", epilog=f"Formats: {FORMAT_HELP}.")
@click.argument("tree_file", metavar="TREE", type=click.Path(dir_okay=False))
@scenario_options
@click.option(
    "-f", "--format", "fmt", type=click.Choice(list(FORMATS)), help="Output format (default: from --out's extension)."
)
@click.option(
    "-o", "--out", "out_file", type=click.Path(dir_okay=False), help="Output file (default: standard output)."
)
def export_command(
    tree_file: str,
    source: ScenarioSource,
    fmt: str | None,
    out_file: str | None,
) -> int:
    """Convert TREE (hbtp JSON or BehaviorTree.CPP v4 XML) to another format.

    The tree's names are checked against the scenario (--scenario, --pddl, or the scenario recorded
    in a JSON tree). Nothing is written when the input is bad.
    """
    chosen = fmt or (format_from_extension(out_file) if out_file else None)
    if chosen is None:
        raise InputError("give --format or an --out file whose extension names the format")
    if out_file is None and FORMATS[chosen].binary:
        raise InputError(f"{chosen} is a binary format: give --out FILE")
    metadata = _document_metadata(tree_file)
    recorded = metadata.get("scenario")
    loaded = source.load(default=recorded if isinstance(recorded, str) else None)
    tree = read_tree(tree_file, loaded.task)
    goal = metadata.get("goal") if isinstance(metadata.get("goal"), str) else ""
    if out_file is None:
        data = export_tree(tree, loaded.task, chosen, scenario=loaded.name, goal=str(goal))
        click.echo(data if isinstance(data, str) else data.decode("utf-8"), nl=False)
    else:
        write_export(tree, loaded.task, out_file, chosen, scenario=loaded.name, goal=str(goal))
        click.echo(f"wrote {out_file} ({chosen})")
    return 0


__all__ = ["export_command", "export_options", "write_export"]
