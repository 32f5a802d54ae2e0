"""Graphviz pictures of a tree: DOT text, and SVG/PNG through the ``dot`` binary.

Drawing conventions (the usual BT notation): a Fallback is a box marked ``?``, a Sequence a box
marked ``→``, a condition an ellipse listing its literals, an action a filled box. Node ids are
``n0, n1, ...`` in depth-first order, so the same tree always gives the same text.
"""

from __future__ import annotations

import shutil
import subprocess
from typing import Literal

from hbtp.bt.nodes import Action, Condition, Fallback, Node
from hbtp.errors import InputError
from hbtp.logic.task import GroundTask

ImageFormat = Literal["svg", "png"]
IMAGE_FORMATS: tuple[ImageFormat, ...] = ("svg", "png")
DOT_TIMEOUT_S = 120.0

_STYLE = {
    "fallback": 'shape=box, label="?", width=0.4, fontsize=16, style="rounded,bold"',
    "sequence": 'shape=box, label="→", width=0.4, fontsize=16, style="rounded,bold"',
    "condition": 'shape=ellipse, style=filled, fillcolor="#e8f4e8"',
    "action": 'shape=box, style=filled, fillcolor="#ffe9c7"',
}


def _quote(text: str) -> str:
    """A DOT double-quoted string: backslashes and quotes escaped, line breaks as ``\\n``."""
    escaped = text.replace("\\", "\\\\").replace('"', '\\"')
    return '"' + escaped.replace("\r\n", "\n").replace("\n", "\\n") + '"'


def tree_to_dot(tree: Node, task: GroundTask, *, name: str = "behavior_tree") -> str:
    """The tree as a DOT digraph (deterministic; children keep their order left to right)."""
    lines = [
        f"digraph {_quote(name)} {{",
        "  graph [ordering=out, rankdir=LR, nodesep=0.15, ranksep=0.3];",
        '  node [fontname="Helvetica", fontsize=11, margin="0.12,0.06"];',
        "  edge [arrowhead=none];",
    ]
    # Nodes are value objects: equal subtrees may be the same object, so draw by position, not identity.
    counter = 0

    def visit(node: Node) -> str:
        nonlocal counter
        node_id = f"n{counter}"
        counter += 1
        if isinstance(node, Condition):
            label = "\n".join(task.names(node.literals)) or "true"
            lines.append(f"  {node_id} [{_STYLE['condition']}, label={_quote(label)}];")
            return node_id
        if isinstance(node, Action):
            label = task.actions[node.action].name
            lines.append(f"  {node_id} [{_STYLE['action']}, label={_quote(label)}];")
            return node_id
        kind = "fallback" if isinstance(node, Fallback) else "sequence"
        lines.append(f"  {node_id} [{_STYLE[kind]}];")
        for child in node.children:
            child_id = visit(child)
            lines.append(f"  {node_id} -> {child_id};")
        return node_id

    visit(tree)
    lines.append("}")
    return "\n".join(lines) + "\n"


def find_dot() -> str:
    """The path of Graphviz's ``dot`` binary; :class:`InputError` when it is not installed."""
    found = shutil.which("dot")
    if found is None:
        raise InputError(
            "Graphviz's dot program is not on PATH: install graphviz (apt-get install graphviz, "
            "brew install graphviz, conda install graphviz) or export to dot/mermaid instead"
        )
    return found


def render_bytes(dot_text: str, fmt: ImageFormat) -> bytes:
    """Render DOT text to SVG or PNG bytes with the ``dot`` binary."""
    if fmt not in IMAGE_FORMATS:
        raise InputError(f"unknown image format {fmt!r} (choose {', '.join(IMAGE_FORMATS)})")
    dot = find_dot()
    try:
        done = subprocess.run(
            [dot, f"-T{fmt}"],
            input=dot_text.encode("utf-8"),
            capture_output=True,
            timeout=DOT_TIMEOUT_S,
            check=False,
        )
    except subprocess.TimeoutExpired:
        raise InputError(f"dot took more than {DOT_TIMEOUT_S:.0f} s to draw the tree; export to dot instead") from None
    except OSError as error:
        raise InputError(f"cannot run {dot}: {error.strerror}") from None
    if done.returncode != 0 or not done.stdout:
        message = done.stderr.decode("utf-8", "replace").strip().splitlines()
        raise InputError(f"dot failed (exit {done.returncode}): {message[0] if message else 'no output'}")
    return done.stdout
