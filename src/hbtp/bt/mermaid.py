"""Mermaid flowcharts of a tree (GitHub, GitLab and most Markdown viewers draw them).

A Fallback is a box marked ``?``, a Sequence a box marked ``→``, a condition a stadium listing its
literals, an action a box. Node ids are ``n0, n1, ...`` in depth-first order (deterministic).
"""

from __future__ import annotations

from hbtp.bt.nodes import Action, Condition, Fallback, Node
from hbtp.logic.task import GroundTask

# Mermaid entity codes: inside a quoted label these characters would end the label or be read as
# markup. "#" goes first, since every replacement introduces one.
_ENTITIES = (("#", "#35;"), ('"', "#quot;"), ("<", "#lt;"), (">", "#gt;"), ("&", "#amp;"))


def escape_label(text: str) -> str:
    """Text that is safe inside a quoted Mermaid label."""
    for char, entity in _ENTITIES:
        text = text.replace(char, entity)
    return text


def tree_to_mermaid(tree: Node, task: GroundTask) -> str:
    """The tree as a ``flowchart TD`` diagram; multi-literal conditions list one literal a line."""
    lines = ["flowchart TD"]
    edges: list[str] = []
    counter = 0

    def visit(node: Node) -> str:
        nonlocal counter
        node_id = f"n{counter}"
        counter += 1
        if isinstance(node, Condition):
            names = [escape_label(name) for name in task.names(node.literals)] or ["true"]
            lines.append(f'  {node_id}(["{"<br/>".join(names)}"]):::condition')
            return node_id
        if isinstance(node, Action):
            lines.append(f'  {node_id}["{escape_label(task.actions[node.action].name)}"]:::action')
            return node_id
        if isinstance(node, Fallback):
            lines.append(f'  {node_id}["?"]:::fallback')
        else:
            lines.append(f'  {node_id}["→"]:::sequence')
        for child in node.children:
            edges.append(f"  {node_id} --> {visit(child)}")
        return node_id

    visit(tree)
    lines.extend(edges)
    lines.extend(
        [
            "  classDef fallback fill:#f2f2f2,stroke:#333,font-weight:bold",
            "  classDef sequence fill:#f2f2f2,stroke:#333,font-weight:bold",
            "  classDef condition fill:#e8f4e8,stroke:#4a7f4a",
            "  classDef action fill:#ffe9c7,stroke:#a66b00",
        ]
    )
    return "\n".join(lines) + "\n"
