"""py_trees: a live ``py_trees`` tree backed by a symbolic simulator, and a standalone module writer.

The mapping keeps hbtp's semantics (:func:`hbtp.bt.nodes.tick`) tick for tick:

* Fallback -> ``py_trees.composites.Selector(memory=False)``, Sequence ->
  ``py_trees.composites.Sequence(memory=False)``: without memory both restart at their first child on
  every tick, as hbtp's trees do (the goal and every condition are re-checked).
* Condition -> a behaviour that returns SUCCESS iff all its literals hold in the shared world state,
  FAILURE otherwise.
* Action -> a behaviour that, when the action's preconditions hold, applies its effects to the world
  and returns RUNNING (the robot is busy; the next tick restarts at the root and finds out what to do
  next), and returns FAILURE otherwise. The root therefore returns SUCCESS exactly when the goal
  branch holds, and a tick loop from s0 runs the same actions as hbtp's own executor.

``py_trees`` (``pip install 'hbtp[pytrees]'``, py-trees>=2.2) is imported only when a live tree is
built; :func:`write_pytrees_module` needs nothing but hbtp.
"""

from __future__ import annotations

import functools
import json
import logging
from collections.abc import Callable
from dataclasses import dataclass, field
from typing import TYPE_CHECKING

from hbtp.bt.nodes import Action, Condition, Node, Sequence, walk
from hbtp.errors import InputError
from hbtp.logic.task import GroundTask, State

if TYPE_CHECKING:
    import py_trees

logger = logging.getLogger(__name__)


@dataclass
class SymbolicWorld:
    """The simulator state the behaviours share: the current state and the actions applied so far."""

    task: GroundTask
    state: State = field(default=frozenset())
    executed: list[int] = field(default_factory=list)

    @classmethod
    def initial(cls, task: GroundTask) -> SymbolicWorld:
        """A world in the task's initial state s0."""
        return cls(task, task.initial_state)

    def holds(self, literals: frozenset[int]) -> bool:
        return literals <= self.state

    def apply(self, action: int) -> bool:
        """Apply a grounded action if its preconditions hold; returns whether it was applied."""
        grounded = self.task.actions[action]
        if not grounded.applicable(self.state):
            return False
        self.state = grounded.progress(self.state)
        self.executed.append(action)
        logger.debug("applied %s", grounded.name)
        return True


def _require_py_trees() -> None:
    try:
        import py_trees  # noqa: F401
    except ImportError:
        raise InputError("py_trees is not installed: pip install 'hbtp[pytrees]' (py-trees>=2.2)") from None


@functools.cache
def _behaviour_classes() -> tuple[
    Callable[..., py_trees.behaviour.Behaviour], Callable[..., py_trees.behaviour.Behaviour]
]:
    """The condition and action behaviour classes (defined once py_trees is importable)."""
    _require_py_trees()
    import py_trees

    class LiteralCondition(py_trees.behaviour.Behaviour):
        """SUCCESS iff every literal holds in the world, FAILURE otherwise."""

        def __init__(self, name: str, literals: frozenset[int], world: SymbolicWorld) -> None:
            super().__init__(name=name)
            self.literals = literals
            self.world = world

        def update(self) -> py_trees.common.Status:
            if self.world.holds(self.literals):
                return py_trees.common.Status.SUCCESS
            return py_trees.common.Status.FAILURE

    class GroundActionBehaviour(py_trees.behaviour.Behaviour):
        """RUNNING after applying the action when its preconditions hold, FAILURE otherwise."""

        def __init__(self, name: str, action: int, world: SymbolicWorld) -> None:
            super().__init__(name=name)
            self.action = action
            self.world = world

        def update(self) -> py_trees.common.Status:
            if self.world.apply(self.action):
                return py_trees.common.Status.RUNNING
            return py_trees.common.Status.FAILURE

    return LiteralCondition, GroundActionBehaviour


def condition_name(literals: frozenset[int], task: GroundTask) -> str:
    """A condition's readable name: its sorted literals joined by `` & `` (``true`` when empty)."""
    return " & ".join(task.names(literals)) or "true"


def build_pytrees(tree: Node, task: GroundTask, world: SymbolicWorld) -> py_trees.behaviour.Behaviour:
    """A live py_trees tree whose behaviours read and change ``world`` (see the module docstring)."""
    condition_class, action_class = _behaviour_classes()
    import py_trees

    def build(node: Node) -> py_trees.behaviour.Behaviour:
        if isinstance(node, Condition):
            return condition_class(condition_name(node.literals, task), node.literals, world)
        if isinstance(node, Action):
            return action_class(task.actions[node.action].name, node.action, world)
        children = [build(child) for child in node.children]
        if isinstance(node, Sequence):
            return py_trees.composites.Sequence("Sequence", memory=False, children=children)
        return py_trees.composites.Selector("Fallback", memory=False, children=children)

    return build(tree)


def tick_to_goal(root: py_trees.behaviour.Behaviour, max_ticks: int = 10_000) -> py_trees.common.Status:
    """Tick ``root`` until it stops RUNNING (or ``max_ticks`` ticks); the final status."""
    _require_py_trees()
    import py_trees

    for _ in range(max_ticks):
        root.tick_once()
        if root.status != py_trees.common.Status.RUNNING:
            break
    return root.status


# ------------------------------------------------------------------------------------ standalone module

_MODULE_HEAD = '''\
"""A behavior tree planned by hbtp, rebuilt with py_trees (py-trees>=2.2).
{about}

Run it (``python {filename}``) to tick the tree from the initial state in a symbolic simulator:
conditions check literals of ``World.state``; an action whose preconditions hold applies its effects
and returns RUNNING, and the next tick restarts at the root (Selector/Sequence without memory).
To drive a robot, replace ``Act.update`` and ``Check.update`` with your skills and sensing.
"""

from __future__ import annotations

import logging

import py_trees
from py_trees.common import Status
from py_trees.composites import Selector, Sequence

logger = logging.getLogger(__name__)

INITIAL_STATE: frozenset[str] = {initial}

# action -> (preconditions, add effects, delete effects)
ACTIONS: dict[str, tuple[frozenset[str], frozenset[str], frozenset[str]]] = {{
{actions}}}


class World:
    """The symbolic state shared by the behaviours, and the actions applied so far."""

    def __init__(self, state: frozenset[str] = INITIAL_STATE) -> None:
        self.state = frozenset(state)
        self.executed: list[str] = []


def holds(literals: frozenset[str], state: frozenset[str]) -> bool:
    """Whether every literal holds: ``P(a)`` when it is in the state, ``~P(a)`` when ``P(a)`` is not."""
    return all(lit[1:] not in state if lit.startswith("~") else lit in state for lit in literals)


class Check(py_trees.behaviour.Behaviour):
    """SUCCESS iff every literal holds, FAILURE otherwise."""

    def __init__(self, literals: tuple[str, ...], world: World) -> None:
        super().__init__(name=" & ".join(literals) or "true")
        self.literals = frozenset(literals)
        self.world = world

    def update(self) -> Status:
        return Status.SUCCESS if holds(self.literals, self.world.state) else Status.FAILURE


class Act(py_trees.behaviour.Behaviour):
    """Applies the action and returns RUNNING when its preconditions hold, FAILURE otherwise."""

    def __init__(self, action: str, world: World) -> None:
        super().__init__(name=action)
        self.world = world

    def update(self) -> Status:
        pre, add, delete = ACTIONS[self.name]
        if not holds(pre, self.world.state):
            return Status.FAILURE
        self.world.state = (self.world.state - delete) | add
        self.world.executed.append(self.name)
        logger.info("%s", self.name)
        return Status.RUNNING


def create_root(world: World) -> py_trees.behaviour.Behaviour:
    """The planned tree, its behaviours bound to ``world``."""
    return {root}


def run(max_ticks: int = 10_000) -> tuple[Status, World]:
    """Tick the tree from the initial state until it stops RUNNING; the final status and world."""
    world = World()
    root = create_root(world)
    for _ in range(max_ticks):
        root.tick_once()
        if root.status != Status.RUNNING:
            break
    return root.status, world


if __name__ == "__main__":
    logging.basicConfig(level=logging.INFO, format="%(message)s")
    final, end = run()
    logger.info("%s after %d action(s)", final.value, len(end.executed))
'''


def _string(text: str) -> str:
    """A Python string literal (double quoted, escaped)."""
    return json.dumps(text, ensure_ascii=False)


def _collection(opening: str, items: list[str], closing: str, indent: str, around: int = 2) -> str:
    """``opening item, item closing`` on one line when it fits (with ``around`` more characters on the
    line) in 120 columns after ``indent``, else one item a line."""
    one_line = opening + ", ".join(items) + closing
    if len(indent) + len(one_line) + around <= 120:
        return one_line
    inner = indent + "    "
    return opening + "\n" + "".join(f"{inner}{item},\n" for item in items) + indent + closing


def _frozenset(names: list[str], indent: str) -> str:
    if not names:
        return "frozenset()"
    return _collection("frozenset({", [_string(n) for n in names], "})", indent)


def _positive(task: GroundTask, ids: frozenset[int]) -> frozenset[int]:
    """``ids`` without negated twins: the module's state lists what is true (``~P`` holds by absence)."""
    return frozenset(i for i in ids if not task.atoms[i].negated)


def write_pytrees_module(tree: Node, task: GroundTask, *, scenario: str = "", goal: str = "") -> str:
    """A standalone Python module (needs only py_trees) that rebuilds ``tree`` and can tick it.

    It holds the initial state and the pre/add/delete lists of the actions the tree uses, so
    ``python module.py`` runs the tree in a symbolic simulator; ``create_root(World())`` gives the
    py_trees root. Deterministic: same tree, same text.
    """

    def expression(node: Node, indent: str) -> str:
        if isinstance(node, Condition):
            names = [_string(n) for n in task.names(node.literals)]
            literals = _collection("(", names, ",)" if len(names) == 1 else ")", indent, len("Check(, world),"))
            return f"Check({literals}, world)"
        if isinstance(node, Action):
            return f"Act({_string(task.actions[node.action].name)}, world)"
        inner = indent + "    "
        kind = "Sequence" if isinstance(node, Sequence) else "Selector"
        label = "Sequence" if isinstance(node, Sequence) else "Fallback"
        children = "".join(f"{inner}    {expression(child, inner + '    ')},\n" for child in node.children)
        return f'{kind}(\n{inner}"{label}",\n{inner}memory=False,\n{inner}children=[\n{children}{inner}],\n{indent})'

    used = sorted({node.action for node in walk(tree) if isinstance(node, Action)})
    action_lines = []
    for index in used:
        action = task.actions[index]
        pre, add, delete = action.pre, _positive(task, action.add), _positive(task, action.delete)
        parts = [_frozenset(task.names(part), "        ") for part in (pre, add, delete)]
        key = _string(action.name)
        action_lines.append(f"    {key}: {_collection('(', parts, ')', '    ', len(key) + 3)},\n")
    about = "".join(
        f"\n{label}: {value.replace(chr(92), '/').replace(chr(34) * 3, chr(39) * 3)}"
        for label, value in (("Scenario", scenario), ("Goal", goal))
        if value
    )
    return _MODULE_HEAD.format(
        about=about,
        filename="tree.py",
        initial=_frozenset(task.names(_positive(task, task.initial_state)), ""),
        actions="".join(action_lines),
        root=expression(tree, "    "),
    )
