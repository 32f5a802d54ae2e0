"""Labels that leave out what the check puts back: the steps a taught model must say, and no more.

A taught model's plan is checked before it prunes anything (:mod:`hbtp.llm.checked`): an action
whose preconditions do not hold is preceded by the planner's plan to them. So a label need not
say the steps that plan would add: in RobotHow, ``Grab milk, PutIn milk fridge`` is checked into
``Walk milk, Grab milk, Walk fridge, Open fridge, PutIn milk fridge``. A shorter reply is a faster
one (decoding is most of a taught model's time), and it leaves the model the steps that matter.

:func:`abridged` walks the optimal plan and leaves out an action when

* the check of the next action, from the state before the actions left out just before it, puts
  back exactly those actions and this one (the same plan, in the same order); and
* its objects are named by the next action or by an action kept before it.

The second rule keeps the reply's objects those of the whole plan, so a world that is not
grounded, where a reply is not checked but read as hints (:mod:`hbtp.pipeline.loop`), prunes to a
space that still holds the plan once the predicates of the actions left out are added to the
reply's (an adapter records them: :data:`hbtp.llm.backends.adapters.KEY_FILLED`). The abridged
plan is checked as a reply would be; when the check does not give back the optimal plan, action
for action, the whole plan is the label.
"""

from __future__ import annotations

from collections.abc import Sequence

from hbtp.llm.checked import Simulation
from hbtp.logic.goal import Goal
from hbtp.logic.task import GroundAction, GroundTask


def abridged(task: GroundTask, goal: Goal, plan: Sequence[GroundAction]) -> tuple[GroundAction, ...]:
    """The actions of ``plan`` (an optimal plan to ``goal``) a taught model says (see the module docstring)."""
    before = Simulation(task, goal, None)  # the state before the actions left out since the last kept one
    kept: list[GroundAction] = []
    left: list[GroundAction] = []
    for index, action in enumerate(plan):
        following = plan[index + 1] if index + 1 < len(plan) else None
        named = {o for a in kept for o in a.objects}
        if following is not None and set(action.objects) <= named | set(following.objects):
            trial = before.fork()
            if trial.fill(following) and trial.plan[len(before.plan) :] == [*left, action]:
                left.append(action)
                continue
        if not before.fill(action):
            return tuple(plan)
        before.apply(action)
        kept.append(action)
        left = []
    check = Simulation(task, goal, None)
    check.take([str(a.signature) for a in kept])
    same = [a.index for a in check.plan] == [a.index for a in plan]
    return tuple(kept) if same else tuple(plan)


__all__ = ["abridged"]
