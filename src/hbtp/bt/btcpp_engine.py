"""Tick a tree in BehaviorTree.CPP itself (through ``behaviortreepy``), backed by the symbolic world.

The tree is written in the export flavour the binding loads as is (``hbtp export --format
btcpp-named``: :func:`hbtp.bt.btcpp.tree_to_btcpp` with ``ports=False``): one node ID per predicate
and action predicate, the grounded literal in each leaf's ``name``, no ports (``behaviortreepy``
0.1.4 registers Python callbacks without ports, and BT.CPP rejects a port attribute a node type does
not declare). The port-based flavour (``--format btcpp``) is the one C++ users implement; it loads
in BT.CPP once each node type declares its ``arg1..argN`` input ports.

:class:`BtcppPolicy` is BT.CPP as a tick policy (:data:`hbtp.logic.execution.Policy`): each call
ticks the tree once in the state given. Each condition callback succeeds iff its literal holds in
that state; each action is a stateful action whose start and running callbacks fail when the
action's precondition does not hold and otherwise record the action and return RUNNING, which the
reactive parents pass up to the root. The policy applies no effects: the world does (hbtp's executor
:func:`~hbtp.logic.execution.execute`, with its disturbances, or the user's robot through
:class:`hbtp.runtime.Runtime`). The tree keeps its statuses between ticks, as BT.CPP does: a
RUNNING action ticked again goes on (``onRunning``), and the reactive parents (the export's
``ReactiveFallback``/``ReactiveSequence``; a condition group's plain ``Sequence`` holds conditions
only, which never run) re-check the goal and every condition before it at each tick, as hbtp's own
:func:`~hbtp.bt.nodes.tick` does, and halt it (``onHalted``) when another branch takes over or the
root ends. :meth:`BtcppPolicy.halt` halts the whole tree (a re-plan swapping it, the end of a
run). Between ticks the tree keeps the statuses of the last one, which Groot2 shows.
:class:`BtcppEngine` runs the policy in hbtp's executor from a state, with Groot2 and BT.CPP's log
watching (:class:`Watch`, one tree after the other when re-plans swap them: :class:`Watcher`);
its result is the executor's :class:`~hbtp.logic.execution.Run`, so both engines are compared field
by field.
"""

from __future__ import annotations

import contextlib
import importlib
import logging
import math
import tempfile
import time
from collections.abc import Iterator
from dataclasses import dataclass
from pathlib import Path
from typing import Any

from hbtp.bt.btcpp import tree_to_btcpp, used_node_ids
from hbtp.bt.btlog import btlog_paths, read_btlog
from hbtp.bt.groot2 import groot2_publisher
from hbtp.bt.live import LiveOptions
from hbtp.bt.nodes import Node
from hbtp.bt.simulate import simulate
from hbtp.errors import HbtpError, InputError
from hbtp.files import InputKind, check_output, read_bytes, write_all_atomically
from hbtp.logic.execution import Disturbance, NodeStatus, Run
from hbtp.logic.task import GroundTask, State

log = logging.getLogger(__name__)

__all__ = ["BtcppEngine", "BtcppPolicy", "Watch", "Watcher", "btcpp_binding"]


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
            self.factory.register_simple_stateful_action(
                node_id, self.calls.action, self.calls.action, self.calls.halted
            )
        #: The BT.CPP tree, built from :attr:`xml` (the exported text itself).
        self.tree = self.factory.create_tree_from_text(self.xml)

    def __call__(self, state: State) -> tuple[NodeStatus, int | None]:
        calls = self.calls
        calls.state, calls.ticked, calls.errors = state, None, []
        status = _status(self.bt, self.tree.tick_once())
        if calls.errors:
            raise HbtpError(f"BehaviorTree.CPP callbacks failed: {'; '.join(calls.errors[:3])}")
        if status is not NodeStatus.RUNNING:
            return status, None
        if calls.ticked is None:
            raise HbtpError("BehaviorTree.CPP's root is RUNNING but no action was ticked")
        return status, calls.ticked

    def halt(self) -> None:
        """Halt the tree: each RUNNING node is halted (an action's ``onHalted``), every node idle."""
        self.tree.halt_tree()

    @property
    def halted(self) -> list[str]:
        """The action nodes BT.CPP halted while they were RUNNING, by name, in order."""
        return self.calls.halted_nodes


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
        self.halted_nodes: list[str] = []

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

    def halted(self, node: Any) -> None:
        self.halted_nodes.append(node.name())


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
        live: LiveOptions | None = None,
    ) -> Run:
        """Tick from ``state`` (default s0) until the root is not RUNNING or ``max_ticks`` ticks;
        ``watch`` publishes the run to Groot2 and/or writes BT.CPP's log of it, ``trace`` records
        every tick in :attr:`Run.trace`, ``live`` gives the ticks per action and the tick rate. Each
        run ticks a tree of its own, halted when the run ends (an action still running is halted)
        and then freed."""
        if max_ticks < 1:
            raise InputError(f"max_ticks must be at least 1, not {max_ticks}")
        policy = BtcppPolicy(self.tree, self.task, self.xml)
        with (watch or Watch()).attached(self.bt, policy):
            try:
                return simulate(
                    self.tree, self.task, state, max_ticks=max_ticks, disturbance=disturbance, trace=trace,
                    policy=policy, live=live,
                )  # fmt: skip
            finally:
                policy.halt()


@dataclass(frozen=True)
class Watch:
    """Who watches a BT.CPP run: Groot2 live on ``groot_port`` (``groot_wait_s`` seconds given to
    Groot2 to connect before the first tick), a FileLogger2 log at ``btlog`` (one file per tree of
    the run: :func:`hbtp.bt.btlog.btlog_paths`)."""

    groot_port: int | None = None
    btlog: Path | None = None
    groot_wait_s: float = 0.0

    def __post_init__(self) -> None:
        if not (0 <= self.groot_wait_s < math.inf):
            raise InputError(f"the wait for Groot2 must be a finite number of seconds >= 0, not {self.groot_wait_s!r}")
        if self.groot_wait_s and self.groot_port is None:
            raise InputError("a wait for Groot2 needs a port to publish on")

    @contextlib.contextmanager
    def attached(self, bt: Any, policy: BtcppPolicy) -> Iterator[Watcher]:
        """The publisher and the logger attached to ``policy``'s tree while the run lasts (the log
        written when it ends); the :class:`Watcher` yielded attaches them to the later trees of a
        run that swaps trees."""
        with self.watching(bt) as watcher:
            watcher.attach(policy)
            yield watcher

    @contextlib.contextmanager
    def watching(self, bt: Any) -> Iterator[Watcher]:
        """A :class:`Watcher` for the trees of one run; when the run ends, every tree's log is
        written (BT.CPP's logger writes files of a private temporary folder; the logs are then
        written as hbtp writes every output: regular files only, all or nothing)."""
        if self.btlog is not None:
            check_output(self.btlog)
        with tempfile.TemporaryDirectory(prefix="hbtp-btlog-") as folder:
            watcher = Watcher(self, bt, Path(folder))
            try:
                yield watcher
            finally:
                watcher.detach()
                watcher.write_logs()


class Watcher:
    """Groot2 and BT.CPP's log watching the trees of one run, one after the other: :meth:`attach`
    moves them to the tree a re-plan swapped in (a new publisher on the same port, which Groot2
    sees as a new tree; a new log file)."""

    def __init__(self, watch: Watch, bt: Any, folder: Path) -> None:
        self.watch = watch
        self.bt = bt
        self.folder = folder
        #: The policy watched now, kept alive while its publisher and logger are.
        self.policy: BtcppPolicy | None = None
        self.publisher: Any = None
        self.logger: Any = None
        #: The staged log of each tree watched, in order.
        self.logs: list[Path] = []
        self.trees = 0

    def attach(self, policy: BtcppPolicy) -> None:
        """Watch ``policy``'s tree from now on (the tree before is no longer watched). The first
        time, wait ``groot_wait_s`` seconds for Groot2 to connect: the binding cannot tell whether
        a client did."""
        self.detach()
        port, wait = self.watch.groot_port, self.watch.groot_wait_s
        self.policy, self.trees = policy, self.trees + 1
        if port is not None:
            try:
                self.publisher = groot2_publisher(self.bt, policy.tree, port)
            except RuntimeError as error:  # the port is taken (by Groot2Publisher or another program)
                raise InputError(f"cannot publish to Groot2 on port {port}: {error}") from None
        if self.watch.btlog is not None:
            staged = self.folder / f"tree-{len(self.logs)}.btlog"
            self.logs.append(staged)
            self.logger = self.bt.FileLogger(policy.tree, str(staged))
        if port is not None and wait > 0 and self.trees == 1:
            log.info("published to Groot2 on port %d: waiting %g s before the first tick", port, wait)
            time.sleep(wait)

    def detach(self) -> None:
        """Stop watching the current tree (its log closed)."""
        if self.logger is not None:
            # Not logger.flush(): in BT.CPP 4.8 it writes the file from this thread while the
            # logger's writer thread does too (a race fixed upstream in BehaviorTree.CPP #1102)
            # and can garble the log. The writer thread wakes every 10 ms: let it drain its
            # queue, then the destructor stops it and closes the file.
            time.sleep(LOG_DRAIN_S)
        self.logger = self.publisher = None  # the destructors close the log and the port
        self.policy = None

    def write_logs(self) -> None:
        """Write the log of each tree watched to :func:`~hbtp.bt.btlog.btlog_paths` of ``btlog``."""
        if self.watch.btlog is None or not self.logs:
            return
        for staged in self.logs:
            _await_whole_log(staged)
        targets = btlog_paths(self.watch.btlog, len(self.logs))
        pairs = zip(targets, self.logs, strict=True)
        write_all_atomically({path: read_bytes(staged, InputKind.TRACE) for path, staged in pairs})


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
