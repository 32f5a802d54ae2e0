"""Our JSON tree format (round trip): readable names, resolved against a scenario when read.

``{"format": "hbtp-tree", "version": 1, "scenario": "robothow", "goal": "...",
   "root": {"type": "Fallback", "children": [{"type": "Condition", "literals": ["IsOpen(fridge)"]},
   {"type": "Sequence", "children": [... {"type": "Action", "action": "Open(fridge)"}]}]}}``
"""

from __future__ import annotations

import json
from typing import Any

from hbtp.bt.nodes import Action, Condition, Fallback, Node, Sequence
from hbtp.errors import InputError
from hbtp.logic.atoms import parse_atom
from hbtp.logic.task import GroundTask

FORMAT = "hbtp-tree"
VERSION = 1


def node_to_dict(node: Node, task: GroundTask) -> dict[str, Any]:
    if isinstance(node, Condition):
        return {"type": "Condition", "literals": task.names(node.literals)}
    if isinstance(node, Action):
        return {"type": "Action", "action": task.actions[node.action].name}
    kind = "Sequence" if isinstance(node, Sequence) else "Fallback"
    return {"type": kind, "children": [node_to_dict(child, task) for child in node.children]}


def tree_to_json(node: Node, task: GroundTask, *, scenario: str = "", goal: str = "") -> str:
    """The tree as a JSON document (deterministic: same tree, same bytes)."""
    document = {
        "format": FORMAT,
        "version": VERSION,
        "scenario": scenario or task.name,
        "goal": goal,
        "root": node_to_dict(node, task),
    }
    return json.dumps(document, indent=1, ensure_ascii=False) + "\n"


def node_from_dict(data: Any, task: GroundTask, where: str = "root") -> Node:
    if not isinstance(data, dict):
        raise InputError(f"{where}: expected an object, found {type(data).__name__}")
    kind = data.get("type")
    if kind == "Condition":
        literals = data.get("literals")
        if not isinstance(literals, list) or not all(isinstance(x, str) for x in literals):
            raise InputError(f"{where}: a Condition needs a list of literal names")
        return Condition(frozenset(task.atom_id(parse_atom(x)) for x in literals))
    if kind == "Action":
        name = data.get("action")
        if not isinstance(name, str):
            raise InputError(f"{where}: an Action needs an action name")
        return Action(task.action(name).index)
    if kind in ("Sequence", "Fallback"):
        children = data.get("children")
        if not isinstance(children, list) or not children:
            raise InputError(f"{where}: a {kind} needs a non-empty list of children")
        nodes = tuple(node_from_dict(c, task, f"{where}.{kind}[{i}]") for i, c in enumerate(children))
        return Sequence(nodes) if kind == "Sequence" else Fallback(nodes)
    raise InputError(f"{where}: unknown node type {kind!r} (expected Condition, Action, Sequence, Fallback)")


def tree_from_json(text: str, task: GroundTask, source: str = "<tree>") -> tuple[Node, dict[str, Any]]:
    """Read a tree written by :func:`tree_to_json`; returns the root and the document's metadata."""
    try:
        document = json.loads(text)
    except json.JSONDecodeError as error:
        raise InputError(f"{source}: not valid JSON ({error.msg} at line {error.lineno})") from None
    if not isinstance(document, dict) or document.get("format") != FORMAT:
        raise InputError(f'{source}: not an hbtp tree (expected "format": "{FORMAT}")')
    if document.get("version") != VERSION:
        raise InputError(f"{source}: unsupported tree version {document.get('version')!r}")
    try:
        root = node_from_dict(document.get("root"), task)
    except InputError as error:
        raise InputError(f"{source}: {error}") from None
    meta = {k: v for k, v in document.items() if k != "root"}
    return root, meta
