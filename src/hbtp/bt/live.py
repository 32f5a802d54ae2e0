"""How a symbolic run unfolds in time: actions that take several ticks, and a tick rate.

:class:`LiveOptions` is one value for :func:`hbtp.bt.simulate.simulate`,
:meth:`hbtp.bt.btcpp_engine.BtcppEngine.run` and :func:`hbtp.replanning.run_replanning` (``hbtp run
--action-ticks N --tick-hz F``):

* ``action_ticks``: each action is RUNNING for that many ticks before the executor applies its
  effects; an action the tree stops ticking before then is halted and has no effect
  (:mod:`hbtp.logic.lifecycle`, counted in :attr:`hbtp.logic.execution.Run.halts`);
* ``rate``: at most that many ticks per second (:class:`hbtp.pacing.TickRate`; default: as fast as
  possible).

Who watches a BehaviorTree.CPP run (Groot2, BT.CPP's log) is another value,
:class:`hbtp.bt.btcpp_engine.Watch`.
"""

from __future__ import annotations

from dataclasses import dataclass

from hbtp.logic.execution import NodeStatus, Policy
from hbtp.logic.lifecycle import ActionLifecycle
from hbtp.logic.task import State
from hbtp.pacing import TickRate

__all__ = ["LiveOptions", "paced"]


@dataclass(frozen=True)
class LiveOptions:
    """Ticks per action and the tick rate (see the module docstring)."""

    action_ticks: int = 1
    rate: TickRate | None = None

    def __post_init__(self) -> None:
        ActionLifecycle(self.action_ticks)  # checks the number

    def lifecycle(self) -> ActionLifecycle:
        """A fresh :class:`ActionLifecycle` for one run."""
        return ActionLifecycle(self.action_ticks)


def paced(policy: Policy, rate: TickRate | None) -> Policy:
    """``policy``, ticked at most ``rate`` times a second (itself when ``rate`` is ``None``)."""
    if rate is None:
        return policy
    pacer = rate.pacer()

    def tick(state: State) -> tuple[NodeStatus, int | None]:
        pacer.wait()
        return policy(state)

    return tick
