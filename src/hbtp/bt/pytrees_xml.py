"""py_trees ticking our BehaviorTree.CPP XML through py_trees' own BT.CPP-XML reader.

py_trees 2.6 reads BT.CPP v4 XML (``py_trees.parsers.behaviour_tree_xml.parse_behaviour_tree_xml``,
experimental). It knows ``Sequence``, ``Fallback``/``Selector`` and ``Parallel`` (a ``memory``
attribute, ``true`` by default), py_trees' decorators by class name (``Inverter``), ``SubTree``,
and resolves every other tag in a *node registry* of :class:`py_trees.ports.PortsMixin` classes:
a leaf's attributes other than ``name`` become its ports or constructor arguments, and its name is
the path of the explicit names of its ancestors and its own (``Sequence 3.Condition 1.IsOpen(fridge)``).
Two things in our export needed the registry or a change, and nothing else:

* ``ReactiveSequence`` and ``ReactiveFallback`` are not tags the reader knows. The registry maps them
  to ``Sequence``/``Selector`` without memory, which re-tick from their first child as BT.CPP's
  reactive nodes do; ``AlwaysSuccess`` (the empty condition) to a leaf that succeeds.
* The reader rejects a tree in which two nodes have the same name ("Duplicate node name found"),
  and a planned tree checks the same literal in many branches. The writer therefore names every
  group and control node but the root after its kind and position (``Sequence 3``), which makes
  every path of names unique (:mod:`hbtp.bt.btcpp`).

Each node ID of the task is registered (:mod:`hbtp.bt.pytrees_nodes`): a condition ID as a behaviour
that succeeds iff its literal holds in the state of the current tick, an action ID as one that fails
when the action's precondition does not hold and otherwise records the action and returns RUNNING.
The grounded objects come from the ports ``arg1..argN`` (the ``btcpp`` flavour; they reach the
constructor as arguments) or, without ports (``btcpp-named``), from the last part of the node's
name. Both flavours load. :class:`PytreesPolicy` is the tree as a tick policy
(:data:`hbtp.logic.execution.Policy`) that, like :class:`hbtp.bt.btcpp_engine.BtcppPolicy`,
applies no effects and keeps the tree's statuses between ticks: a RUNNING action ticked again goes
on, and the parents without memory re-check everything before it and stop (halt) it when another
branch takes over or the root ends; :meth:`PytreesPolicy.halt` stops the whole tree.
"""

from __future__ import annotations

import functools
import tempfile
import weakref
from collections.abc import Callable
from dataclasses import dataclass, field
from pathlib import Path
from typing import Any

from hbtp.bt.btcpp import node_ids, tree_to_btcpp
from hbtp.bt.nodes import Node
from hbtp.errors import HbtpError, InputError
from hbtp.logic.execution import NodeStatus
from hbtp.logic.task import GroundTask, State

__all__ = ["PytreesPolicy", "TickState", "node_registry", "pytrees_from_btcpp", "require_py_trees"]


def require_py_trees() -> Any:
    """The ``py_trees`` module (2.6 or later, for its XML reader), or a one-line :class:`InputError`."""
    try:
        import py_trees
        import py_trees.parsers.behaviour_tree_xml  # py_trees >= 2.6
    except ImportError:
        raise InputError(
            "--engine pytrees needs py_trees 2.6 or later (its BT.CPP-XML reader): pip install 'py-trees>=2.6'"
        ) from None
    return py_trees


@dataclass
class TickState:
    """What the behaviours of one tree share: the state of the current tick, the action ticked, and
    the actions py_trees halted (stopped while RUNNING), by name, in order."""

    task: GroundTask
    state: State = field(default=frozenset())
    action: int | None = None
    halted: list[str] = field(default_factory=list)


def node_registry(tick: TickState) -> dict[str, Callable[..., Any]]:
    """The reader's node registry for ``tick.task``: every condition and action ID bound to
    ``tick``, the reactive control nodes and ``AlwaysSuccess``."""
    require_py_trees()
    from hbtp.bt import pytrees_nodes as nodes  # imports py_trees

    ids = node_ids(tick.task)
    registry: dict[str, Callable[..., Any]] = {
        "AlwaysSuccess": nodes.AlwaysSuccess,
        "ReactiveSequence": nodes.ReactiveSequence,
        "ReactiveFallback": nodes.ReactiveFallback,
    }
    for node_id, predicate in ids.condition_predicates.items():
        registry[node_id] = functools.partial(nodes.Check, shared=tick, predicate=predicate)
    for node_id, predicate in ids.action_predicates.items():
        registry[node_id] = functools.partial(nodes.Act, shared=tick, predicate=predicate)
    return registry


def pytrees_from_btcpp(xml_text: str, tick: TickState, source: str = "<xml>") -> Any:
    """The py_trees tree that py_trees' BT.CPP-XML reader builds from ``xml_text`` (written to a
    temporary file, as the reader reads files), its leaves bound to ``tick``; a one-line
    :class:`InputError` when the reader refuses it."""
    require_py_trees()
    from py_trees.parsers.behaviour_tree_xml import parse_behaviour_tree_xml

    registry = node_registry(tick)
    with tempfile.TemporaryDirectory(prefix="hbtp-") as folder:
        path = Path(folder) / "tree.xml"
        path.write_text(xml_text, encoding="utf-8")
        try:
            return parse_behaviour_tree_xml(str(path), node_registry=registry)
        except Exception as error:  # the reader raises ValueError, KeyError, TypeError, its own XMLParserError...
            message = " ".join(str(error).split())
            raise InputError(f"{source}: py_trees' XML reader refused it: {type(error).__name__}: {message}") from None


def _release(root: Any) -> None:
    """Unregister the blackboard clients of a tree's nodes (py_trees keeps them in a global table)."""
    for node in root.iterate():
        for client in node.blackboards:
            client.unregister(clear=True)


class PytreesPolicy:
    """py_trees ticking ``tree`` once per call in the state given: the tree exported as BT.CPP XML
    (the ``btcpp`` flavour, with ports; ``btcpp-named`` with ``ports=False``) and loaded by py_trees'
    reader (see the module docstring)."""

    def __init__(self, tree: Node, task: GroundTask, *, ports: bool = True) -> None:
        self.py_trees = require_py_trees()
        self.tick = TickState(task)
        self.xml = tree_to_btcpp(tree, task, ports=ports)
        self.root = pytrees_from_btcpp(self.xml, self.tick)
        weakref.finalize(self, _release, self.root)

    def __call__(self, state: State) -> tuple[NodeStatus, int | None]:
        Status = self.py_trees.common.Status
        self.tick.state, self.tick.action = state, None
        self.root.tick_once()
        status = self.root.status
        if status == Status.SUCCESS:
            return NodeStatus.SUCCESS, None
        if status == Status.FAILURE:
            return NodeStatus.FAILURE, None
        if self.tick.action is None:
            raise HbtpError(f"py_trees' root is {status.value} but no action was ticked")
        return NodeStatus.RUNNING, self.tick.action

    def halt(self) -> None:
        """Stop the tree: each RUNNING behaviour is stopped (halted), every one INVALID."""
        if self.root.status != self.py_trees.common.Status.INVALID:
            self.root.stop(self.py_trees.common.Status.INVALID)

    @property
    def halted(self) -> list[str]:
        """The actions py_trees halted while they were RUNNING, by name, in order."""
        return self.tick.halted
