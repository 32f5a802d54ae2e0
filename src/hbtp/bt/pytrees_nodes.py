"""The behaviour classes of :func:`hbtp.bt.pytrees_xml.node_registry`: what py_trees' BT.CPP-XML
reader builds for our node IDs, ``AlwaysSuccess`` and BT.CPP's reactive control nodes.

This module imports py_trees (2.6 or later): import it only through :mod:`hbtp.bt.pytrees_xml`,
which says how to install py_trees when it is missing. The leaves read the state of the current
tick from a shared :class:`~hbtp.bt.pytrees_xml.TickState` and apply no effects.
"""

from __future__ import annotations

from typing import TYPE_CHECKING, Any

import py_trees
from py_trees.common import Status
from py_trees.ports import PortInformation, PortsMixin

from hbtp.logic.atoms import Atom, parse_atom

if TYPE_CHECKING:
    from hbtp.bt.pytrees_xml import TickState

__all__ = ["Act", "AlwaysSuccess", "Check", "ReactiveFallback", "ReactiveSequence"]


def grounded(predicate: str, name: str, args: dict[str, str]) -> Atom:
    """The leaf's literal or action: from the ports ``arg1..argN``, else from the last part of its
    name (the reader prefixes the names of its ancestors: ``Sequence 3.IsOpen(fridge)``)."""
    if args:
        return Atom(predicate, tuple(args[f"arg{i}"] for i in range(1, len(args) + 1)))
    cut = name.rfind("(")
    return parse_atom(name[name.rfind(".", 0, cut if cut >= 0 else len(name)) + 1 :])


class NoPorts(PortsMixin, register=False):
    """A node of the registry: it declares no ports (the ``argN`` attributes reach the constructor)."""

    # PortsMixin declares them as plain attributes, which every concrete class assigns
    INPUT_PORTS: dict[str, PortInformation] = {}  # noqa: RUF012
    OUTPUT_PORTS: dict[str, PortInformation] = {}  # noqa: RUF012


class Check(NoPorts, py_trees.behaviour.Behaviour, register=False):
    """A condition ID: SUCCESS iff the literal holds in the tick's state."""

    def __init__(self, name: str, shared: TickState, predicate: str, **kwargs: str) -> None:
        behaviour_class = kwargs.pop("behaviour_class_name", None)
        super().__init__(name=name, behaviour_class_name=behaviour_class)
        self.shared = shared  # not ``self.tick``: that is the behaviour's own tick()
        self.atom = shared.task.atom_id(grounded(predicate, name, kwargs))

    def update(self) -> Status:
        return Status.SUCCESS if self.atom in self.shared.state else Status.FAILURE


class Act(NoPorts, py_trees.behaviour.Behaviour, register=False):
    """An action ID: FAILURE unless the action's precondition holds; then the action is recorded in
    the tick's state and the behaviour is RUNNING. Stopped while RUNNING (py_trees' halt: a parent
    invalidates it), it records its name in the shared state's ``halted``."""

    def __init__(self, name: str, shared: TickState, predicate: str, **kwargs: str) -> None:
        behaviour_class = kwargs.pop("behaviour_class_name", None)
        super().__init__(name=name, behaviour_class_name=behaviour_class)
        self.shared = shared
        self.action = shared.task.action(grounded(predicate, name, kwargs)).index

    def update(self) -> Status:
        shared = self.shared
        if not shared.task.actions[self.action].applicable(shared.state):
            return Status.FAILURE
        shared.action = self.action
        return Status.RUNNING

    def terminate(self, new_status: Status) -> None:
        if new_status == Status.INVALID and self.status == Status.RUNNING:
            self.shared.halted.append(self.shared.task.actions[self.action].name)


class AlwaysSuccess(NoPorts, py_trees.behaviour.Behaviour, register=False):
    """BT.CPP's AlwaysSuccess: the empty condition."""

    def update(self) -> Status:
        return Status.SUCCESS


class ReactiveSequence(NoPorts, py_trees.composites.Sequence, register=False):
    """BT.CPP's ReactiveSequence: a Sequence without memory (it re-ticks from its first child)."""

    def __init__(self, name: str, children: list[Any], behaviour_class_name: str | None = None) -> None:
        super().__init__(name=name, memory=False, children=children, behaviour_class_name=behaviour_class_name)


class ReactiveFallback(NoPorts, py_trees.composites.Selector, register=False):
    """BT.CPP's ReactiveFallback: a Selector without memory (it re-ticks from its first child)."""

    def __init__(self, name: str, children: list[Any], behaviour_class_name: str | None = None) -> None:
        super().__init__(name=name, memory=False, children=children, behaviour_class_name=behaviour_class_name)
