"""One registry of export formats, file-extension lookup, tree reading and atomic writing.

``FORMATS`` maps a format name to its :class:`ExportFormat`; the command line, ``hbtp plan --export``
and the tests all go through :func:`export_tree`, :func:`format_from_extension` and
:func:`write_export`.
"""

from __future__ import annotations

import logging
import os
from collections.abc import Callable
from dataclasses import dataclass
from pathlib import Path

from hbtp.bt.btcpp import tree_to_btcpp
from hbtp.bt.graphviz import render_bytes, tree_to_dot
from hbtp.bt.jsonio import tree_to_json
from hbtp.bt.mermaid import tree_to_mermaid
from hbtp.bt.nodes import Node
from hbtp.bt.pytrees_export import write_pytrees_module
from hbtp.bt.text import render_text
from hbtp.bt.treefile import read_tree_file
from hbtp.errors import InputError
from hbtp.files import write_atomically
from hbtp.logic.task import GroundTask

logger = logging.getLogger(__name__)

Writer = Callable[[Node, GroundTask, str, str], str | bytes]


@dataclass(frozen=True)
class ExportFormat:
    """An export format: its writer ``(tree, task, scenario, goal) -> str | bytes`` and file extensions."""

    name: str
    description: str
    extensions: tuple[str, ...]
    write: Writer
    binary: bool = False


def _text(tree: Node, task: GroundTask, scenario: str, goal: str) -> str:
    header = [f"# scenario: {scenario}"] if scenario else []
    header += [f"# goal: {goal}"] if goal else []
    return "\n".join([*header, render_text(tree, task)]) + "\n"


FORMATS: dict[str, ExportFormat] = {
    fmt.name: fmt
    for fmt in (
        ExportFormat(
            "btcpp",
            "BehaviorTree.CPP v4 XML (Groot2, ROS 2 Nav2)",
            (".xml",),
            lambda tree, task, scenario, goal: tree_to_btcpp(tree, task, scenario=scenario, goal=goal),
        ),
        ExportFormat(
            "btcpp-named",
            "BehaviorTree.CPP v4 XML without ports, the grounded literal in each leaf's name "
            "(loads as is in behaviortreepy, whose Python nodes have no ports; hbtp run --engine btcpp)",
            (),
            lambda tree, task, scenario, goal: tree_to_btcpp(tree, task, scenario=scenario, goal=goal, ports=False),
        ),
        ExportFormat(
            "pytrees",
            "a standalone Python module that rebuilds the tree with py_trees",
            (".py",),
            lambda tree, task, scenario, goal: write_pytrees_module(tree, task, scenario=scenario, goal=goal),
        ),
        ExportFormat("dot", "Graphviz DOT text", (".dot", ".gv"), lambda tree, task, _s, _g: tree_to_dot(tree, task)),
        ExportFormat(
            "svg",
            "SVG picture (needs Graphviz's dot)",
            (".svg",),
            lambda tree, task, _s, _g: render_bytes(tree_to_dot(tree, task), "svg").decode("utf-8"),
        ),
        ExportFormat(
            "png",
            "PNG picture (needs Graphviz's dot)",
            (".png",),
            lambda tree, task, _s, _g: render_bytes(tree_to_dot(tree, task), "png"),
            binary=True,
        ),
        ExportFormat(
            "mermaid", "Mermaid flowchart", (".mmd", ".mermaid"), lambda tree, task, _s, _g: tree_to_mermaid(tree, task)
        ),
        ExportFormat(
            "json",
            "hbtp's JSON tree (reads back with the scenario)",
            (".json",),
            lambda tree, task, scenario, goal: tree_to_json(tree, task, scenario=scenario, goal=goal),
        ),
        ExportFormat("text", "an indented text view", (".txt",), _text),
    )
}


def _check_format(fmt: str) -> ExportFormat:
    try:
        return FORMATS[fmt]
    except KeyError:
        raise InputError(f"unknown export format {fmt!r} (choose {', '.join(FORMATS)})") from None


def export_tree(tree: Node, task: GroundTask, fmt: str, *, scenario: str = "", goal: str = "") -> str | bytes:
    """The tree in format ``fmt`` (a key of :data:`FORMATS`): text, or bytes for ``png``."""
    return _check_format(fmt).write(tree, task, scenario, goal)


def format_from_extension(path: str | os.PathLike[str]) -> str:
    """The export format a file name asks for (``tree.xml`` -> ``btcpp``); :class:`InputError` if none."""
    suffix = Path(path).suffix.lower()
    for fmt in FORMATS.values():
        if suffix in fmt.extensions:
            return fmt.name
    known = ", ".join(f"{ext} ({fmt.name})" for fmt in FORMATS.values() for ext in fmt.extensions)
    raise InputError(f"{path}: cannot tell the format from the extension {suffix or '(none)'!r}; use {known}")


def read_tree(path: str | os.PathLike[str], task: GroundTask) -> Node:
    """Read a tree file, hbtp JSON or BehaviorTree.CPP v4 XML (told apart by content, see
    :func:`hbtp.bt.treefile.read_tree_file`), resolved against ``task``."""
    return read_tree_file(path).tree(task)


def write_export(
    tree: Node,
    task: GroundTask,
    path: str | os.PathLike[str],
    fmt: str | None = None,
    *,
    scenario: str = "",
    goal: str = "",
) -> None:
    """Export ``tree`` to ``path`` in ``fmt`` (default: from the extension), atomically.

    The whole output is produced before anything touches the disk, so an error (unknown format,
    missing ``dot``) leaves no file behind.
    """
    chosen = fmt or format_from_extension(path)
    data = export_tree(tree, task, chosen, scenario=scenario, goal=goal)
    write_atomically(Path(path), data)
    logger.info("wrote %s (%s)", path, chosen)
