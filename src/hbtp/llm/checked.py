"""A taught model's plan, made to run with the action model before it prunes anything.

A taught model answers a goal with a plan (:func:`hbtp.llm.prompt.taught_prompt`). A 270M model
knows the steps that matter (fetch the knife, cut the pancake) better than every precondition on
the way (the microwave is unplugged and closed in s0). hbtp knows which actions apply in which
state, so the reply is simulated from s0, action by action:

* an action that applies is kept, unless everything it adds already holds (it would change
  nothing the plan needs: a second ``PlugIn`` of the same appliance), which is skipped;
* an action whose preconditions do not all hold is preceded by a plan to them: the planner's
  (OBTEA with the landmark heuristic, from the state the plan so far leads to, bounded by
  :data:`GAP_EXPANSIONS` conditions), to the missing ones or, when that plan would undo another,
  to all of them; when it finds none, the reply is cut there;
* the plan ends as soon as the goal holds (what follows is not needed);
* a plan that ends before the goal holds is continued: the model is asked again, the prompt being
  the question and the plan so far, and its grammar (:func:`hbtp.llm.constrain.constraint_of` with ``first``)
  offering as the next action only those that apply.

The model still proposes every step that is not a precondition; the action model fills gaps and
takes away what cannot run. Bounded: at most :data:`MAX_STEPS` calls, :data:`MAX_GAPS` gaps and
:data:`MAX_ACTIONS` actions; when a bound is reached the plan so far is the answer (its
predicates and objects still prune the space; the loop's feedback rounds and fallback do the rest).
The hints are the plan's predicates and objects, so when the plan reaches the goal the pruned space
holds a plan that does, and the round's search (optimal in that space) finds a tree.
"""

from __future__ import annotations

from collections.abc import Callable, Sequence
from dataclasses import dataclass, replace

from hbtp.deadline import Deadline, expired
from hbtp.errors import InputError
from hbtp.llm.backend import Reply, Request
from hbtp.llm.constrain import Bounds, constraint_of
from hbtp.llm.parse import parse_reply
from hbtp.logic.atoms import Atom
from hbtp.logic.goal import Goal
from hbtp.logic.task import GroundAction, GroundTask, State
from hbtp.planning.heuristic_names import HeuristicName
from hbtp.planning.limits import Limits
from hbtp.planning.planners import plan

#: The most model calls one checked answer makes.
MAX_STEPS = 3
#: The most actions a checked answer keeps (the longest plan a reply may have).
MAX_ACTIONS = 24
#: The most gaps filled in one answer, and the conditions one gap's search may explore.
MAX_GAPS = 6
GAP_EXPANSIONS = 2_000


@dataclass(frozen=True)
class CheckedAnswer:
    """The plan kept (it runs from s0, in the datasets' spelling), whether it reaches the goal, and
    every call made for it (its request and reply)."""

    plan: tuple[str, ...]
    reached: bool
    calls: tuple[tuple[Request, Reply], ...]

    @property
    def text(self) -> str:
        """The plan as a taught reply (what the model would have said had it been right at once)."""
        return " " + ", ".join(self.plan) + "\n\n"

    @property
    def seconds(self) -> float:
        return sum(reply.seconds for _, reply in self.calls)


def _names_of(text: str) -> tuple[str, ...]:
    """The action names of a taught reply (it continues ``Optimal Actions:``), read as the loop reads it."""
    return parse_reply("Optimal Actions:" + text).hints.path


class Simulation:
    """The plan so far and the state it leads to (a taught reply being checked, or a label being
    abridged: :mod:`hbtp.train.abridge`)."""

    def __init__(self, task: GroundTask, goal: Goal, deadline: Deadline | None) -> None:
        self.task, self.goal, self.deadline = task, goal, deadline
        self.state: State = task.initial_state
        self.plan: list[GroundAction] = []
        self.gaps = 0

    @property
    def reached(self) -> bool:
        return self.goal.holds(self.state)

    def fork(self) -> Simulation:
        """A copy that goes on alone (the plan so far shared, not its future)."""
        other = Simulation(self.task, self.goal, self.deadline)
        other.state, other.plan, other.gaps = self.state, list(self.plan), self.gaps
        return other

    def applicable(self) -> list[Atom]:
        return [a.signature for a in self.task.actions if a.applicable(self.state)]

    def action(self, name: str) -> GroundAction | None:
        try:
            return self.task.action(name)
        except InputError:  # not an action of the world (a reply read without the grammar)
            return None

    def take(self, names: Sequence[str]) -> None:
        """Apply ``names`` in order, each after a plan to its preconditions when they do not hold,
        until the goal holds, the plan is full, or a gap cannot be filled."""
        for name in names:
            action = self.action(name)
            if action is not None and action.add and action.add <= self.state:
                continue
            if action is None or not self.fill(action):
                return
            self.apply(action)
            if self.reached or len(self.plan) >= MAX_ACTIONS:
                return

    def apply(self, action: GroundAction) -> None:
        self.state = action.progress(self.state)
        self.plan.append(action)

    def fill(self, action: GroundAction) -> bool:
        """Make ``action`` apply: a plan to its missing preconditions, applied; when that plan undoes
        another of them (puts down what the action needs held, to free a hand), a plan to all of
        them instead. ``False`` when neither is found within the bounds."""
        missing = action.pre - self.state
        if not missing:
            return True
        if self.gaps >= MAX_GAPS or expired(self.deadline):
            return False
        self.gaps += 1
        for wanted in (missing, action.pre):
            gap = self.gap(wanted)
            if gap is not None and len(self.plan) + len(gap) < MAX_ACTIONS:
                state = self.state
                for step in gap:
                    state = step.progress(state)
                if action.applicable(state):
                    for step in gap:
                        self.apply(step)
                    return True
        return False

    def gap(self, wanted: frozenset[int]) -> list[GroundAction] | None:
        """An optimal plan from the current state to ``wanted`` (bounded), or ``None``."""
        here = self.task.from_state(self.state)
        goal = here.resolve_goal([self.task.atoms[atom] for atom in sorted(wanted)])
        limits = Limits(max_expansions=GAP_EXPANSIONS, deadline=self.deadline)
        found = plan(here, goal, "obtea", heuristic=HeuristicName.LM, limits=limits)
        return [self.task.actions[index] for index in found.solution] if found.solved else None


def checked_answer(
    complete: Callable[[Request], Reply],
    request: Request,
    task: GroundTask,
    goal: Goal,
    deadline: Deadline | None = None,
) -> CheckedAnswer:
    """Ask ``request`` (a taught model's question about ``goal``, resolved in ``task``) in checked
    steps (see the module docstring), by ``deadline`` (no call and no gap search starts after it);
    ``complete`` is the backend's call (it raises :class:`hbtp.errors.BackendError`, which ends the
    answer: the caller sees it)."""
    simulation = Simulation(task, goal, deadline)
    calls: list[tuple[Request, Reply]] = []
    step = request  # the first question as it is: the model's own first action (a gap may precede it)
    while not simulation.reached and len(calls) < MAX_STEPS and len(simulation.plan) < MAX_ACTIONS:
        if calls and expired(deadline):
            break
        reply = complete(step)
        calls.append((step, reply))
        before = len(simulation.plan)
        simulation.take(_names_of(reply.text))
        masked = step is not request
        if len(simulation.plan) == before and masked:  # not even an action that applies was kept
            break
        allowed = simulation.applicable()
        if not allowed:
            break
        so_far = request.spelling.plan(a.signature for a in simulation.plan) + "," if simulation.plan else ""
        step = replace(
            request,
            completion_prompt=request.completion_prompt + so_far,
            constraint=constraint_of(
                task,
                Bounds(actions=MAX_ACTIONS - len(simulation.plan)),
                path_only=True,
                first=allowed,
                spelling=request.spelling,
            ),
            attempt=len(calls),
        )
    names = tuple(action.signature.underscored for action in simulation.plan)
    return CheckedAnswer(names, simulation.reached, tuple(calls))


__all__ = ["GAP_EXPANSIONS", "MAX_ACTIONS", "MAX_GAPS", "MAX_STEPS", "CheckedAnswer", "Simulation", "checked_answer"]
