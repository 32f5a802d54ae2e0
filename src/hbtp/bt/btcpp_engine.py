"""Tick a tree in BehaviorTree.CPP itself (through ``behaviortreepy``), backed by the symbolic world.

The tree is written in the export flavour the binding loads as is (``hbtp export --format
btcpp-named``: :func:`hbtp.bt.btcpp.tree_to_btcpp` with ``ports=False``): one node ID per predicate
and action predicate, the grounded literal in each leaf's ``name``, no ports (``behaviortreepy``
0.1.4 registers Python callbacks without ports, and BT.CPP rejects a port attribute a node type does
not declare). The port-based flavour (``--format btcpp``) is the one C++ users implement; it loads
in BT.CPP once each node type declares its ``arg1..argN`` input ports.

Each condition callback succeeds iff its literal holds in the symbolic state; each action callback,
if its precondition holds, applies the action's effects and returns RUNNING (a stateful action), so
the reactive parents re-check the goal and the conditions at the next tick, as hbtp's own
:func:`~hbtp.logic.execution.execute` does. Before each tick a disturbance (the executor's
:class:`~hbtp.logic.execution.Disturbance`) may change the state. The result is the executor's
:class:`~hbtp.logic.execution.Run`, so both engines are compared field by field.
"""

from __future__ import annotations

import contextlib
import importlib
import logging
import time
from collections.abc import Iterator
from dataclasses import dataclass
from pathlib import Path
from typing import Any

from hbtp.bt.btcpp import tree_to_btcpp, used_node_ids
from hbtp.bt.btlog import read_btlog
from hbtp.bt.nodes import Node
from hbtp.errors import HbtpError, InputError
from hbtp.logic.execution import Disturbance, NodeStatus, Run
from hbtp.logic.task import GroundTask, State

log = logging.getLogger(__name__)

__all__ = ["BtcppEngine", "Watch", "btcpp_binding"]


def btcpp_binding() -> Any:
    """The ``behaviortreepy`` module, or a one-line :class:`InputError` saying how to install it."""
    try:
        return importlib.import_module("behaviortreepy")
    except ImportError:
        raise InputError("--engine btcpp needs BehaviorTree.CPP's Python binding: pip install 'hbtp[btcpp]'") from None


class BtcppEngine:
    """BehaviorTree.CPP ticking ``tree`` over ``task``'s symbolic state (see the module docstring)."""

    def __init__(self, tree: Node, task: GroundTask) -> None:
        self.bt = btcpp_binding()
        self.task = task
        self.xml = tree_to_btcpp(tree, task, ports=False)
        self.state: State = task.initial_state
        self.executed: list[int] = []
        self.errors: list[str] = []  # the binding turns a Python exception into FAILURE: kept to report
        self.factory = self.bt.BehaviorTreeFactory()
        conditions, actions = used_node_ids(tree, task)
        for node_id in conditions:
            self.factory.register_simple_condition(node_id, self._condition)
        for node_id in actions:
            self.factory.register_simple_stateful_action(node_id, self._action, self._action)

    def _condition(self, node: Any) -> Any:
        try:
            holds = self.task.atom_id(node.name()) in self.state
        except Exception as error:  # a name the task does not know: a bug, reported after the run
            self.errors.append(f"condition {node.name()!r}: {error}")
            raise
        return self.bt.NodeStatus.SUCCESS if holds else self.bt.NodeStatus.FAILURE

    def _action(self, node: Any) -> Any:
        try:
            grounded = self.task.action(node.name())
        except Exception as error:
            self.errors.append(f"action {node.name()!r}: {error}")
            raise
        if not grounded.applicable(self.state):
            return self.bt.NodeStatus.FAILURE
        self.state = grounded.progress(self.state)
        self.executed.append(grounded.index)
        return self.bt.NodeStatus.RUNNING

    def run(
        self,
        state: State | None = None,
        *,
        max_ticks: int,
        disturbance: Disturbance | None = None,
        watch: Watch | None = None,
    ) -> Run:
        """Tick from ``state`` (default s0) until the root is not RUNNING or ``max_ticks`` ticks;
        ``watch`` publishes the run to Groot2 and/or writes BT.CPP's log of it."""
        if max_ticks < 1:
            raise InputError(f"max_ticks must be at least 1, not {max_ticks}")
        self.state = self.task.initial_state if state is None else frozenset(state)
        self.executed, self.errors = [], []
        tree = self.factory.create_tree_from_text(self.xml)
        with (watch or Watch()).attached(self.bt, tree):
            return self._tick(tree, max_ticks, disturbance)

    def _tick(self, tree: Any, max_ticks: int, disturbance: Disturbance | None) -> Run:
        running = self.bt.NodeStatus.RUNNING
        status, events, ticks = running, 0, 0
        last: int | None = None
        before: State | None = None
        for ticks in range(1, max_ticks + 1):
            if disturbance is not None:
                event = disturbance(ticks, self.state, last, before)
                if event is not None:
                    self.state = event.apply(self.state)
                    events += 1
            done = len(self.executed)
            before = self.state
            status = tree.tick_once()
            last = self.executed[-1] if len(self.executed) > done else None
            if status != running:
                break
        if self.errors:
            raise HbtpError(f"BehaviorTree.CPP callbacks failed: {'; '.join(self.errors[:3])}")
        cost = sum(self.task.actions[i].cost for i in self.executed)
        return Run(_status(self.bt, status), tuple(self.executed), cost, ticks, self.state, events)


@dataclass(frozen=True)
class Watch:
    """Who watches a BT.CPP run: Groot2 live on ``groot_port``, a FileLogger2 log at ``btlog``."""

    groot_port: int | None = None
    btlog: Path | None = None

    @contextlib.contextmanager
    def attached(self, bt: Any, tree: Any) -> Iterator[None]:
        """The publisher and the logger attached to ``tree`` while the run lasts (the log flushed)."""
        publisher = logger = None
        if self.groot_port is not None:
            try:
                publisher = bt.Groot2Publisher(tree, self.groot_port)
            except RuntimeError as error:  # the port is taken (by Groot2Publisher or another program)
                raise InputError(f"cannot publish to Groot2 on port {self.groot_port}: {error}") from None
        if self.btlog is not None:
            self.btlog.parent.mkdir(parents=True, exist_ok=True)
            logger = bt.FileLogger(tree, str(self.btlog))
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
                _await_whole_log(self.btlog)


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
