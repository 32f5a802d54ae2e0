"""Our JSON tree format (round trip): readable names, resolved against a scenario when read.

``{"format": "hbtp-tree", "version": 1, "scenario": "robothow", "goal": ["IsIn(milk,fridge)"],
   "complete": true,
   "root": {"type": "Fallback", "children": [{"type": "Condition", "literals": ["IsOpen(fridge)"]},
   {"type": "Sequence", "children": [... {"type": "Action", "action": "Open(fridge)"}]}]}}``

``goal`` is the list of goal literals in the ``Pred(a,b)`` form (a string ``"IsIn_milk_fridge &
..."`` in files written before, still read). ``complete`` is false for the partial tree of an
unsolved search (``hbtp plan --partial``). A tree planned from the user's PDDL also records
``"pddl": {"domain": ..., "problem": ...}`` (paths relative to the tree file's folder, and the
``objects``, ``keep_fluent`` and ``mutex`` options when given), so that ``hbtp run``, ``verify``
and ``export`` can reload the task. A tree planned in the pruned space of some hints (an LLM's, or
``--hints``) records them, ``"hints": {"path": [...], "predicates": [...], "objects": [...]}``:
``hbtp run --replan`` searches their space first. Trees nested deeper than
:data:`~hbtp.bt.nodes.MAX_TREE_DEPTH` levels are rejected.
"""

from __future__ import annotations

import json
from collections.abc import Iterable, Mapping
from typing import Any

from hbtp.bt.nodes import MAX_TREE_DEPTH, MAX_TREE_NODES, Action, Condition, Fallback, Node, Sequence
from hbtp.errors import InputError
from hbtp.logic.atoms import Atom, parse_atom
from hbtp.logic.goals import parse_goal
from hbtp.logic.task import Goal, GroundTask
from hbtp.planning.hints import Hints

FORMAT = "hbtp-tree"
VERSION = 1

GoalLike = Goal | str | Iterable[Atom | str]


def goal_terms(goal: GoalLike) -> list[list[str]]:
    """The goal's disjuncts, each a list of literals in the ``Pred(a,b)`` form (none for ``""``).

    A string is read as a goal text (``A(x) & ~B(y) | C(z)``; give the ``Pred(a,b)`` form, the
    underscored one is ambiguous when names contain ``_``)."""
    if isinstance(goal, Goal):
        return [[str(atom) for atom in term] for term in goal.terms]
    if isinstance(goal, str):
        return [[str(atom) for atom in term] for term in parse_goal(goal)] if goal.strip() else []
    return [[str(parse_atom(item) if isinstance(item, str) else item) for item in goal]]


def goal_record(goal: GoalLike) -> list[str] | str:
    """The goal as a tree file records it: the list of literals of a conjunction, else its text."""
    terms = goal_terms(goal)
    if len(terms) <= 1:
        return terms[0] if terms else []
    return goal_text(goal)


def goal_text(goal: GoalLike) -> str:
    """The goal as text in the ``Pred(a,b)`` form: ``IsIn(milk,fridge) & ~IsOpen(fridge) | IsOn(milk,table)``."""
    return " | ".join(" & ".join(term) for term in goal_terms(goal))


def node_to_dict(node: Node, task: GroundTask) -> dict[str, Any]:
    if isinstance(node, Condition):
        return {"type": "Condition", "literals": task.names(node.literals)}
    if isinstance(node, Action):
        return {"type": "Action", "action": task.actions[node.action].name}
    kind = "Sequence" if isinstance(node, Sequence) else "Fallback"
    return {"type": kind, "children": [node_to_dict(child, task) for child in node.children]}


def tree_to_json(
    node: Node,
    task: GroundTask,
    *,
    scenario: str = "",
    goal: GoalLike = "",
    complete: bool = True,
    pddl: Mapping[str, Any] | None = None,
    hints: Hints | None = None,
) -> str:
    """The tree as a JSON document (deterministic: same tree, same bytes); ``hints``: those whose
    pruned space it was planned in (re-plans search that space first)."""
    document: dict[str, Any] = {
        "format": FORMAT,
        "version": VERSION,
        "scenario": scenario or task.name,
        "goal": goal_record(goal),
        "complete": complete,
    }
    if pddl:
        document["pddl"] = dict(pddl)
    if hints is not None:
        document["hints"] = {
            "path": list(hints.path), "predicates": list(hints.predicates), "objects": list(hints.objects)
        }  # fmt: skip
    document["root"] = node_to_dict(node, task)
    return json.dumps(document, indent=1, ensure_ascii=False) + "\n"


def _too_deep() -> InputError:
    return InputError(f"the tree is nested more than {MAX_TREE_DEPTH} levels deep (the most hbtp reads)")


def node_from_dict(data: Any, task: GroundTask, where: str = "root", depth: int = 1) -> Node:
    if depth > MAX_TREE_DEPTH:
        raise _too_deep()
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
        nodes = tuple(node_from_dict(c, task, f"{where}.{kind}[{i}]", depth + 1) for i, c in enumerate(children))
        return Sequence(nodes) if kind == "Sequence" else Fallback(nodes)
    raise InputError(f"{where}: unknown node type {kind!r} (expected Condition, Action, Sequence, Fallback)")


def json_document(text: str, source: str = "<tree>") -> dict[str, Any]:
    """The checked document of an hbtp JSON tree (its ``root`` not yet resolved against a task)."""
    try:
        document = json.loads(text)
    except json.JSONDecodeError as error:
        raise InputError(f"{source}: not valid JSON ({error.msg} at line {error.lineno})") from None
    except RecursionError:
        raise InputError(f"{source}: {_too_deep()}") from None
    if not isinstance(document, dict) or document.get("format") != FORMAT:
        raise InputError(f'{source}: not an hbtp tree (expected "format": "{FORMAT}")')
    if document.get("version") != VERSION:
        raise InputError(f"{source}: unsupported tree version {document.get('version')!r}")
    if _more_nodes_than(document.get("root"), MAX_TREE_NODES):
        raise InputError(f"{source}: the tree has more than {MAX_TREE_NODES:,} nodes, the limit hbtp reads")
    return document


def _more_nodes_than(root: Any, limit: int) -> bool:
    """Whether the JSON tree under ``root`` has more than ``limit`` nodes (counted without recursion,
    stopping at the limit)."""
    pending, count = [root], 0
    while pending:
        node = pending.pop()
        count += 1
        if count > limit:
            return True
        children = node.get("children") if isinstance(node, dict) else None
        if isinstance(children, list):
            pending.extend(children)
    return False


def tree_from_json(text: str, task: GroundTask, source: str = "<tree>") -> tuple[Node, dict[str, Any]]:
    """Read a tree written by :func:`tree_to_json`; returns the root and the document's metadata."""
    document = json_document(text, source)
    root = root_from_document(document, task, source)
    meta = {k: v for k, v in document.items() if k != "root"}
    return root, meta


def root_from_document(document: Mapping[str, Any], task: GroundTask, source: str = "<tree>") -> Node:
    """The tree of a document read by :func:`json_document`, resolved against ``task``."""
    try:
        return node_from_dict(document.get("root"), task)
    except InputError as error:
        raise InputError(f"{source}: {error}") from None
