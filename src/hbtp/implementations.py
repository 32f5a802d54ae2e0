"""The user's implementation of each action, for :class:`hbtp.runtime.Runtime`.

An implementation is a :class:`StatefulAction`, as BehaviorTree.CPP's ``StatefulActionNode`` has
one: ``on_start`` when the action starts, ``on_running`` on each later tick while it runs, and
``on_halted`` when it is stopped while RUNNING (see :mod:`hbtp.logic.lifecycle` for when). Start
and running return ``"success"``, ``"failure"``, ``"running"`` (or a :class:`NodeStatus`, or a
bool); halt returns nothing. A plain callable is the implementation whose start and running are that
callable and whose halt does nothing.

:func:`implementations` maps each ground action of a task to its implementation: by the action's
name (``RightGrab(apple)``), else by its predicate (``RightGrab``: then every callback is called with
the action's objects as arguments); an action without one fails when called (logged once).
"""

from __future__ import annotations

import logging
from collections.abc import Callable, Mapping
from dataclasses import dataclass
from typing import Any

from hbtp.errors import InputError
from hbtp.logic.atoms import declared_action, parse_atom
from hbtp.logic.execution import NodeStatus
from hbtp.logic.lifecycle import Phase
from hbtp.logic.task import GroundTask

log = logging.getLogger(__name__)

__all__ = ["ActionCallback", "Bound", "StatefulAction", "implementations", "read_status", "shown"]

#: A callback of an action's implementation (called with the action's objects when it is given
#: for an action predicate).
ActionCallback = Callable[..., Any]

_STATUS = {"success": NodeStatus.SUCCESS, "failure": NodeStatus.FAILURE, "running": NodeStatus.RUNNING}


@dataclass(frozen=True)
class StatefulAction:
    """An action's implementation: ``on_start``, ``on_running`` (default: ``on_start`` again) and
    ``on_halted`` (default: nothing), as BehaviorTree.CPP's ``StatefulActionNode``."""

    on_start: ActionCallback
    on_running: ActionCallback | None = None
    on_halted: ActionCallback | None = None

    def __post_init__(self) -> None:
        for name in ("on_start", "on_running", "on_halted"):
            value = getattr(self, name)
            if value is not None and not callable(value):
                raise InputError(f"{name} of a StatefulAction must be callable, not {shown(value)}")
        if self.on_start is None:
            raise InputError("a StatefulAction needs on_start")

    @classmethod
    def of(cls, implementation: StatefulAction | ActionCallback) -> StatefulAction:
        """``implementation`` itself, or a plain callable as start and running with no halt."""
        if isinstance(implementation, StatefulAction):
            return implementation
        if not callable(implementation):
            raise InputError(
                f"an action's implementation must be callable or a StatefulAction: {shown(implementation)}"
            )
        return cls(implementation)

    def callback(self, phase: Phase) -> ActionCallback:
        """What a tick calls: ``on_start`` when the action starts, ``on_running`` while it goes on."""
        if phase is Phase.RUNNING and self.on_running is not None:
            return self.on_running
        return self.on_start


@dataclass(frozen=True)
class Bound:
    """A ground action's implementation and the arguments its callbacks take (its objects when the
    implementation was given for its predicate, else none)."""

    implementation: StatefulAction
    args: tuple[str, ...] = ()


def read_status(answer: Any) -> NodeStatus | str:
    """An action's answer as a status, or the answer shown (:func:`shown`) when it is none."""
    if isinstance(answer, NodeStatus):
        return answer
    if isinstance(answer, bool):
        return NodeStatus.SUCCESS if answer else NodeStatus.FAILURE
    if isinstance(answer, str):
        status = _STATUS.get(str.__str__(answer).strip().lower())
        if status is not None:
            return status
    return shown(answer)


def shown(value: Any) -> str:
    """``repr(value)`` for a message, or its type when even that fails (the user's objects)."""
    try:
        text = repr(value)
    except Exception:
        return f"<{type(value).__name__}>"
    return text if len(text) <= 200 else text[:200] + "..."


def implementations(task: GroundTask, actions: Mapping[str, StatefulAction | ActionCallback]) -> dict[int, Bound]:
    """Each ground action's implementation: by its name, else by its predicate (with its objects).

    The further ground actions of a PDDL action with a disjunctive precondition (``go-alt2(y,z)``,
    see :func:`hbtp.logic.atoms.alternative_name`) share the implementation of ``go(y,z)`` / ``go``."""
    by_name: dict[tuple[str, tuple[str, ...]], StatefulAction] = {}
    by_predicate: dict[str, StatefulAction] = {}
    predicates = set(task.action_predicates)
    for key, given in actions.items():
        if not isinstance(given, StatefulAction) and not callable(given):
            raise InputError(f"the implementation of {key!r} is not callable")
        implementation = StatefulAction.of(given)
        if key in predicates:
            by_predicate[key] = implementation
            continue
        try:
            named = task.action(parse_atom(key))
        except InputError as error:
            raise InputError(f"no action or action predicate {key!r} in {task.name}: {error}") from None
        by_name[(named.predicate, named.objects)] = implementation
    table: dict[int, Bound] = {}
    for ground in task.actions:
        for predicate in dict.fromkeys((ground.predicate, declared_action(ground.predicate))):
            if (predicate, ground.objects) in by_name:
                table[ground.index] = Bound(by_name[(predicate, ground.objects)])
            elif predicate in by_predicate:
                table[ground.index] = Bound(by_predicate[predicate], tuple(ground.objects))
            else:
                continue
            break
    return _complete(task, table)


def _complete(task: GroundTask, table: dict[int, Bound]) -> dict[int, Bound]:
    """Actions without an implementation fail when called (logged once each)."""
    warned: set[str] = set()

    def missing(name: str) -> StatefulAction:
        def fail(*_: str) -> NodeStatus:
            if name not in warned:
                warned.add(name)
                log.warning("no implementation for %s: it fails", name)
            return NodeStatus.FAILURE

        return StatefulAction(fail)

    for ground in task.actions:
        table.setdefault(ground.index, Bound(missing(ground.name)))
    return table
