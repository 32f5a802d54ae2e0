"""Re-planning: tick a planned tree, and plan again from the state when the tree has no answer.

A planned tree acts from every state that satisfies one of its conditions. A disturbance can leave
the world in a state that satisfies none (the tree's root fails), and on a robot an action can keep
failing. :class:`Replanner` is a policy (:data:`hbtp.logic.execution.Policy`) that ticks the current
tree and, when it fails, plans again from the state it is ticked in (LLM-free: OBTEA, with the
landmark heuristic in the full space and h_max in the hints' space by default), swaps the new tree
in and ticks that. It is bounded: at most
``max_replans`` re-plans and ``budget_s`` seconds of re-planning per run; then, or when the goal is
unsolvable from the observed state, the policy fails for good with the reason in
:attr:`Replanner.gave_up`. The tree is ticked by the engine of :attr:`ReplanOptions.engine`
(:class:`hbtp.bt.engines.Engine`: hbtp's own, py_trees through its BT.CPP-XML reader, or
BehaviorTree.CPP); a re-plan builds the new tree in that engine. Swapping a tree halts the old one
(:meth:`~hbtp.bt.engines.TreePolicy.halt`) and then calls the ``on_swap`` hooks with the new tree's
policy: the runtime halts the action that was running (:mod:`hbtp.logic.lifecycle`), Groot2 and
BT.CPP's log move to the new tree (:class:`hbtp.bt.btcpp_engine.Watcher`).

:func:`run_replanning` runs it in the symbolic world: the one executor applies each action's effects
and an optional disturbance changes the state before ticks; the robustness benchmark and ``hbtp run
--replan`` use it. :class:`hbtp.runtime.Runtime` runs it on a robot.

Re-planning from a state uses the proved mutexes only when the state satisfies them (a state that
breaks an invariant, which no action can cause, is planned from without mutex pruning).

A re-plan is a *repair* by default (:attr:`ReplanOptions.repair`): the first re-plan's search is kept
(:class:`hbtp.planning.repair.RepairableSearch`) and each later re-plan continues it from the new
state, with the same optimal cost as a search from scratch. A state that breaks a proved mutex, left
out actions, or a planner whose searches cannot be continued (:func:`~hbtp.planning.repair.repairable`)
search from scratch.
"""

from __future__ import annotations

import contextlib
import dataclasses
import json
import logging
import statistics
import time
from collections.abc import Callable, Iterable, Sequence
from dataclasses import dataclass, field
from typing import Any

from hbtp.bt.btcpp_engine import Watch, btcpp_binding
from hbtp.bt.build import tree_of
from hbtp.bt.disturb import seeded_disturbances, summarise_runs
from hbtp.bt.engines import Engine, TreePolicy
from hbtp.bt.jsonio import node_to_dict
from hbtp.bt.live import LiveOptions, paced
from hbtp.bt.nodes import Node
from hbtp.bt.simulate import DEFAULT_MAX_TICKS, simulate, trace_to_jsonl
from hbtp.domains.mutex import Mutexes
from hbtp.domains.scenarios import Scenario
from hbtp.errors import InputError
from hbtp.logic.execution import Disturbance, NodeStatus, Run, Trace, execute
from hbtp.logic.task import Goal, GoalIds, GroundAction, GroundTask, State
from hbtp.planning.heuristic_names import DEFAULT_HEURISTIC, HeuristicName
from hbtp.planning.hints import Hints
from hbtp.planning.kept import KeptSearch
from hbtp.planning.limits import Limits
from hbtp.planning.planners import Space, confirmed_search, planner_config
from hbtp.planning.repair import RepairableSearch, repairable
from hbtp.planning.result import PlanResult, Status
from hbtp.planning.search_state import SearchConfig
from hbtp.planning.symmetry import find_symmetry

log = logging.getLogger(__name__)

__all__ = [
    "PRUNED_EXPANSIONS",
    "UNSOLVABLE_FROM_STATE",
    "KeptSearch",
    "Replan",
    "ReplanOptions",
    "Replanner",
    "ReplanningRun",
    "SwapHook",
    "full_space_cost",
    "replanning_runs",
    "replanning_stats",
    "replanning_summary",
    "replanning_trace_jsonl",
    "run_replanning",
]


#: How :attr:`Replanner.gave_up` starts when no tree reaches the goal from the state.
UNSOLVABLE_FROM_STATE = "no tree reaches the goal from the observed state"
#: Conditions a re-plan's repair explores before a state with interchangeable objects is searched
#: afresh with symmetry pruning (see :func:`_repaired`).
REPAIR_EXPANSIONS = 5_000
#: Conditions a re-plan explores in the hints' space before it searches the full space.
PRUNED_EXPANSIONS = 5_000

#: Called when a re-plan swaps a tree in, with the new tree's policy (the old tree already halted).
SwapHook = Callable[[TreePolicy], object]


@dataclass(frozen=True)
class ReplanOptions:
    """How to re-plan: the planner and heuristic, the kind of tree, the bounds of one run, and the
    engine that ticks the trees."""

    max_replans: int = 10
    #: Seconds of re-planning in one run, all re-plans together.
    budget_s: float = 30.0
    planner: str = "obtea"
    #: The heuristic of the full space's search.
    heuristic: HeuristicName = DEFAULT_HEURISTIC
    #: The heuristic of the searches in the hints' space (:attr:`hints`): spaces of tens of actions,
    #: where building the landmark table costs more than the expansions it saves (h_max: re-plans
    #: 8-12% faster on the four Table II sets, the same optimal costs in that space).
    pruned_heuristic: HeuristicName = HeuristicName.HMAX
    tree: str = "full"
    engine: Engine = Engine.HBTP
    #: Continue the last re-plan's search from the new state (:mod:`hbtp.planning.repair`: the same
    #: optimal cost, less work); ``False`` searches from scratch each time (for comparison).
    repair: bool = True
    #: The search re-plans continue, shared by the runs given these options (``None``: each
    #: :class:`Replanner` keeps its own; :func:`replanning_runs` gives its runs one).
    kept: KeptSearch | None = field(default=None, compare=False, repr=False)
    #: The hints the tree was planned with (an LLM's, HBTP-S's pruned space): a re-plan first searches
    #: their pruned space widened by the objects the state changed (see :meth:`Replanner.replan`), then
    #: the full space. ``None``: the full space only (the optimal tree from the state).
    hints: Hints | None = None

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
        planner_config(self.planner, heuristic=self.heuristic)  # checks the names
        planner_config(self.planner, heuristic=self.pruned_heuristic)


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
    #: The action space whose search answered: the hints' (pruned) or every action's (full).
    space: Space = Space.FULL
    #: The answer of an earlier search from the same state (:meth:`KeptSearch.recall`), not searched again.
    recalled: bool = False
    #: The state it planned from.
    state: State = field(default=frozenset(), compare=False, repr=False)

    def to_dict(self) -> dict[str, Any]:
        """The re-plan without its tree (:meth:`trace_record` has it) and state."""
        record = {f.name: getattr(self, f.name) for f in dataclasses.fields(self) if f.name not in ("tree", "state")}
        record["space"] = self.space.value
        return record

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
        self,
        scenario: Scenario,
        goal: Goal,
        tree: Node | None,
        options: ReplanOptions = ReplanOptions(),
        *,
        on_swap: Iterable[SwapHook] = (),
    ) -> None:
        self.task = scenario.task
        self.mutexes = scenario.mutexes.proved_only()
        self.goal = goal
        self.options = options
        #: The current tree, ticked by ``options.engine`` (``None``: no tree yet, the first tick re-plans).
        self.tree = tree
        self.policy: TreePolicy | None = None if tree is None else options.engine.policy(tree, self.task)
        self.on_swap = list(on_swap)
        self.replans: list[Replan] = []
        self.spent = 0.0
        self.ticks = 0
        self.excluded: set[int] = set()
        #: The search the next re-plan continues (its ``search`` is ``None`` until a re-plan starts one).
        self.kept = options.kept if options.kept is not None else KeptSearch()
        if options.hints is not None:  # built with the tree, not at the first re-plan
            self.kept.pruned_space(self.task, options.hints)
        # The full space's heuristic reads which actions need each atom; built here once, every task
        # from an observed state (GroundTask.from_state) shares it instead of building its own.
        _ = self.task.consumers
        #: Why the policy stopped re-planning (``None`` while it may still re-plan).
        self.gave_up: str | None = None
        #: Whether it stopped because a re-plan proved the goal unreachable from the state.
        self.unsolvable = False

    def __call__(self, state: State) -> tuple[NodeStatus, int | None]:
        self.ticks += 1
        status, action = self._tick(state)
        if status is not NodeStatus.FAILURE or self.gave_up is not None:
            return status, action
        if not self.replan(state, "no condition of the tree holds"):
            return NodeStatus.FAILURE, None
        return self._tick(state)

    def _tick(self, state: State) -> tuple[NodeStatus, int | None]:
        return (NodeStatus.FAILURE, None) if self.policy is None else self.policy(state)

    def halt(self) -> None:
        """Halt the current tree (the end of a run)."""
        if self.policy is not None:
            self.policy.halt()

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
        space, result, recalled = self._plan(state, left)
        seconds = time.perf_counter() - started
        self.spent += seconds
        log.info(
            "tick %d: re-planned (%s) in %.1f ms: %s in the %s space%s",
            self.ticks, reason, seconds * 1000, result.status.value, space.value, " (recalled)" if recalled else "",
        )  # fmt: skip
        tree = tree_of(result, options.tree) if result.solved else None
        replan = Replan(self.ticks, reason, round(seconds, 6), result.status.value, result.cost, result.message)
        self.replans.append(
            dataclasses.replace(replan, tree=tree, space=space, recalled=recalled, state=frozenset(state))
        )
        if result.status is Status.UNSOLVABLE:
            self.unsolvable = True
            return self._give_up(f"{UNSOLVABLE_FROM_STATE}: {result.message}")
        if tree is None:
            return self._give_up(f"re-planning found no tree ({result.status.value}: {result.message})")
        self._swap(tree)
        return True

    def _swap(self, tree: Node) -> None:
        """Halt the current tree, tick ``tree`` from now on, and tell the ``on_swap`` hooks."""
        self.halt()
        self.tree = tree
        self.policy = self.options.engine.policy(tree, self.task)
        for hook in self.on_swap:
            hook(self.policy)

    def _plan(self, state: State, seconds: float) -> tuple[Space, PlanResult, bool]:
        """The new tree's search from ``state``: the hints' space first (when the options have hints
        and it finds a tree within :data:`PRUNED_EXPANSIONS`), else the full space; and whether the
        answer was recalled (:meth:`KeptSearch.recall`: the hints' space searched from ``state``
        before, by this or another run sharing the kept search)."""
        started = time.perf_counter()
        options = self.options
        config = planner_config(options.planner, heuristic=options.heuristic)
        pruned_config = planner_config(options.planner, heuristic=options.pruned_heuristic)
        hints = options.hints
        key = (self.goal.disjuncts, pruned_config, frozenset(state), frozenset(self.excluded))
        settled, answer = self.kept.recall(key) if hints is not None else (True, None)
        if answer is not None:
            return Space.PRUNED, answer, True
        world = self.task.from_state(state)
        goal = world.resolve_goal(self.goal)
        mutexes = self.mutexes if self.mutexes.conflict(frozenset(state)) is None else None
        if not settled:  # the hints' space not searched from this state yet
            left = seconds - (time.perf_counter() - started)
            answer, decided = self._pruned(world, goal, state, pruned_config, mutexes, left)
            if decided:
                self.kept.remember(key, answer)
            if answer is not None:
                return Space.PRUNED, answer, False
        actions: Sequence[GroundAction] = world.actions
        if self.excluded:
            actions = [a for a in world.actions if a.index not in self.excluded]
        left = max(seconds - (time.perf_counter() - started), 1e-9)
        return Space.FULL, self._full(world, goal, actions, config, mutexes, left), False

    def _pruned(
        self, world: GroundTask, goal: Goal, state: State, config: SearchConfig, mutexes: Mutexes | None, seconds: float
    ) -> tuple[PlanResult | None, bool]:
        """The hints' space's tree from ``state`` (``None``: none within :data:`PRUNED_EXPANSIONS`
        conditions, its space widened twice), and whether that is decided (no time limit ended a
        search: the same search would give it again)."""
        assert self.options.hints is not None
        started = time.perf_counter()
        space = self.kept.pruned_space(self.task, self.options.hints)
        decided = True
        for widened in (space.around, space.beyond):
            left = max(seconds - (time.perf_counter() - started), 1e-9)
            limits = Limits(time_s=left, max_expansions=PRUNED_EXPANSIONS)
            pruned = [world.actions[i] for i in widened(state) if i not in self.excluded]
            result = confirmed_search(world, goal, pruned, config, mutexes=mutexes, limits=limits)
            if result.solved:
                return result, decided
            decided = decided and result.status is not Status.TIMEOUT
            log.info("no tree in the hints' space (%s, %s)", widened.__name__, result.status.value)
        return None, decided

    def _full(
        self,
        world: GroundTask,
        goal: Goal,
        actions: Sequence[GroundAction],
        config: SearchConfig,
        mutexes: Mutexes | None,
        seconds: float,
    ) -> PlanResult:
        """The full space's search: the kept search continued (a repair) where it can be."""
        limits = Limits(time_s=seconds)
        if not self.options.repair or self.excluded or mutexes is None or not repairable(config):
            return confirmed_search(world, goal, actions, config, mutexes=mutexes, limits=limits)
        search, result = _repaired(self.kept.take(goal, config), world, goal, actions, config, mutexes, seconds)
        self.kept.search = search
        if search is not None and search.spent:
            log.info("the kept search holds %d conditions: dropped, the next re-plan starts anew", len(search.nodes))
            self.kept.search = None
        return result

    def _give_up(self, reason: str) -> bool:
        self.gave_up = reason  # reported by the caller (the run's result, the command's output)
        log.info("%s", reason)
        return False


def _repaired(
    search: RepairableSearch | None,
    world: GroundTask,
    goal: Goal,
    actions: Sequence[GroundAction],
    config: SearchConfig,
    mutexes: Mutexes,
    seconds: float,
) -> tuple[RepairableSearch | None, PlanResult]:
    """The kept ``search`` continued from ``world``'s s0 (started when ``None``), optimal; the search
    to keep. A repair that explores :data:`REPAIR_EXPANSIONS` more conditions without an answer gives
    way, when the state has interchangeable objects, to a fresh search that prunes by them (optimal
    too, and far smaller there: a robot holding one thing it could put on any of a hundred surfaces);
    otherwise the repair goes on. Both within ``seconds``; the expansion bound keeps it deterministic."""
    started = time.perf_counter()
    base = 0 if search is None else len(search.expansions)
    capped = Limits(time_s=seconds, max_expansions=base + REPAIR_EXPANSIONS)
    if search is None:
        search, result = RepairableSearch.start(world, goal, actions, config, mutexes=mutexes, limits=capped)
    else:
        result = search.repair(world, goal, capped)
    if result.status is not Status.NODE_LIMIT or search is None:
        return search, result
    left = max(seconds - (time.perf_counter() - started), 1e-9)
    if find_symmetry(world, goal.disjuncts, actions) is None:
        return search, search.repair(world, goal, Limits(time_s=left))
    log.info("the repair explored %d conditions: a fresh search with symmetry pruning instead", REPAIR_EXPANSIONS)
    symmetric = dataclasses.replace(config, symmetry=True)
    return search, confirmed_search(world, goal, actions, symmetric, mutexes=mutexes, limits=Limits(time_s=left))


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
    live: LiveOptions | None = None,
    watch: Watch | None = None,
) -> ReplanningRun:
    """Run ``tree`` in the symbolic world from ``state`` (default s0), re-planning when it fails;
    ``live`` gives the ticks per action and the tick rate, ``watch`` (BehaviorTree.CPP only) has
    Groot2 and BT.CPP's log follow every tree of the run. A re-plan halts the action running."""
    if watch is not None and options.engine is not Engine.BTCPP:
        raise InputError("Groot2 and BT.CPP's log watch BehaviorTree.CPP: give the engine Engine.BTCPP")
    live = live or LiveOptions()
    life = live.lifecycle()
    policy = Replanner(scenario, goal, tree, options, on_swap=[lambda _policy: life.halt()])
    tracer = Trace(scenario.task) if trace else None
    with contextlib.ExitStack() as stack:
        if watch is not None:
            watcher = stack.enter_context(watch.watching(btcpp_binding()))
            watcher.attach(policy.policy)  # type: ignore[arg-type]  # a BtcppPolicy (checked above)
            policy.on_swap.append(watcher.attach)  # type: ignore[arg-type]
        stack.callback(policy.halt)  # the tree halted when the run ends (while still watched)
        run = execute(
            paced(policy, live.rate),
            scenario.task,
            state,
            max_ticks=max_ticks,
            disturbance=disturbance,
            observers=(tracer,) if tracer else (),
            lifecycle=life,
        )
    if tracer is not None:
        run = dataclasses.replace(run, trace=tuple(tracer.steps))
    return ReplanningRun(run, tuple(policy.replans), policy.gave_up, policy.unsolvable)


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
    live: LiveOptions | None = None,
) -> list[ReplanningRun]:
    """``runs`` runs with re-planning under the seeded disturbances of
    :func:`hbtp.bt.disturb.disturbed_runs` (run ``i`` meets the same random numbers as there). The runs
    share one :class:`KeptSearch`: a re-plan continues the search of the runs before it."""
    if options.kept is None:
        options = dataclasses.replace(options, kept=KeptSearch())
    return [
        run_replanning(
            scenario, goal, tree, max_ticks=max_ticks, disturbance=disturbance, options=options, trace=trace, live=live
        )
        for disturbance in seeded_disturbances(scenario.task, scenario.mutexes, p, runs, seed)
    ]


def replanning_summary(base: Run, results: Sequence[ReplanningRun], goal: Goal) -> dict[str, Any]:
    """:func:`hbtp.bt.disturb.summarise_runs` of the runs, plus the re-plans per run, their times,
    and the runs that ended because the goal could no longer be reached (``unsolvable_runs``)."""
    stats = summarise_runs(base, [r.run for r in results], goal)
    unsolvable = [r for r in results if r.unsolvable]
    reachable = [r for r in results if not r.unsolvable]
    times = [replan.seconds for r in results for replan in r.replans]
    searched = [replan.seconds for r in results for replan in r.replans if not replan.recalled]
    stats.update(
        replans=sum(len(r.replans) for r in results),
        mean_replans=round(statistics.fmean(len(r.replans) for r in results), 6) if results else None,
        median_replan_ms=round(1000 * statistics.median(times), 3) if times else None,
        max_replan_ms=round(1000 * max(times), 3) if times else None,
        recalled_replans=len(times) - len(searched),
        median_searched_replan_ms=round(1000 * statistics.median(searched), 3) if searched else None,
        pruned_replans=sum(replan.space is Space.PRUNED for r in results for replan in r.replans),
        unsolvable_runs=len(unsolvable),
        budget_runs=sum(_hit_budget(r) for r in results),
        success_rate_reachable=(
            round(sum(r.reached(goal) for r in reachable) / len(reachable), 6) if reachable else None
        ),
    )
    return stats


def full_space_cost(
    scenario: Scenario, goal: Goal, state: State, options: ReplanOptions = ReplanOptions()
) -> int | None:
    """The optimal cost from ``state`` (a fresh search of the full space with ``options``' planner and
    heuristic; ``None`` when there is no tree): what a re-plan in the hints' space is checked against."""
    world = scenario.task.from_state(state)
    proved = scenario.mutexes.proved_only()
    mutexes = proved if proved.conflict(frozenset(state)) is None else None
    config = planner_config(options.planner, heuristic=options.heuristic)
    return confirmed_search(world, world.resolve_goal(goal), world.actions, config, mutexes=mutexes).cost


def _hit_budget(result: ReplanningRun) -> bool:
    """Whether a run's re-planning ran out of time (a re-plan's time limit or the run's budget)."""
    timed_out = any(r.status == Status.TIMEOUT.value for r in result.replans)
    return timed_out or (result.gave_up is not None and "budget" in result.gave_up)


def replanning_stats(
    scenario: Scenario,
    goal: Goal,
    tree: Node,
    p: float,
    runs: int,
    seed: int = 0,
    max_ticks: int = DEFAULT_MAX_TICKS,
    options: ReplanOptions = ReplanOptions(),
    *,
    check: bool = False,
) -> dict[str, Any]:
    """:func:`hbtp.bt.disturb.perturbation_stats` with re-planning (see :func:`replanning_summary`);
    with ``check``, each re-plan the hints' space answered is checked against :func:`full_space_cost`:
    how many found that optimum (``optimal_replans``) and the cost the others added
    (``replan_extra_cost``)."""
    base = simulate(tree, scenario.task, max_ticks=max_ticks)
    results = replanning_runs(scenario, goal, tree, p, runs, seed, max_ticks=max_ticks, options=options)
    stats = {"p": p, "seed": seed, **replanning_summary(base, results, goal)}
    if check:
        pruned = [replan for result in results for replan in result.replans if replan.space is Space.PRUNED]
        pairs = [(replan.cost or 0, full_space_cost(scenario, goal, replan.state, options) or 0) for replan in pruned]
        stats["optimal_replans"] = sum(cost == best for cost, best in pairs)
        stats["replan_extra_cost"] = sum(cost - best for cost, best in pairs)
    return stats
