"""The behavior-tree model: Condition, Action, Sequence, Fallback, and ticking.

Ticking is a pure function of the state: a Condition succeeds iff all its literals hold; an Action
is RUNNING when its preconditions hold (the executor then applies it) and FAILURE otherwise; a
Sequence returns the first child status that is not SUCCESS; a Fallback the first that is not
FAILURE. Node literals and actions are ids of one grounded task.
"""

from __future__ import annotations

import enum
from collections.abc import Iterator
from dataclasses import dataclass

from hbtp.logic.task import GroundTask, State

#: The deepest tree hbtp reads from a file (a single leaf has depth 1). Ticking, verifying and
#: exporting recurse once or twice per level, so this keeps them well inside Python's recursion
#: limit (and the py_trees export inside the Python parser's 200 nested brackets); planned trees are
#: far shallower (at most 7 levels over every task of the shipped datasets, compacted or not).
MAX_TREE_DEPTH = 90

#: The most nodes hbtp reads from a BehaviorTree.CPP file once its ``<SubTree>`` references are
#: expanded (identical subtrees are shared in memory, but ticking and exporting visit every copy).
MAX_TREE_NODES = 1_000_000


class NodeStatus(enum.Enum):
    SUCCESS = "success"
    FAILURE = "failure"
    RUNNING = "running"


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


def tick(node: Node, state: State, task: GroundTask, checks: list[int] | None = None) -> tuple[NodeStatus, int | None]:
    """Tick ``node`` in ``state``: the status and, when RUNNING, the action to apply.

    ``checks``, if given, has its first item increased by every condition node ticked (the tick
    count BTPG reports)."""
    if isinstance(node, Condition):
        if checks is not None:
            checks[0] += 1
        return (NodeStatus.SUCCESS if node.literals <= state else NodeStatus.FAILURE), None
    if isinstance(node, Action):
        if task.actions[node.action].pre <= state:
            return NodeStatus.RUNNING, node.action
        return NodeStatus.FAILURE, None
    stop = NodeStatus.SUCCESS if isinstance(node, Sequence) else NodeStatus.FAILURE
    for child in node.children:
        status, running = tick(child, state, task, checks)
        if status is not stop:
            return status, running
    return stop, None


def walk(node: Node) -> Iterator[Node]:
    """Every node of the tree, depth first, parents before children."""
    yield node
    if isinstance(node, Sequence | Fallback):
        for child in node.children:
            yield from walk(child)


def size(node: Node) -> tuple[int, int]:
    """(number of nodes, depth) of a tree; a single leaf has depth 1."""
    if isinstance(node, Condition | Action):
        return 1, 1
    counts = [size(child) for child in node.children]
    return 1 + sum(c for c, _ in counts), 1 + max((d for _, d in counts), default=0)
