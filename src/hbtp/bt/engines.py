"""Who ticks a tree: hbtp's own engine, py_trees or BehaviorTree.CPP, each as a tick policy.

An :class:`Engine` is a value; :meth:`Engine.policy` gives the tree as a tick policy
(:data:`hbtp.logic.execution.Policy`: state -> status and, when RUNNING, the action to apply). No
engine applies effects: the world does (hbtp's executor :func:`hbtp.logic.execution.execute`,
with its disturbances, or the user's robot, :class:`hbtp.runtime.Runtime`), so every engine runs in
the same loop and is compared tick for tick.

Each policy is a :class:`TreePolicy`: it also halts its tree (:meth:`TreePolicy.halt`: every
RUNNING node is halted), which a re-plan does before swapping a tree and a run when it ends.
BT.CPP and py_trees keep their nodes' statuses between ticks and halt a RUNNING action themselves
when the reactive parents move on (see :mod:`hbtp.bt.btcpp_engine`, :mod:`hbtp.bt.pytrees_xml`);
which *user* action is halted, and when, is decided from the ticks alone, the same on every engine
(:mod:`hbtp.logic.lifecycle`).

* :attr:`Engine.HBTP`: :func:`hbtp.bt.simulate.compile_tree` (:func:`hbtp.bt.nodes.tick`), which
  keeps nothing between ticks (:class:`HbtpPolicy`: halting it does nothing).
* :attr:`Engine.PY_TREES`: the tree exported as BT.CPP XML (``btcpp``, with ports) and read by
  py_trees' own BT.CPP-XML reader (:class:`hbtp.bt.pytrees_xml.PytreesPolicy`; py_trees >= 2.6).
* :attr:`Engine.BTCPP`: the tree exported as ``btcpp-named`` XML and ticked by BehaviorTree.CPP
  through ``behaviortreepy`` (:class:`hbtp.bt.btcpp_engine.BtcppPolicy`).
"""

from __future__ import annotations

import enum
from typing import Protocol

from hbtp.bt.btcpp_engine import BtcppPolicy, btcpp_binding
from hbtp.bt.nodes import Node
from hbtp.bt.pytrees_xml import PytreesPolicy, require_py_trees
from hbtp.bt.simulate import compile_tree
from hbtp.logic.execution import NodeStatus
from hbtp.logic.task import GroundTask, State

__all__ = ["Engine", "HbtpPolicy", "TreePolicy"]


class TreePolicy(Protocol):
    """A tree ticked by an engine: a tick policy (state -> status and, when RUNNING, the action)
    that can halt its tree."""

    def __call__(self, state: State, /) -> tuple[NodeStatus, int | None]: ...

    def halt(self) -> None:
        """Halt the tree: every RUNNING node is halted, every node idle."""


class HbtpPolicy:
    """hbtp's own tick as a :class:`TreePolicy`: a pure function of the state, nothing to halt."""

    def __init__(self, tree: Node, task: GroundTask) -> None:
        self.tick = compile_tree(tree, task)

    def __call__(self, state: State) -> tuple[NodeStatus, int | None]:
        return self.tick(state)

    def halt(self) -> None:
        """Nothing to do: the tick keeps no state between ticks."""


class Engine(enum.Enum):
    """An engine that ticks trees; its value is its name on the command line (``--engine``)."""

    HBTP = "hbtp"
    PY_TREES = "pytrees"
    BTCPP = "btcpp"

    @property
    def label(self) -> str:
        """The engine's name for people: ``hbtp``, ``py_trees``, ``BehaviorTree.CPP``."""
        return {"hbtp": "hbtp", "pytrees": "py_trees", "btcpp": "BehaviorTree.CPP"}[self.value]

    def require(self) -> None:
        """Check that the engine's library is installed (a one-line :class:`InputError` if not)."""
        if self is Engine.PY_TREES:
            require_py_trees()
        elif self is Engine.BTCPP:
            btcpp_binding()

    def policy(self, tree: Node, task: GroundTask) -> TreePolicy:
        """``tree`` ticked by this engine, as a policy over ``task``'s states (see the module docstring)."""
        if self is Engine.PY_TREES:
            return PytreesPolicy(tree, task)
        if self is Engine.BTCPP:
            return BtcppPolicy(tree, task)
        return HbtpPolicy(tree, task)
