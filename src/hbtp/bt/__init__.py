"""Behavior trees: the node model, ticking, building from a search, views and exchange formats."""

from hbtp.bt.build import full_tree, path_tree, tree_of
from hbtp.bt.nodes import Action, Condition, Fallback, Node, NodeStatus, Sequence, size, tick, walk
from hbtp.bt.text import render_text

__all__ = [
    "Action",
    "Condition",
    "Fallback",
    "Node",
    "NodeStatus",
    "Sequence",
    "full_tree",
    "path_tree",
    "render_text",
    "size",
    "tick",
    "tree_of",
    "walk",
]
