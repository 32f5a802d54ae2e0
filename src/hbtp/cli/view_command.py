"""``hbtp view``: a self-contained HTML page of a tree, stepping through an execution trace.

The page is built by :mod:`hbtp.bt.html_view` (scripts and styles inlined: it opens from disk, with
no server and no network). Exit codes: 0 written; 2 bad input (a tree or trace that cannot be read,
a trace that does not match the tree), and then nothing is written.
"""

from __future__ import annotations

from pathlib import Path

import click

from hbtp.bt.html_view import ViewHeader, read_trace, render_page, view_data
from hbtp.bt.jsonio import goal_text
from hbtp.bt.nodes import size
from hbtp.cli.options import ScenarioSource, output_option, scenario_options
from hbtp.cli.tree_input import load_tree_input
from hbtp.files import InputKind, read_text, write_all_atomically


@click.command("view")
@click.argument("tree_file", metavar="TREE", type=click.Path(dir_okay=False))
@scenario_options
@click.option("-g", "--goal", "goal_option", help="Goal (default: the goal stored in the tree file).")
@click.option(
    "--trace",
    "trace_file",
    type=click.Path(dir_okay=False),
    help="A tick-by-tick JSONL trace of the tree (hbtp run --trace FILE) to step through.",
)
@output_option("-o", "--out", "out_file", required=True, help="The HTML file to write.")
def view_command(
    tree_file: str, source: ScenarioSource, goal_option: str | None, trace_file: str | None, out_file: str
) -> int:
    """Write TREE (hbtp JSON or BehaviorTree.CPP v4 XML) as one self-contained HTML page.

    The page draws the tree (collapse, search, zoom) and, with --trace, steps through the trace tick
    by tick (buttons, slider, arrow keys; #tick=N in the address opens a tick): the nodes ticked with
    their statuses and the active path highlighted, the state's true literals, disturbances and
    re-plans marked on a timeline, and a run selector. The trace must match the tree: at every tick,
    the tree ticked in the trace's state must choose the trace's action (else exit code 2, and
    nothing is written).
    """
    read = load_tree_input(tree_file, source, goal_option)
    runs = read_trace(read_text(trace_file, InputKind.TRACE), trace_file) if trace_file else []
    header = ViewHeader(
        title=Path(tree_file).name,
        scenario=read.scenario.name,
        goal=goal_text(read.goal) if read.goal is not None else "",
        trace=Path(trace_file).name if trace_file else None,
    )
    data = view_data(read.tree, read.scenario.task, runs, header, source=trace_file)
    write_all_atomically({Path(out_file): render_page(data)})
    ticks = sum(len(run["ticks"]) for run in data["runs"])
    what = f"{size(read.tree).nodes} nodes"
    if trace_file:
        what += f", {len(runs)} run(s), {ticks} tick(s)"
    click.echo(f"wrote {out_file} ({what})")
    return 0


__all__ = ["view_command"]
