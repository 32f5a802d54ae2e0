"""``hbtp export``: convert a saved tree (hbtp JSON or BehaviorTree.CPP XML) to another format.

Register it in :mod:`hbtp.cli` with ``cli.add_command(export_command)``. ``hbtp plan --export FILE``
can reuse :func:`export_options` and :func:`write_export`.
"""

from __future__ import annotations

from collections.abc import Callable
from pathlib import Path
from typing import Any, TypeVar

import click

from hbtp.bt.export import FORMATS, export_tree, format_from_extension, write_export
from hbtp.bt.jsonio import goal_text, tree_to_json
from hbtp.bt.treefile import pddl_record, read_tree_file
from hbtp.cli.options import ScenarioSource, output_option, scenario_options
from hbtp.cli.tree_input import pddl_files, resolve_tree, scenario_for
from hbtp.errors import InputError
from hbtp.files import write_atomically

F = TypeVar("F", bound=Callable[..., Any])

FORMAT_HELP = "; ".join(
    f"{fmt.name}: {fmt.description}" + (f" ({'/'.join(fmt.extensions)})" if fmt.extensions else " (give --format)")
    for fmt in FORMATS.values()
)


def export_options(function: F) -> F:
    """``--export FILE`` and ``--format NAME`` (for ``hbtp plan``): pass them to :func:`write_export`."""
    function = click.option(
        "--format",
        "export_format",
        type=click.Choice(list(FORMATS)),
        help="Format of --export (default: from its extension).",
    )(function)
    function = output_option(
        "--export",
        "export_file",
        help="Also export the tree to FILE (.xml BT.CPP, .py py_trees, .dot, .svg, .png, .mmd, .json, .txt).",
    )(function)
    return function


@click.command("export", epilog=f"Formats: {FORMAT_HELP}.")
@click.argument("tree_file", metavar="TREE", type=click.Path(dir_okay=False))
@scenario_options
@click.option(
    "-f", "--format", "fmt", type=click.Choice(list(FORMATS)), help="Output format (default: from --out's extension)."
)
@output_option("-o", "--out", "out_file", help="Output file (default: standard output).")
def export_command(
    tree_file: str,
    source: ScenarioSource,
    fmt: str | None,
    out_file: str | None,
) -> int:
    """Convert TREE (hbtp JSON or BehaviorTree.CPP v4 XML) to another format.

    The tree's names are checked against the scenario (--scenario, --pddl, or the scenario or PDDL
    files recorded in the tree). Nothing is written when the input is bad.
    """
    chosen = fmt or (format_from_extension(out_file) if out_file else None)
    if chosen is None:
        raise InputError("give --format or an --out file whose extension names the format")
    if out_file is None and FORMATS[chosen].binary:
        raise InputError(f"{chosen} is a binary format: give --out FILE")
    file = read_tree_file(tree_file)
    loaded, tree, goal = resolve_tree(file, scenario_for(file, source))
    goal_line = goal_text(goal) if goal is not None else ""
    if chosen == "json":  # keeps what only JSON records: the PDDL files and completeness
        pddl = pddl_files(source) if source.given else file.pddl
        data: str | bytes = tree_to_json(
            tree,
            loaded.task,
            scenario=loaded.name,
            goal=goal_line,
            complete=file.complete,
            pddl=pddl_record(pddl, out_file or ".", warn=out_file is not None),
        )
    else:
        data = export_tree(tree, loaded.task, chosen, scenario=loaded.name, goal=goal_line)
    if out_file is None:
        click.echo(data if isinstance(data, str) else data.decode("utf-8"), nl=False)
    else:
        write_atomically(Path(out_file), data)
        click.echo(f"wrote {out_file} ({chosen})")
    return 0


__all__ = ["export_command", "export_options", "write_export"]
