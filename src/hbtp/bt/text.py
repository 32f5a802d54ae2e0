"""A terminal view of a tree."""

from __future__ import annotations

from hbtp.bt.nodes import Action, Condition, Fallback, Node
from hbtp.logic.task import GroundTask


def label(node: Node, task: GroundTask) -> str:
    if isinstance(node, Condition):
        return " & ".join(task.names(node.literals)) if node.literals else "(true)"
    if isinstance(node, Action):
        return task.actions[node.action].name
    return "Fallback" if isinstance(node, Fallback) else "Sequence"


def render_text(node: Node, task: GroundTask, max_children: int | None = None) -> str:
    """An indented tree: ``?`` marks a Fallback, ``->`` a Sequence, ``[C]`` and ``[A]`` the leaves."""
    lines: list[str] = []

    def visit(current: Node, prefix: str, last: bool, top: bool) -> None:
        joint = "" if top else ("└── " if last else "├── ")
        if isinstance(current, Condition):
            lines.append(f"{prefix}{joint}[C] {label(current, task)}")
            return
        if isinstance(current, Action):
            lines.append(f"{prefix}{joint}[A] {label(current, task)}")
            return
        mark = "?" if isinstance(current, Fallback) else "->"
        lines.append(f"{prefix}{joint}{mark} {label(current, task)}")
        children = current.children
        hidden = 0
        if max_children is not None and len(children) > max_children:
            hidden = len(children) - max_children
            children = children[:max_children]
        child_prefix = prefix if top else prefix + ("    " if last else "│   ")
        for i, child in enumerate(children):
            visit(child, child_prefix, i == len(children) - 1 and not hidden, False)
        if hidden:
            lines.append(f"{child_prefix}└── ... {hidden} more branch(es)")

    visit(node, "", True, True)
    return "\n".join(lines)
