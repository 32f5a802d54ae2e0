"""Tick a tree in BehaviorTree.CPP itself (through ``behaviortreepy``), backed by the symbolic world.

The tree is written in the export flavour the binding loads as is (``hbtp export --format
btcpp-named``: :func:`hbtp.bt.btcpp.tree_to_btcpp` with ``ports=False``): one node ID per predicate
and action predicate, the grounded literal in each leaf's ``name``, no ports (``behaviortreepy``
0.1.4 registers Python callbacks without ports, and BT.CPP rejects a port attribute a node type does
not declare). The port-based flavour (``--format btcpp``) is the one C++ users implement; it loads
in BT.CPP once each node type declares its ``arg1..argN`` input ports.

:class:`BtcppPolicy` is BT.CPP as a tick policy (:data:`hbtp.logic.execution.Policy`): each call
ticks the tree once in the state given. Each condition callback succeeds iff its literal holds in
that state; each action callback fails when the action's precondition does not hold and otherwise
records the action and returns RUNNING (a stateful action), which the reactive parents pass up to
the root. The policy applies no effects: the world does (hbtp's executor
:func:`~hbtp.logic.execution.execute`, with its disturbances, or the user's robot through
:class:`hbtp.runtime.Runtime`). Before a tick that follows a RUNNING one the tree is halted, so
every tick starts from idle nodes and re-checks the goal and every condition, as hbtp's own
:func:`~hbtp.bt.nodes.tick` does, whatever the control nodes (plain ``Sequence``/``Fallback``
would otherwise resume the running child); between ticks the tree keeps the statuses of the last
one, which Groot2 shows. :class:`BtcppEngine` runs the policy in hbtp's executor from a state, with
Groot2 and BT.CPP's log watching (:class:`Watch`); its result is the executor's
:class:`~hbtp.logic.execution.Run`, so both engines are compared field by field.
"""

from __future__ import annotations

import contextlib
import importlib
import logging
import tempfile
import time
from collections.abc import Iterator
from dataclasses import dataclass
from pathlib import Path
from typing import Any

from hbtp.bt.btcpp import tree_to_btcpp, used_node_ids
from hbtp.bt.btlog import read_btlog
from hbtp.bt.nodes import Node
from hbtp.bt.simulate import simulate
from hbtp.errors import HbtpError, InputError
from hbtp.files import InputKind, check_output, read_bytes, write_atomically
from hbtp.logic.execution import Disturbance, NodeStatus, Run
from hbtp.logic.task import GroundTask, State

log = logging.getLogger(__name__)

__all__ = ["BtcppEngine", "BtcppPolicy", "Watch", "btcpp_binding"]


def btcpp_binding() -> Any:
    """The ``behaviortreepy`` module, or a one-line :class:`InputError` saying how to install it."""
    try:
        return importlib.import_module("behaviortreepy")
    except ImportError:
        raise InputError("--engine btcpp needs BehaviorTree.CPP's Python binding: pip install 'hbtp[btcpp]'") from None


class BtcppPolicy:
    """BehaviorTree.CPP ticking ``tree`` once per call in the state given (see the module docstring)."""

    def __init__(self, tree: Node, task: GroundTask, xml: str | None = None) -> None:
        self.bt = btcpp_binding()
        #: The ``btcpp-named`` export of ``tree`` (``xml`` when the caller has it already).
        self.xml = xml if xml is not None else tree_to_btcpp(tree, task, ports=False)
        self.calls = _Callbacks(self.bt, task)
        self.factory = self.bt.BehaviorTreeFactory()
        conditions, actions = used_node_ids(tree, task)
        for node_id in conditions:
            self.factory.register_simple_condition(node_id, self.calls.condition)
        for node_id in actions:
            self.factory.register_simple_stateful_action(node_id, self.calls.action, self.calls.action)
        #: The BT.CPP tree, built from :attr:`xml` (the exported text itself).
        self.tree = self.factory.create_tree_from_text(self.xml)
        self.running = False

    def __call__(self, state: State) -> tuple[NodeStatus, int | None]:
        if self.running:
            self.tree.halt_tree()  # the next tick starts from idle nodes
        calls = self.calls
        calls.state, calls.ticked, calls.errors = state, None, []
        status = _status(self.bt, self.tree.tick_once())
        if calls.errors:
            raise HbtpError(f"BehaviorTree.CPP callbacks failed: {'; '.join(calls.errors[:3])}")
        self.running = status is NodeStatus.RUNNING
        if not self.running:
            return status, None
        if calls.ticked is None:
            raise HbtpError("BehaviorTree.CPP's root is RUNNING but no action was ticked")
        return status, calls.ticked


class _Callbacks:
    """The Python side of a BT.CPP tree: the state of the tick its callbacks read, the action ticked,
    the errors. Kept apart from the policy so that the factory's callbacks refer to nothing that
    refers back to the factory: the tree is freed as soon as its policy is, not by a later garbage
    collection."""

    def __init__(self, bt: Any, task: GroundTask) -> None:
        self.bt = bt
        self.task = task
        self.state: State = frozenset()
        self.ticked: int | None = None
        self.errors: list[str] = []  # the binding turns a Python exception into FAILURE: kept to report

    def condition(self, node: Any) -> Any:
        try:
            holds = self.task.atom_id(node.name()) in self.state
        except Exception as error:  # a name the task does not know: a bug, reported after the tick
            self.errors.append(f"condition {node.name()!r}: {error}")
            raise
        return self.bt.NodeStatus.SUCCESS if holds else self.bt.NodeStatus.FAILURE

    def action(self, node: Any) -> Any:
        try:
            grounded = self.task.action(node.name())
        except Exception as error:
            self.errors.append(f"action {node.name()!r}: {error}")
            raise
        if not grounded.applicable(self.state):
            return self.bt.NodeStatus.FAILURE
        self.ticked = grounded.index
        return self.bt.NodeStatus.RUNNING


class BtcppEngine:
    """Runs of ``tree`` over ``task``'s symbolic state, ticked by BehaviorTree.CPP
    (:class:`BtcppPolicy` in hbtp's executor), optionally watched by Groot2 and BT.CPP's log."""

    def __init__(self, tree: Node, task: GroundTask) -> None:
        self.bt = btcpp_binding()
        self.tree = tree
        self.task = task
        #: The text every run ticks (the ``btcpp-named`` export).
        self.xml = tree_to_btcpp(tree, task, ports=False)

    @property
    def factory(self) -> Any:
        """A BT.CPP factory with the tree's node IDs registered (to load other layouts of the tree)."""
        return BtcppPolicy(self.tree, self.task, self.xml).factory

    def run(
        self,
        state: State | None = None,
        *,
        max_ticks: int,
        disturbance: Disturbance | None = None,
        watch: Watch | None = None,
        trace: bool = False,
    ) -> Run:
        """Tick from ``state`` (default s0) until the root is not RUNNING or ``max_ticks`` ticks;
        ``watch`` publishes the run to Groot2 and/or writes BT.CPP's log of it, ``trace`` records
        every tick in :attr:`Run.trace`. Each run ticks a tree of its own, freed when it ends."""
        if max_ticks < 1:
            raise InputError(f"max_ticks must be at least 1, not {max_ticks}")
        policy = BtcppPolicy(self.tree, self.task, self.xml)
        with (watch or Watch()).attached(self.bt, policy.tree):
            return simulate(
                self.tree, self.task, state, max_ticks=max_ticks, disturbance=disturbance, trace=trace, policy=policy
            )


@dataclass(frozen=True)
class Watch:
    """Who watches a BT.CPP run: Groot2 live on ``groot_port``, a FileLogger2 log at ``btlog``."""

    groot_port: int | None = None
    btlog: Path | None = None

    @contextlib.contextmanager
    def attached(self, bt: Any, tree: Any) -> Iterator[None]:
        """The publisher and the logger attached to ``tree`` while the run lasts (the log flushed).

        BT.CPP's logger writes a file of a private temporary folder; the whole log is then written
        to ``btlog`` as hbtp writes every output (a regular file only, all or nothing)."""
        if self.btlog is not None:
            check_output(self.btlog)
        with tempfile.TemporaryDirectory(prefix="hbtp-btlog-") as folder:
            publisher = logger = None
            staged = Path(folder) / "run.btlog"
            if self.groot_port is not None:
                try:
                    publisher = bt.Groot2Publisher(tree, self.groot_port)
                except RuntimeError as error:  # the port is taken (by Groot2Publisher or another program)
                    raise InputError(f"cannot publish to Groot2 on port {self.groot_port}: {error}") from None
            if self.btlog is not None:
                logger = bt.FileLogger(tree, str(staged))
            try:
                yield
            finally:
                if logger is not None:
                    # Not logger.flush(): in BT.CPP 4.8 it writes the file from this thread while the
                    # logger's writer thread does too (a race fixed upstream in BehaviorTree.CPP #1102)
                    # and can garble the log. The writer thread wakes every 10 ms: let it drain its
                    # queue, then the destructor stops it and closes the file.
                    time.sleep(LOG_DRAIN_S)
                del logger, publisher
                if self.btlog is not None:
                    _await_whole_log(staged)
                    write_atomically(self.btlog, read_bytes(staged, InputKind.TRACE))


#: Seconds to wait for BT.CPP's log writer (a thread of its own) to finish the file.
LOG_SETTLE_S = 2.0
#: Seconds given to the log writer thread to write what is queued (it wakes every 10 ms).
LOG_DRAIN_S = 0.05


def _await_whole_log(path: Path) -> None:
    """Wait until the log at ``path`` reads whole (every transition record complete), at most
    :data:`LOG_SETTLE_S`: FileLogger2 writes from a thread of its own, and under load the file was
    once read before that thread had finished it."""
    deadline = time.monotonic() + LOG_SETTLE_S
    while True:
        try:
            read_btlog(path)
            return
        except InputError as error:
            if time.monotonic() >= deadline:
                log.warning("%s", error)
                return
            time.sleep(0.01)


def _status(bt: Any, status: Any) -> NodeStatus:
    if status == bt.NodeStatus.SUCCESS:
        return NodeStatus.SUCCESS
    if status == bt.NodeStatus.FAILURE:
        return NodeStatus.FAILURE
    return NodeStatus.RUNNING
