"""STRIPS core: atoms, grounded actions, tasks, progression and regression. No I/O."""

from hbtp.logic.atoms import Atom, parse_atom, parse_conjunction
from hbtp.logic.task import Condition, Goal, GroundAction, GroundTask, State

__all__ = [
    "Atom",
    "Condition",
    "Goal",
    "GroundAction",
    "GroundTask",
    "State",
    "parse_atom",
    "parse_conjunction",
]
