"""Run a planned tree in a world that can surprise it, and re-plan when the tree has no answer.

A planned tree acts from every state that satisfies one of its conditions. A disturbance can leave
the world in a state that satisfies none (the tree's root fails), and on a robot an action can keep
failing. :class:`Replanner` is a policy (:data:`hbtp.logic.execution.Policy`) that ticks the current
tree and, when it fails, plans again from the state it is ticked in (LLM-free: OBTEA with the
landmark heuristic by default), swaps the new tree in and ticks that. It is bounded: at most
``max_replans`` re-plans and ``budget_s`` seconds of re-planning per run; then, or when the goal is
unsolvable from the observed state, the policy fails for good with the reason in
:attr:`Replanner.gave_up`. The tree is ticked by the engine of :attr:`ReplanOptions.engine`
(:class:`hbtp.bt.engines.Engine`: hbtp's own, py_trees through its BT.CPP-XML reader, or
BehaviorTree.CPP); a re-plan builds the new tree in that engine.

Two ways to run it:

* in the symbolic world (:func:`run_replanning`): the one executor applies each action's effects and
  an optional disturbance changes the state before ticks; the robustness benchmark uses this;
* on a robot (:class:`Runtime`): the user gives an implementation per action (a callable returning
  ``"success"``, ``"failure"`` or ``"running"``, or a :class:`NodeStatus`) and an observer returning
  the literals that hold now. Each tick observes, ticks the tree, and calls the running action; an
  action that fails ``max_failures`` times in a row is left out of the next plan. An action that
  raises or answers garbage counts as a failure (logged); an observer that raises or answers
  literals that cannot be read ends the run with :class:`RuntimeFailure`, as does an action or an
  observer that does not return within ``tick_timeout_s`` (a positive, finite number).

Re-planning from a state uses the proved mutexes only when the state satisfies them (a state that
breaks an invariant, which no action can cause, is planned from without mutex pruning).
"""

from __future__ import annotations

import dataclasses
import json
import logging
import math
import statistics
import threading
import time
from collections.abc import Callable, Iterable, Mapping, Sequence
from dataclasses import dataclass, field
from typing import Any

from hbtp.bt.build import tree_of
from hbtp.bt.disturb import seeded_disturbances, summarise_runs
from hbtp.bt.engines import Engine
from hbtp.bt.jsonio import node_to_dict
from hbtp.bt.nodes import Node
from hbtp.bt.simulate import DEFAULT_MAX_TICKS, simulate, trace_to_jsonl
from hbtp.domains.scenarios import Scenario
from hbtp.errors import HbtpError, InputError
from hbtp.logic.atoms import declared_action, parse_atom
from hbtp.logic.execution import Disturbance, NodeStatus, Policy, Run, Trace, TraceStep, execute
from hbtp.logic.task import Goal, GoalIds, GroundAction, GroundTask, State
from hbtp.planning.heuristics import DEFAULT_HEURISTIC, HeuristicName
from hbtp.planning.limits import Limits
from hbtp.planning.planners import confirmed_search, planner_config
from hbtp.planning.result import PlanResult, Status

log = logging.getLogger(__name__)

__all__ = [
    "Replan",
    "ReplanOptions",
    "Replanner",
    "ReplanningRun",
    "Runtime",
    "RuntimeFailure",
    "replanning_runs",
    "replanning_stats",
    "replanning_summary",
    "replanning_trace_jsonl",
    "run_replanning",
]


#: How :attr:`Replanner.gave_up` starts when no tree reaches the goal from the state.
UNSOLVABLE_FROM_STATE = "no tree reaches the goal from the observed state"


class RuntimeFailure(HbtpError):
    """The runtime had to stop: a callback hung, or the observer named what the domain does not have."""


@dataclass(frozen=True)
class ReplanOptions:
    """How to re-plan: the planner and heuristic, the kind of tree, the bounds of one run, and the
    engine that ticks the trees."""

    max_replans: int = 10
    #: Seconds of re-planning in one run, all re-plans together.
    budget_s: float = 30.0
    planner: str = "obtea"
    heuristic: HeuristicName = DEFAULT_HEURISTIC
    tree: str = "full"
    engine: Engine = Engine.HBTP

    def __post_init__(self) -> None:
        if not isinstance(self.engine, Engine):
            raise InputError(f"the engine must be an Engine ({', '.join(e.name for e in Engine)}), not {self.engine!r}")
        self.engine.require()
        if self.max_replans < 0:
            raise InputError(f"max_replans must not be negative, not {self.max_replans}")
        if not self.budget_s > 0:
            raise InputError(f"the re-planning budget must be a positive number of seconds, not {self.budget_s}")
        if self.tree not in ("full", "path"):
            raise InputError(f"unknown tree kind {self.tree!r}; choose full or path")
        planner_config(self.planner, heuristic=self.heuristic)  # checks both names


@dataclass(frozen=True)
class Replan:
    """One re-plan: at which tick, why, how long it took and what it found (``tree``: the tree
    swapped in, ``None`` when the re-plan found none)."""

    tick: int
    reason: str
    seconds: float
    status: str
    cost: int | None = None
    message: str = ""
    tree: Node | None = field(default=None, compare=False, repr=False)

    def to_dict(self) -> dict[str, Any]:
        """The re-plan without its tree (:meth:`trace_record` has it)."""
        return {f.name: getattr(self, f.name) for f in dataclasses.fields(self) if f.name != "tree"}

    def trace_record(self, task: GroundTask) -> dict[str, Any]:
        """The re-plan as a trace line has it: tick, reason, seconds, status, cost and the new tree's
        root in the shape of the ``root`` of an hbtp tree file (:func:`hbtp.bt.jsonio.node_to_dict`);
        a re-plan that found no tree has its ``message`` instead."""
        record: dict[str, Any] = {
            "tick": self.tick, "reason": self.reason, "seconds": self.seconds, "status": self.status,
            "cost": self.cost,
        }  # fmt: skip
        if self.tree is not None:
            record["tree"] = node_to_dict(self.tree, task)
        elif self.message:
            record["message"] = self.message
        return record


class Replanner:
    """A policy: the current tree's tick, or a new tree planned from the state when it fails."""

    def __init__(
        self, scenario: Scenario, goal: Goal, tree: Node | None, options: ReplanOptions = ReplanOptions()
    ) -> None:
        self.task = scenario.task
        self.mutexes = scenario.mutexes.proved_only()
        self.goal = goal
        self.options = options
        #: The current tree, ticked by ``options.engine`` (``None``: no tree yet, the first tick re-plans).
        self.tree = tree
        self.policy: Policy = _no_tree if tree is None else options.engine.policy(tree, self.task)
        self.replans: list[Replan] = []
        self.spent = 0.0
        self.ticks = 0
        self.excluded: set[int] = set()
        #: Why the policy stopped re-planning (``None`` while it may still re-plan).
        self.gave_up: str | None = None
        #: Whether it stopped because a re-plan proved the goal unreachable from the state.
        self.unsolvable = False

    def __call__(self, state: State) -> tuple[NodeStatus, int | None]:
        self.ticks += 1
        status, action = self.policy(state)
        if status is not NodeStatus.FAILURE or self.gave_up is not None:
            return status, action
        if not self.replan(state, "no condition of the tree holds"):
            return NodeStatus.FAILURE, None
        return self.policy(state)

    def replan(self, state: State, reason: str, without: Iterable[int] = ()) -> bool:
        """Plan from ``state`` (leaving out the actions ``without`` from now on) and use the new tree;
        ``False`` (and :attr:`gave_up` set) when the bounds are reached or no tree reaches the goal."""
        self.excluded.update(without)
        options = self.options
        if len(self.replans) >= options.max_replans:
            return self._give_up(f"gave up after {len(self.replans)} re-plan(s) (max_replans)")
        left = options.budget_s - self.spent
        if left <= 0:
            return self._give_up(f"the re-planning budget of {options.budget_s:g} s is spent")
        started = time.perf_counter()
        result = self._plan(state, left)
        seconds = time.perf_counter() - started
        self.spent += seconds
        log.info("tick %d: re-planned (%s) in %.1f ms: %s", self.ticks, reason, seconds * 1000, result.status.value)
        tree = tree_of(result, options.tree) if result.solved else None
        self.replans.append(
            Replan(self.ticks, reason, round(seconds, 6), result.status.value, result.cost, result.message, tree)
        )
        if result.status is Status.UNSOLVABLE:
            self.unsolvable = True
            return self._give_up(f"{UNSOLVABLE_FROM_STATE}: {result.message}")
        if tree is None:
            return self._give_up(f"re-planning found no tree ({result.status.value}: {result.message})")
        self.tree = tree
        self.policy = options.engine.policy(tree, self.task)
        return True

    def _plan(self, state: State, seconds: float) -> PlanResult:
        world = self.task.from_state(state)
        goal = world.resolve_goal(self.goal)
        actions: Sequence[GroundAction] = world.actions
        if self.excluded:
            actions = [a for a in world.actions if a.index not in self.excluded]
        mutexes = self.mutexes if self.mutexes.conflict(frozenset(state)) is None else None
        config = planner_config(self.options.planner, heuristic=self.options.heuristic)
        return confirmed_search(world, goal, actions, config, mutexes=mutexes, limits=Limits(time_s=seconds))

    def _give_up(self, reason: str) -> bool:
        self.gave_up = reason  # reported by the caller (the run's result, the command's output)
        log.info("%s", reason)
        return False


@dataclass(frozen=True)
class ReplanningRun:
    """A run with re-planning: the executor's run, the re-plans, and why it stopped re-planning."""

    run: Run
    replans: tuple[Replan, ...]
    gave_up: str | None = None
    #: The goal became unreachable from the run's state (proved by the last re-plan).
    unsolvable: bool = False

    @property
    def replanning_s(self) -> float:
        return sum(r.seconds for r in self.replans)

    def reached(self, goal: GoalIds) -> bool:
        return self.run.reached(goal)


def replanning_trace_jsonl(result: ReplanningRun, task: GroundTask, *, run_index: int | None = None) -> str:
    """The run's trace as JSON lines (:func:`hbtp.bt.simulate.trace_to_jsonl`: one line per tick,
    then the ``end`` line), with a line ``{"replan": {...}}`` (:meth:`Replan.trace_record`) before
    the tick of each re-plan, which is the first tick that uses the tree it found (a re-plan that
    found none has no ``tree``), and the reason the run gave up (``"gave_up"``), if it did, in the
    ``end`` line. ``run_index`` adds ``"run"`` to every line."""
    lines = trace_to_jsonl(result.run, task, run_index=run_index).splitlines()
    extra = {} if run_index is None else {"run": run_index}
    replans: dict[int, list[str]] = {}
    for replan in result.replans:
        line = json.dumps({**extra, "replan": replan.trace_record(task)}, ensure_ascii=False)
        replans.setdefault(replan.tick, []).append(line)
    out: list[str] = []
    for step, line in zip(result.run.trace, lines, strict=False):
        out += replans.pop(step.tick, [])
        out.append(line)
    out += [line for later in replans.values() for line in later]  # after the last traced tick
    end = json.loads(lines[-1])
    if result.gave_up is not None:
        end["gave_up"] = result.gave_up
    out.append(json.dumps(end, ensure_ascii=False))
    return "\n".join(out) + "\n"


def run_replanning(
    scenario: Scenario,
    goal: Goal,
    tree: Node,
    *,
    max_ticks: int,
    disturbance: Disturbance | None = None,
    options: ReplanOptions = ReplanOptions(),
    state: State | None = None,
    trace: bool = False,
) -> ReplanningRun:
    """Run ``tree`` in the symbolic world from ``state`` (default s0), re-planning when it fails."""
    policy = Replanner(scenario, goal, tree, options)
    tracer = Trace(scenario.task) if trace else None
    run = execute(
        policy,
        scenario.task,
        state,
        max_ticks=max_ticks,
        disturbance=disturbance,
        observers=(tracer,) if tracer else (),
    )
    if tracer is not None:
        run = dataclasses.replace(run, trace=tuple(tracer.steps))
    return ReplanningRun(run, tuple(policy.replans), policy.gave_up, policy.unsolvable)


# ============================================================ on a robot
#: An action's implementation: called once per tick while the action runs.
ActionCallback = Callable[..., Any]
#: Returns the literals that hold now (``IsIn(milk,fridge)`` or ``IsIn_milk_fridge``).
StateObserver = Callable[[], Iterable[str]]

_STATUS = {"success": NodeStatus.SUCCESS, "failure": NodeStatus.FAILURE, "running": NodeStatus.RUNNING}


@dataclass
class RuntimeReport:
    """What a :class:`Runtime` run did: how it ended, its ticks, the actions called, the re-plans."""

    status: NodeStatus
    reason: str
    ticks: int
    called: list[str] = field(default_factory=list)
    failures: int = 0
    replans: tuple[Replan, ...] = ()
    trace: list[TraceStep] = field(default_factory=list)

    @property
    def succeeded(self) -> bool:
        return self.status is NodeStatus.SUCCESS

    def to_dict(self) -> dict[str, Any]:
        return {
            "status": self.status.value,
            "reason": self.reason,
            "ticks": self.ticks,
            "called": self.called,
            "failures": self.failures,
            "replans": [r.to_dict() for r in self.replans],
            "trace": [s.to_dict() for s in self.trace],
        }


class Runtime:
    """Ticks a planned tree against the user's actions and observer, re-planning when needed.

    ``actions`` maps an action name (``RightGrab(apple)``) or an action predicate (``RightGrab``,
    called with the objects as arguments) to its implementation. ``tree`` defaults to a tree
    planned now from the observed state.
    """

    def __init__(
        self,
        scenario: Scenario,
        goal: Goal | str,
        actions: Mapping[str, ActionCallback],
        observe: StateObserver,
        *,
        tree: Node | None = None,
        options: ReplanOptions = ReplanOptions(),
        max_failures: int = 3,
        tick_timeout_s: float = 10.0,
    ) -> None:
        if not isinstance(max_failures, int) or isinstance(max_failures, bool) or max_failures < 1:
            raise InputError(f"max_failures must be a whole number of at least 1, not {max_failures!r}")
        if not isinstance(tick_timeout_s, (int, float)) or not (0 < tick_timeout_s < math.inf):
            raise InputError(f"tick_timeout_s must be a positive, finite number of seconds, not {tick_timeout_s!r}")
        scenario, self.goal = scenario.resolve_goal(goal)
        task = scenario.task
        self.task = task
        self.callbacks = _callbacks(task, actions)
        self.observe = observe
        self.max_failures = max_failures
        self.tick_timeout_s = tick_timeout_s
        self.scenario = scenario
        self.options = options
        self.tree = tree

    def run(self, max_ticks: int = 1000) -> RuntimeReport:
        """Tick until the goal holds, the tree fails for good, or ``max_ticks`` ticks."""
        if not isinstance(max_ticks, int) or isinstance(max_ticks, bool) or max_ticks < 1:
            raise InputError(f"max_ticks must be a whole number of at least 1, not {max_ticks!r}")
        state = self._observed()
        replanner = Replanner(self.scenario, self.goal, self.tree, self.options)
        if self.tree is None and not replanner.replan(state, "the first plan, from the observed state"):
            return RuntimeReport(NodeStatus.FAILURE, replanner.gave_up or "", 0, replans=tuple(replanner.replans))
        report = RuntimeReport(NodeStatus.RUNNING, f"{max_ticks} ticks without reaching the goal", 0)
        failures: dict[int, int] = {}
        for tick in range(1, max_ticks + 1):
            state = state if tick == 1 else self._observed()
            status, action = replanner(state)
            report.ticks = tick
            report.trace.append(TraceStep(tick, tuple(self.task.names(state)), status, self._name(action), None))
            if status is not NodeStatus.RUNNING:
                report.status = status
                report.reason = "the goal holds" if status is NodeStatus.SUCCESS else (replanner.gave_up or "")
                break
            assert action is not None
            report.called.append(self.task.actions[action].name)
            outcome = self._call(action)
            if outcome is NodeStatus.FAILURE:
                report.failures += 1
                failures[action] = failures.get(action, 0) + 1
                if failures[action] >= self.max_failures:
                    reason = f"{self.task.actions[action].name} failed {failures[action]} times in a row"
                    failures[action] = 0
                    if not replanner.replan(state, reason, without=(action,)):
                        report.status, report.reason = NodeStatus.FAILURE, replanner.gave_up or reason
                        break
            else:
                failures[action] = 0
        report.replans = tuple(replanner.replans)
        return report

    def _name(self, action: int | None) -> str | None:
        return None if action is None else self.task.actions[action].name

    def _observed(self) -> State:
        def observe() -> list[str]:  # in the worker: the literals as plain text
            return [_text(literal) for literal in self.observe()]

        answer = _bounded(observe, (), self.tick_timeout_s, "the state observer")
        if isinstance(answer, Exception):  # the user's code: any failure ends the run with its message
            raise RuntimeFailure(f"the state observer failed: {type(answer).__name__}: {_shown(answer)}") from answer
        ids: set[int] = set()
        unknown: list[str] = []
        for literal in answer:
            try:
                ids.add(self.task.atom_id(literal))
            except InputError:
                unknown.append(literal)
        if unknown:
            raise RuntimeFailure(
                f"the state observer returned literal(s) the domain does not have: {', '.join(unknown[:5])}"
            )
        return self.task.complete(ids)

    def _call(self, action: int) -> NodeStatus:
        """Call the action's implementation within ``tick_timeout_s``; anything but success or
        running counts as a failure."""
        ground = self.task.actions[action]
        callback, args = self.callbacks[action]
        answer: NodeStatus | str | Exception = _bounded(
            lambda: _status(callback(*args)), (), self.tick_timeout_s, f"action {ground.name}"
        )
        if isinstance(answer, Exception):  # a failure of the action, logged
            log.warning("action %s raised %s: counted as a failure", ground.name, _shown(answer))
            return NodeStatus.FAILURE
        if isinstance(answer, str):
            log.warning("action %s answered %s: counted as a failure", ground.name, answer)
            return NodeStatus.FAILURE
        return answer


def _bounded(function: Callable[..., Any], args: tuple[Any, ...], timeout: float, what: str) -> Any:
    """``function(*args)`` in a worker thread, waited for ``timeout`` seconds: its value, or the
    exception it raised; :class:`RuntimeFailure` when it has not returned by then (the thread is
    left to finish on its own: Python cannot stop it)."""
    box: list[Any] = []

    def target() -> None:
        try:
            box.append(function(*args))
        except Exception as error:  # the user's code
            box.append(error)

    worker = threading.Thread(target=target, name=f"hbtp-{what}", daemon=True)
    worker.start()
    worker.join(timeout)
    if worker.is_alive() or not box:
        raise RuntimeFailure(f"{what} did not return within {timeout:g} s")
    return box[0]


def _text(literal: Any) -> str:
    """An observed literal as text (a ``str`` subclass read as the plain string it holds)."""
    return str.__str__(literal) if isinstance(literal, str) else str(literal)


def _shown(value: Any) -> str:
    """``repr(value)`` for a message, or its type when even that fails (the user's objects)."""
    try:
        text = repr(value)
    except Exception:
        return f"<{type(value).__name__}>"
    return text if len(text) <= 200 else text[:200] + "..."


def _status(answer: Any) -> NodeStatus | str:
    """An action's answer as a status, or the answer shown (:func:`_shown`) when it is none."""
    if isinstance(answer, NodeStatus):
        return answer
    if isinstance(answer, bool):
        return NodeStatus.SUCCESS if answer else NodeStatus.FAILURE
    if isinstance(answer, str):
        status = _STATUS.get(str.__str__(answer).strip().lower())
        if status is not None:
            return status
    return _shown(answer)


def _callbacks(
    task: GroundTask, actions: Mapping[str, ActionCallback]
) -> dict[int, tuple[ActionCallback, tuple[str, ...]]]:
    """Each ground action's implementation: by its name, else by its predicate (with its objects).

    The further ground actions of a PDDL action with a disjunctive precondition (``go-alt2(y,z)``,
    see :func:`hbtp.logic.atoms.alternative_name`) share the implementation of ``go(y,z)`` / ``go``."""
    by_name: dict[tuple[str, tuple[str, ...]], ActionCallback] = {}
    by_predicate: dict[str, ActionCallback] = {}
    predicates = set(task.action_predicates)
    for key, callback in actions.items():
        if not callable(callback):
            raise InputError(f"the implementation of {key!r} is not callable")
        if key in predicates:
            by_predicate[key] = callback
            continue
        try:
            named = task.action(parse_atom(key))
        except InputError as error:
            raise InputError(f"no action or action predicate {key!r} in {task.name}: {error}") from None
        by_name[(named.predicate, named.objects)] = callback
    table: dict[int, tuple[ActionCallback, tuple[str, ...]]] = {}
    for ground in task.actions:
        for predicate in dict.fromkeys((ground.predicate, declared_action(ground.predicate))):
            if (predicate, ground.objects) in by_name:
                table[ground.index] = (by_name[(predicate, ground.objects)], ())
            elif predicate in by_predicate:
                table[ground.index] = (by_predicate[predicate], tuple(ground.objects))
            else:
                continue
            break
    return _complete(task, table)


def _complete(
    task: GroundTask, table: dict[int, tuple[ActionCallback, tuple[str, ...]]]
) -> dict[int, tuple[ActionCallback, tuple[str, ...]]]:
    """Actions without an implementation fail when called (logged once each)."""
    warned: set[str] = set()

    def missing(name: str) -> ActionCallback:
        def fail(*_: str) -> NodeStatus:
            if name not in warned:
                warned.add(name)
                log.warning("no implementation for %s: it fails", name)
            return NodeStatus.FAILURE

        return fail

    for ground in task.actions:
        table.setdefault(ground.index, (missing(ground.name), ()))
    return table


def _no_tree(state: State) -> tuple[NodeStatus, int | None]:
    """The policy before the first tree: it fails (so the first tick re-plans)."""
    return NodeStatus.FAILURE, None


# ============================================================ robustness
def replanning_runs(
    scenario: Scenario,
    goal: Goal,
    tree: Node,
    p: float,
    runs: int,
    seed: int = 0,
    *,
    max_ticks: int = DEFAULT_MAX_TICKS,
    options: ReplanOptions = ReplanOptions(),
    trace: bool = False,
) -> list[ReplanningRun]:
    """``runs`` runs with re-planning under the seeded disturbances of
    :func:`hbtp.bt.disturb.disturbed_runs` (run ``i`` meets the same random numbers as there)."""
    return [
        run_replanning(scenario, goal, tree, max_ticks=max_ticks, disturbance=disturbance, options=options, trace=trace)
        for disturbance in seeded_disturbances(scenario.task, scenario.mutexes, p, runs, seed)
    ]


def replanning_summary(base: Run, results: Sequence[ReplanningRun], goal: Goal) -> dict[str, Any]:
    """:func:`hbtp.bt.disturb.summarise_runs` of the runs, plus the re-plans per run, their times,
    and the runs that ended because the goal could no longer be reached (``unsolvable_runs``)."""
    stats = summarise_runs(base, [r.run for r in results], goal)
    unsolvable = [r for r in results if r.unsolvable]
    reachable = [r for r in results if not r.unsolvable]
    times = [replan.seconds for r in results for replan in r.replans]
    stats.update(
        replans=sum(len(r.replans) for r in results),
        mean_replans=round(statistics.fmean(len(r.replans) for r in results), 6) if results else None,
        median_replan_ms=round(1000 * statistics.median(times), 3) if times else None,
        max_replan_ms=round(1000 * max(times), 3) if times else None,
        unsolvable_runs=len(unsolvable),
        success_rate_reachable=(
            round(sum(r.reached(goal) for r in reachable) / len(reachable), 6) if reachable else None
        ),
    )
    return stats


def replanning_stats(
    scenario: Scenario,
    goal: Goal,
    tree: Node,
    p: float,
    runs: int,
    seed: int = 0,
    max_ticks: int = DEFAULT_MAX_TICKS,
    options: ReplanOptions = ReplanOptions(),
) -> dict[str, Any]:
    """:func:`hbtp.bt.disturb.perturbation_stats` with re-planning (see :func:`replanning_summary`)."""
    base = simulate(tree, scenario.task, max_ticks=max_ticks)
    results = replanning_runs(scenario, goal, tree, p, runs, seed, max_ticks=max_ticks, options=options)
    return {"p": p, "seed": seed, **replanning_summary(base, results, goal)}
