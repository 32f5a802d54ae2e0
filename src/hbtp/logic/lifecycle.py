"""Which action runs between ticks, and when it is halted: the one home of the halt rule.

An action that a tick runs and that has not finished by the end of that tick is *active*. The next
tick either runs it again (it goes on: :attr:`Phase.RUNNING`) or not: it runs another action, or
none because a condition higher in the tree now holds, the branch changed, or the root failed. Then
the active action is *halted*, once. A re-plan that swaps the tree and the end of a run (success,
failure, the tick limit, an interrupt) halt it too (:meth:`ActionLifecycle.halt`). An action that
finishes (its implementation answers success or failure, or it has run its ticks in the symbolic
world) is no longer active and is not halted; when the tree runs it again, it starts again
(:attr:`Phase.START`).

Actions are told apart by their ground action: a tree that runs the same action from another leaf on
the next tick goes on with it. The executor (:func:`hbtp.logic.execution.execute`, with actions that
take several ticks) and the robot runtime (:class:`hbtp.runtime.Runtime`, which calls the user's
start, running and halt callbacks) both step an :class:`ActionLifecycle`.
"""

from __future__ import annotations

import enum
from dataclasses import dataclass

from hbtp.errors import InputError

__all__ = ["ActionLifecycle", "Phase", "Step"]


class Phase(enum.Enum):
    """How a tick calls the action it runs: it starts, or it goes on running."""

    START = "start"
    RUNNING = "running"


@dataclass(frozen=True, slots=True)
class Step:
    """What one tick did to the actions: the action it halted (if any), and how it calls the action
    it runs (``None``: it runs none)."""

    halted: int | None
    phase: Phase | None


class ActionLifecycle:
    """The active action (see the module docstring), the ticks it has run, the halts so far.

    ``action_ticks`` is how many ticks an action takes in the symbolic world (the executor applies
    its effects after the last one); the robot runtime's actions say themselves when they finish.
    """

    def __init__(self, action_ticks: int = 1) -> None:
        if not isinstance(action_ticks, int) or isinstance(action_ticks, bool) or action_ticks < 1:
            raise InputError(f"an action takes a whole number of ticks, at least 1, not {action_ticks!r}")
        self.action_ticks = action_ticks
        #: The action running between ticks (``None``: none).
        self.active: int | None = None
        #: Ticks the active action has run, this tick included.
        self.ticks = 0
        #: The actions halted, in order.
        self.halted: list[int] = []

    @property
    def halts(self) -> int:
        return len(self.halted)

    @property
    def done(self) -> bool:
        """The active action has run its ``action_ticks`` ticks."""
        return self.active is not None and self.ticks >= self.action_ticks

    def step(self, action: int | None) -> Step:
        """A tick runs ``action`` (``None``: the tick runs none): the active action, if another,
        is halted; ``action`` starts or goes on."""
        halted = self.halt() if self.active is not None and action != self.active else None
        if action is None:
            return Step(halted, None)
        phase = Phase.RUNNING if action == self.active else Phase.START
        self.ticks = self.ticks + 1 if phase is Phase.RUNNING else 1
        self.active = action
        return Step(halted, phase)

    def finish(self) -> None:
        """The active action finished: it is no longer active, and is not halted."""
        self.active, self.ticks = None, 0

    def halt(self) -> int | None:
        """Halt the active action (a swapped tree, the end of the run): the action, or ``None`` when
        none is active."""
        halted = self.active
        if halted is not None:
            self.halted.append(halted)
        self.active, self.ticks = None, 0
        return halted
