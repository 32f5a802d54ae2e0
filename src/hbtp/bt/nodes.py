"""The behavior-tree model: Condition, Action, Sequence, Fallback, and ticking.

Ticking is a pure function of the state: a Condition succeeds iff all its literals hold; an Action
is RUNNING when its preconditions hold (the executor then applies it) and FAILURE otherwise; a
Sequence returns the first child status that is not SUCCESS; a Fallback the first that is not
FAILURE. Node literals and actions are ids of one grounded task.
"""

from __future__ import annotations

from collections.abc import Callable, Iterator
from dataclasses import dataclass

from hbtp.logic.execution import NodeStatus
from hbtp.logic.task import GroundTask, State

#: The deepest tree hbtp reads from a file (a single leaf has depth 1). Ticking, verifying and
#: exporting recurse once or twice per level, so this keeps them well inside Python's recursion
#: limit (and the py_trees export inside the Python parser's 200 nested brackets); planned trees are
#: far shallower (at most 7 levels over every task of the shipped datasets, compacted or not).
MAX_TREE_DEPTH = 90

#: The most nodes hbtp reads from a BehaviorTree.CPP file once its ``<SubTree>`` references are
#: expanded (identical subtrees are shared in memory, but ticking and exporting visit every copy).
MAX_TREE_NODES = 1_000_000


@dataclass(frozen=True, slots=True)
class Condition:
    """Succeeds iff every literal holds."""

    literals: frozenset[int]


@dataclass(frozen=True, slots=True)
class Action:
    """Runs a grounded action; fails when its preconditions do not hold."""

    action: int


@dataclass(frozen=True, slots=True)
class Sequence:
    children: tuple[Node, ...]


@dataclass(frozen=True, slots=True)
class Fallback:
    children: tuple[Node, ...]


Node = Condition | Action | Sequence | Fallback


#: Called with every node a tick visits and the status it returned, children before their parent
#: (like py_trees' visitors); :class:`hbtp.bt.simulate.ConditionChecks` counts condition checks.
Visitor = Callable[[Node, NodeStatus], None]


def tick(node: Node, state: State, task: GroundTask, visitor: Visitor | None = None) -> tuple[NodeStatus, int | None]:
    """Tick ``node`` in ``state``: the status and, when RUNNING, the action to apply.

    ``visitor``, if given, is called with every node ticked and its status."""
    running: int | None = None
    if isinstance(node, Condition):
        status = NodeStatus.SUCCESS if node.literals <= state else NodeStatus.FAILURE
    elif isinstance(node, Action):
        status = NodeStatus.RUNNING if task.actions[node.action].pre <= state else NodeStatus.FAILURE
        running = node.action if status is NodeStatus.RUNNING else None
    else:
        status = NodeStatus.SUCCESS if isinstance(node, Sequence) else NodeStatus.FAILURE
        for child in node.children:
            child_status, running = tick(child, state, task, visitor)
            if child_status is not status:
                status = child_status
                break
    if visitor is not None:
        visitor(node, status)
    return status, running


def walk(node: Node) -> Iterator[Node]:
    """Every node of the tree, depth first, parents before children."""
    yield node
    if isinstance(node, Sequence | Fallback):
        for child in node.children:
            yield from walk(child)


@dataclass(frozen=True, slots=True)
class TreeSize:
    """Nodes, depth (a leaf has depth 1) and literal occurrences in Conditions."""

    nodes: int
    depth: int
    literals: int

    def to_dict(self) -> dict[str, int]:
        return {"nodes": self.nodes, "depth": self.depth, "literals": self.literals}


def size(node: Node) -> TreeSize:
    """The :class:`TreeSize` of a tree."""
    if isinstance(node, Condition):
        return TreeSize(1, 1, len(node.literals))
    if isinstance(node, Action):
        return TreeSize(1, 1, 0)
    sizes = [size(child) for child in node.children]
    return TreeSize(
        1 + sum(s.nodes for s in sizes),
        1 + max((s.depth for s in sizes), default=0),
        sum(s.literals for s in sizes),
    )


__all__ = [
    "MAX_TREE_DEPTH",
    "MAX_TREE_NODES",
    "Action",
    "Condition",
    "Fallback",
    "Node",
    "NodeStatus",
    "Sequence",
    "TreeSize",
    "Visitor",
    "size",
    "tick",
    "walk",
]
