"""Halting and live runs: every action the tree stops ticking while RUNNING is halted exactly once,
on every engine and on a robot (``hbtp.runtime.Runtime``); runs tick at a rate; Groot2 watches a
live run, and the trees a re-plan swaps in.

The actions here take several ticks (``LiveOptions(action_ticks=3)``, ``--action-ticks``): in the
symbolic world an action is RUNNING for that many ticks before its effects apply; on the toy robot
(:class:`SlowRobot`) an action answers ``running`` until its third call.
"""

from __future__ import annotations

import _thread
import dataclasses
import itertools
import json
import logging
import math
import random
import signal
import socket
import subprocess
import sys
import threading
import time
from collections.abc import Callable, Iterator
from pathlib import Path
from typing import Any

import pytest
from click.testing import CliRunner

from hbtp.bt import Action, Condition, Fallback, Node, Sequence, tree_of
from hbtp.bt.btcpp_engine import BtcppEngine, BtcppPolicy, Watch
from hbtp.bt.btlog import btlog_paths, read_btlog
from hbtp.bt.disturb import RandomDisturbance, event_model
from hbtp.bt.engines import Engine, TreePolicy
from hbtp.bt.jsonio import tree_to_json
from hbtp.bt.live import LiveOptions
from hbtp.bt.pytrees_xml import PytreesPolicy
from hbtp.bt.simulate import simulate
from hbtp.cli import main
from hbtp.cli.run_command import run_command
from hbtp.domains import DomainBuilder, Scenario
from hbtp.domains.mutex import infer_mutexes
from hbtp.errors import InputError
from hbtp.implementations import StatefulAction
from hbtp.logic.execution import Disturbance, Event, NodeStatus, Run
from hbtp.logic.lifecycle import ActionLifecycle, Phase
from hbtp.logic.task import GroundTask, State
from hbtp.pacing import MAX_TICK_HZ, Pacer, TickRate
from hbtp.planning import plan
from hbtp.replanning import ReplanOptions, run_replanning
from hbtp.runtime import Runtime
from helpers import kitchen_builder

TICKS = 3  # ticks per action
MILK = "IsIn(milk,fridge)"
COFFEE = "On(Coffee,Bar2)"


# ============================================================ set-up
@pytest.fixture(params=list(Engine), ids=lambda engine: engine.value)
def engine(request: pytest.FixtureRequest) -> Engine:
    """Each engine in turn (skipped when its library is not installed)."""
    if request.param is Engine.PY_TREES:
        pytest.importorskip("py_trees.parsers.behaviour_tree_xml", reason="py_trees >= 2.6 (its XML reader)")
    elif request.param is Engine.BTCPP:
        pytest.importorskip("behaviortreepy")
    return Engine(request.param)


@pytest.fixture
def policies(monkeypatch: pytest.MonkeyPatch) -> list[TreePolicy]:
    """Every tree policy an engine makes from now on (a re-plan makes one per tree), in order."""
    made: list[TreePolicy] = []
    original = Engine.policy

    def recording(self: Engine, tree: Node, task: GroundTask) -> TreePolicy:
        policy = original(self, tree, task)
        made.append(policy)
        return policy

    monkeypatch.setattr(Engine, "policy", recording)
    return made


def _assert_engine_halted(engine: Engine, policy: TreePolicy, expected: list[str]) -> None:
    """The actions the engine itself halted (BT.CPP's ``onHalted``, py_trees' ``terminate``) are
    ``expected``, in order; hbtp's engine keeps nothing between ticks and has nothing to halt."""
    if engine is Engine.HBTP:
        assert not hasattr(policy, "halted")
    else:
        assert isinstance(policy, BtcppPolicy | PytreesPolicy)
        assert policy.halted == expected


def _scenario(task: GroundTask) -> Scenario:
    return Scenario(task.name, task.name, "", task, infer_mutexes(task), Path("-"), Path("-"))


def _kitchen() -> tuple[GroundTask, Node]:
    """Walk to the fridge, open it, put the milk in; the full tree planned for the milk in the fridge."""
    task = kitchen_builder().build()
    result = plan(task, MILK, "obtea")
    assert result.solved
    return task, tree_of(result, "full")


def _trip() -> tuple[GroundTask, Node]:
    """Two ways to the goal, the road first: the disturbance that closes the road changes the branch."""
    task = (
        DomainBuilder("trip")
        .initial(["Road(x)", "Sky(x)"])
        .action("Drive(x)", pre=["Road(x)"], add=["At(x)"], cost=1)
        .action("Fly(x)", pre=["Sky(x)"], add=["At(x)"], cost=5)
        .build()
    )
    by_road = Sequence((_condition(task, "Road(x)"), _action(task, "Drive(x)")))
    by_air = Sequence((_condition(task, "Sky(x)"), _action(task, "Fly(x)")))
    return task, Fallback((_condition(task, "At(x)"), by_road, by_air))


def _walk_only(task: GroundTask) -> Node:
    """A kitchen tree that knows one step: walk to the fridge while it is closed. Once someone opens
    the fridge, no condition of it holds: a re-plan swaps another tree in."""
    walk = Sequence((_condition(task, "IsStanding(self)", "IsClose(fridge)"), _action(task, "Walk(fridge)")))
    return Fallback((_condition(task, MILK), walk))


def _condition(task: GroundTask, *literals: str) -> Condition:
    return Condition(frozenset(task.atom_id(name) for name in literals))


def _action(task: GroundTask, name: str) -> Action:
    return Action(task.action(name).index)


def _event_at(task: GroundTask, at: int, *, add: tuple[str, ...] = (), remove: tuple[str, ...] = ()) -> Disturbance:
    """A world event just before tick ``at``: ``add`` made true, ``remove`` false."""
    added = frozenset(task.atom_id(name) for name in add)
    removed = frozenset(task.atom_id(name) for name in remove)

    def disturbance(tick: int, state: State, last_action: int | None, before_last: State | None) -> Event | None:
        return Event("make-true", added, removed) if tick == at else None

    return disturbance


def _interrupt_at(at: int) -> Disturbance:
    """Ctrl-C just before tick ``at``."""

    def disturbance(tick: int, state: State, last_action: int | None, before_last: State | None) -> Event | None:
        if tick == at:
            raise KeyboardInterrupt
        return None

    return disturbance


def _actions(run: Run) -> list[str | None]:
    """The action each tick ran (``None``: the tick ran none)."""
    return [step.action if step.status is NodeStatus.RUNNING else None for step in run.trace]


def _stretches(run: Run) -> list[str]:
    """The actions of the run's stretches of ticks, a stretch being consecutive ticks of one action."""
    return [action for action, _ in itertools.groupby(_actions(run)) if action is not None]


def _expected_halts(run: Run, action_ticks: int) -> tuple[int, int]:
    """The halts and the actions applied of a run without re-plans, from its trace alone: a stretch
    of ``n`` ticks of one action applies it ``n // action_ticks`` times, and a rest (the tree moved
    on, or the run ended, before the action's last tick) is one halt."""
    lengths = [len(list(group)) for action, group in itertools.groupby(_actions(run)) if action is not None]
    return sum(n % action_ticks != 0 for n in lengths), sum(n // action_ticks for n in lengths)


def _free_port() -> int:
    """A port free on 127.0.0.1 whose next port is free too (Groot2 uses both)."""
    for _ in range(50):
        with socket.socket() as probe:
            probe.bind(("127.0.0.1", 0))
            port = probe.getsockname()[1]
        if port >= 65535:
            continue
        with socket.socket() as second:
            try:
                second.bind(("127.0.0.1", port + 1))
            except OSError:
                continue
        return int(port)
    raise AssertionError("no two free ports in a row on 127.0.0.1")


# ============================================================ the halt rule
def test_the_lifecycle_halts_an_action_the_next_tick_does_not_run_again_and_only_that() -> None:
    life = ActionLifecycle(action_ticks=2)
    assert life.step(7).phase is Phase.START
    assert life.step(7).phase is Phase.RUNNING
    assert life.done
    life.finish()  # applied: no longer active, not halted
    first = life.step(7)
    assert (first.halted, first.phase) == (None, Phase.START)  # the same action again: a new start
    other = life.step(8)
    assert (other.halted, other.phase) == (7, Phase.START)  # another action: 7 halted, once
    assert life.step(None).halted == 8  # no action (a higher condition holds, the root ended)
    assert life.step(None).halted is None
    assert life.halt() is None  # nothing active: nothing to halt at the end
    assert life.halted == [7, 8]
    for bad in (0, -1, 1.5, True, "2"):
        with pytest.raises(InputError, match="whole number of ticks"):
            ActionLifecycle(bad)  # type: ignore[arg-type]


def test_an_action_a_higher_condition_preempts_is_halted_once(engine: Engine) -> None:
    task, tree = _kitchen()
    undisturbed = simulate(tree, task, max_ticks=50, trace=True, live=LiveOptions(TICKS))
    assert undisturbed.reached(task.resolve_goal(MILK).ids)
    assert (undisturbed.halts, undisturbed.ticks, len(undisturbed.executed)) == (0, 3 * TICKS + 1, 3)
    # Someone brings the robot to the fridge while it walks: the higher condition (open the fridge) holds.
    near = _event_at(task, 2, add=("IsNear(self,fridge)",))
    policy = engine.policy(tree, task)
    run = simulate(tree, task, max_ticks=50, disturbance=near, trace=True, policy=policy, live=LiveOptions(TICKS))
    policy.halt()  # the run ended: the engine's tree halted (nothing is running any more)
    assert run.reached(task.resolve_goal(MILK).ids)
    assert _actions(run) == ["Walk(fridge)"] + ["Open(fridge)"] * TICKS + ["PutIn(milk,fridge)"] * TICKS + [None]
    assert run.halts == 1
    assert [task.actions[i].name for i in run.executed] == ["Open(fridge)", "PutIn(milk,fridge)"]  # no walk
    # In the engine an action never finishes by itself (the world applies it): each stretch of RUNNING
    # ticks of a node ends in exactly one halt, the last one when the goal holds.
    assert _stretches(run) == ["Walk(fridge)", "Open(fridge)", "PutIn(milk,fridge)"]
    _assert_engine_halted(engine, policy, _stretches(run))


def test_a_disturbance_that_changes_the_branch_halts_the_action_once(engine: Engine) -> None:
    task, tree = _trip()
    closed = _event_at(task, 3, remove=("Road(x)",))
    policy = engine.policy(tree, task)
    run = simulate(tree, task, max_ticks=20, disturbance=closed, trace=True, policy=policy, live=LiveOptions(TICKS))
    policy.halt()
    assert run.reached(task.resolve_goal("At(x)").ids)
    assert _actions(run) == ["Drive(x)"] * 2 + ["Fly(x)"] * TICKS + [None]
    assert (run.halts, [task.actions[i].name for i in run.executed]) == (1, ["Fly(x)"])
    _assert_engine_halted(engine, policy, ["Drive(x)", "Fly(x)"])


def test_a_replan_that_swaps_the_tree_halts_the_running_action_once(engine: Engine, policies: list[TreePolicy]) -> None:
    task = kitchen_builder().build()
    opened = _event_at(task, 2, add=("IsOpen(fridge)",), remove=("IsClose(fridge)",))
    result = run_replanning(
        _scenario(task), task.resolve_goal(MILK), _walk_only(task), max_ticks=50, disturbance=opened,
        options=ReplanOptions(engine=engine), trace=True, live=LiveOptions(TICKS),
    )  # fmt: skip
    assert result.reached(task.resolve_goal(MILK).ids)
    assert [(r.tick, r.reason, r.status) for r in result.replans] == [(2, "no condition of the tree holds", "solved")]
    run = result.run
    # the walk is halted by the swap and the new tree starts it again: three ticks, then the milk
    assert _actions(run) == ["Walk(fridge)"] * (1 + TICKS) + ["PutIn(milk,fridge)"] * TICKS + [None]
    assert run.halts == 1
    assert [task.actions[i].name for i in run.executed] == ["Walk(fridge)", "PutIn(milk,fridge)"]
    old, new = policies
    _assert_engine_halted(engine, old, ["Walk(fridge)"])  # not again when the swap halts the whole tree
    _assert_engine_halted(engine, new, ["Walk(fridge)", "PutIn(milk,fridge)"])


def test_the_end_of_a_run_and_ctrl_c_halt_the_running_action_once(engine: Engine, policies: list[TreePolicy]) -> None:
    task, tree = _kitchen()
    scenario, goal = _scenario(task), task.resolve_goal(MILK)
    live = LiveOptions(TICKS)
    ended = run_replanning(scenario, goal, tree, max_ticks=2, options=ReplanOptions(engine=engine), live=live)
    assert (ended.run.status, ended.run.hit_limit, ended.run.halts, ended.run.executed) == (
        NodeStatus.RUNNING, True, 1, ()
    )  # fmt: skip
    _assert_engine_halted(engine, policies[-1], ["Walk(fridge)"])
    with pytest.raises(KeyboardInterrupt):
        run_replanning(
            scenario, goal, tree, max_ticks=50, disturbance=_interrupt_at(3), options=ReplanOptions(engine=engine),
            live=live,
        )  # fmt: skip
    _assert_engine_halted(engine, policies[-1], ["Walk(fridge)"])
    finished = run_replanning(scenario, goal, tree, max_ticks=50, options=ReplanOptions(engine=engine), live=live)
    assert finished.reached(goal.ids)
    assert finished.run.halts == 0


def test_ctrl_c_halts_the_running_action_in_behaviortree_cpp_as_its_log_shows(tmp_path: Path) -> None:
    pytest.importorskip("behaviortreepy")
    task, tree = _kitchen()
    log_file = tmp_path / "interrupted.btlog"
    with pytest.raises(KeyboardInterrupt):
        BtcppEngine(tree, task).run(
            max_ticks=50, disturbance=_interrupt_at(3), watch=Watch(btlog=log_file), live=LiveOptions(TICKS)
        )
    log = read_btlog(log_file)  # written although the run was interrupted
    walk = [t.status for t in log.transitions if t.name == "Walk(fridge)"]
    assert walk == ["running", "idle"]  # started once, halted once, never ran to success
    run = BtcppEngine(tree, task).run(max_ticks=50, live=LiveOptions(TICKS))
    assert run.reached(task.resolve_goal(MILK).ids)


def test_halts_follow_the_ticks_on_every_engine_under_random_disturbances(robothow_small: Scenario) -> None:
    """Planned trees of a shipped scenario, actions of three ticks, random disturbances before every
    tick: each engine makes the same runs, and the halts are exactly those the trace implies."""
    task = robothow_small.task
    goal = task.resolve_goal("IsIn_apple_fridge & IsClose_fridge")
    tree = tree_of(plan(task, goal, "obtea", mutexes=robothow_small.mutexes), "full")
    live = LiveOptions(TICKS)
    undisturbed = simulate(tree, task, max_ticks=200, live=live)
    assert undisturbed.reached(goal.ids)
    assert undisturbed.halts == 0
    engines = [e for e in Engine if e is Engine.HBTP or _installed(e)]
    model = event_model(task, robothow_small.mutexes)
    halted = 0
    for seed in range(8):
        runs = []
        for engine in engines:
            policy = engine.policy(tree, task)
            disturbance = RandomDisturbance(model, 0.3, random.Random(seed))
            runs.append(
                simulate(tree, task, max_ticks=200, disturbance=disturbance, trace=True, policy=policy, live=live)
            )
            policy.halt()
        assert all(run == runs[0] for run in runs), seed
        assert (runs[0].halts, len(runs[0].executed)) == _expected_halts(runs[0], TICKS), seed
        halted += runs[0].halts
    assert halted > 0, "the disturbances must cut some actions short, or the test shows nothing"


def _installed(engine: Engine) -> bool:
    try:
        engine.require()
    except InputError:
        return False
    return True


# ============================================================ halting on a robot
class SlowRobot:
    """The symbolic world as a robot whose every action takes ``ticks`` calls: ``running`` until its
    last call, which applies the action's effects and succeeds; a halt stops it with no effect.
    ``events`` change the world when the observer is called for the n-th time (tick n)."""

    def __init__(
        self, task: GroundTask, ticks: int = TICKS, events: dict[int, Callable[[set[str]], None]] | None = None
    ) -> None:
        self.task = task
        self.ticks = ticks
        self.world = set(task.names(task.initial_state))
        self.events = events or {}
        self.observed = 0
        self.log: list[str] = []
        self.progress: dict[str, int] = {}

    def observe(self) -> list[str]:
        self.observed += 1
        event = self.events.get(self.observed)
        if event is not None:
            event(self.world)
        return sorted(self.world)

    def actions(self, **halts: Callable[[], object]) -> dict[str, StatefulAction]:
        """Every action's implementation; ``halts`` replaces the halt callback of some (by predicate)."""
        return {
            a.name: StatefulAction(
                self._callback("start", a.name), self._callback("running", a.name),
                halts.get(a.predicate, self._callback("halted", a.name)),
            )
            for a in self.task.actions
        }  # fmt: skip

    def _callback(self, kind: str, name: str) -> Callable[[], str | None]:
        def callback() -> str | None:
            self.log.append(f"{kind} {name}")
            if kind == "halted":
                self.progress.pop(name, None)
                return None
            return self._step(name, restart=kind == "start")

        return callback

    def _step(self, name: str, *, restart: bool) -> str:
        action = self.task.actions[self.task.action(name).index]
        if not set(self.task.names(action.pre)) <= self.world:
            return "failure"
        done = (0 if restart else self.progress.get(name, 0)) + 1
        if done < self.ticks:
            self.progress[name] = done
            return "running"
        self.progress.pop(name, None)
        self.world.difference_update(self.task.names(action.delete))
        self.world.update(self.task.names(action.add))
        return "success"


def _near(world: set[str]) -> None:
    world.add("IsNear(self,fridge)")


def _opened(world: set[str]) -> None:
    world.symmetric_difference_update({"IsOpen(fridge)", "IsClose(fridge)"})


def _interrupt(world: set[str]) -> None:
    raise KeyboardInterrupt


def _calls(kind: str, name: str) -> list[str]:
    return [f"{kind} {name}"] + [f"running {name}"] * (TICKS - 1)


def test_runtime_calls_start_running_and_halted_once_when_a_higher_condition_holds(engine: Engine) -> None:
    task = kitchen_builder().build()
    robot = SlowRobot(task, events={2: _near})
    report = Runtime(_scenario(task), MILK, robot.actions(), robot.observe, options=ReplanOptions(engine=engine)).run(
        50
    )
    assert report.succeeded, report.reason
    assert MILK in robot.world
    assert robot.log == ["start Walk(fridge)", "halted Walk(fridge)", *_calls("start", "Open(fridge)"),
                         *_calls("start", "PutIn(milk,fridge)")]  # fmt: skip
    assert (report.halted, report.halts, report.halt_errors) == (["Walk(fridge)"], 1, [])
    assert [r.reason for r in report.replans] == ["the first plan, from the observed state"]  # no other
    assert json.loads(json.dumps(report.to_dict()))["halts"] == 1


def test_runtime_halts_the_running_action_once_when_a_replan_swaps_the_tree(engine: Engine) -> None:
    task = kitchen_builder().build()
    robot = SlowRobot(task, events={2: _opened})
    runtime = Runtime(
        _scenario(task), MILK, robot.actions(), robot.observe, tree=_walk_only(task),
        options=ReplanOptions(engine=engine),
    )  # fmt: skip
    report = runtime.run(50)
    assert report.succeeded, report.reason
    assert MILK in robot.world
    assert [r.reason for r in report.replans] == ["no condition of the tree holds"]
    assert robot.log == ["start Walk(fridge)", "halted Walk(fridge)", *_calls("start", "Walk(fridge)"),
                         *_calls("start", "PutIn(milk,fridge)")]  # fmt: skip
    assert report.halted == ["Walk(fridge)"]


@pytest.fixture
def sigint_raises() -> Iterator[None]:
    """SIGINT raising KeyboardInterrupt, as in a terminal: a process started in the background
    (``cmd &`` in a script) inherits it ignored, and interrupt_main() then does nothing."""
    previous = signal.signal(signal.SIGINT, signal.default_int_handler)
    try:
        yield
    finally:
        signal.signal(signal.SIGINT, previous)


@pytest.mark.usefixtures("sigint_raises")
def test_runtime_halts_the_running_action_once_at_the_end_and_on_ctrl_c(engine: Engine) -> None:
    task = kitchen_builder().build()
    options = ReplanOptions(engine=engine)
    robot = SlowRobot(task)
    ended = Runtime(_scenario(task), MILK, robot.actions(), robot.observe, options=options).run(max_ticks=2)
    assert (ended.status, ended.reason, ended.interrupted) == (
        NodeStatus.RUNNING,
        "2 ticks without reaching the goal",
        False,
    )
    assert robot.log == ["start Walk(fridge)", "running Walk(fridge)", "halted Walk(fridge)"]
    assert ended.halted == ["Walk(fridge)"]
    robot = SlowRobot(task, events={3: _interrupt})
    interrupted = Runtime(_scenario(task), MILK, robot.actions(), robot.observe, options=options).run(50)
    assert interrupted.interrupted
    assert interrupted.reason == "interrupted (KeyboardInterrupt) at tick 2"
    assert robot.log == ["start Walk(fridge)", "running Walk(fridge)", "halted Walk(fridge)"]
    assert interrupted.halted == ["Walk(fridge)"]
    assert interrupted.to_dict()["interrupted"] is True
    # Ctrl-C itself: the signal reaches the thread that runs the run while an action's callback runs.
    robot = SlowRobot(task)
    actions = robot.actions()
    actions["Walk(fridge)"] = dataclasses.replace(actions["Walk(fridge)"], on_running=_thread.interrupt_main)
    pressed = Runtime(_scenario(task), MILK, actions, robot.observe, options=options).run(50)
    assert (pressed.interrupted, pressed.ticks, pressed.halted) == (True, 2, ["Walk(fridge)"])
    assert robot.log == ["start Walk(fridge)", "halted Walk(fridge)"]


def test_a_halt_callback_that_raises_is_reported_and_ends_the_run_cleanly(caplog: pytest.LogCaptureFixture) -> None:
    task = kitchen_builder().build()
    robot = SlowRobot(task, events={2: _near})
    halts: list[str] = []

    def stuck() -> None:
        halts.append("Walk")
        raise RuntimeError("the brake is stuck")

    with caplog.at_level(logging.WARNING, logger="hbtp.runtime"):
        report = Runtime(_scenario(task), MILK, robot.actions(Walk=stuck), robot.observe).run(50)
    message = "the halt of Walk(fridge) raised RuntimeError: RuntimeError('the brake is stuck')"
    assert (report.status, report.reason, report.halt_errors) == (NodeStatus.FAILURE, message, [message])
    assert halts == ["Walk"]  # called once
    assert report.halted == ["Walk(fridge)"]  # the open it would have started never started: no halt
    assert robot.log == ["start Walk(fridge)"]
    assert message in caplog.text


def test_a_halt_callback_that_hangs_is_bounded_by_the_tick_timeout_and_reported() -> None:
    task = kitchen_builder().build()
    robot = SlowRobot(task)
    release = threading.Event()
    runtime = Runtime(
        _scenario(task), MILK, robot.actions(Walk=lambda: release.wait(30)), robot.observe, tick_timeout_s=0.3
    )
    started = time.monotonic()
    report = runtime.run(max_ticks=2)
    elapsed = time.monotonic() - started
    release.set()
    assert elapsed < 10, elapsed  # bounded: the halt would hang for 30 s
    error = "the halt of Walk(fridge) did not return within 0.3 s"
    assert report.halt_errors == [error]
    assert report.reason == f"2 ticks without reaching the goal; {error}"
    assert report.halted == ["Walk(fridge)"]


def test_stateful_actions_are_checked_and_a_plain_callable_is_one() -> None:
    plain = StatefulAction.of(len)
    assert (plain.on_start, plain.on_running, plain.on_halted) == (len, None, None)
    assert plain.callback(Phase.RUNNING) is len
    with pytest.raises(InputError, match="on_halted of a StatefulAction must be callable"):
        StatefulAction(len, on_halted=42)  # type: ignore[arg-type]
    with pytest.raises(InputError, match="must be callable or a StatefulAction"):
        StatefulAction.of("go")  # type: ignore[arg-type]


# ============================================================ a tick rate
def test_a_pacer_sleeps_until_one_period_after_the_tick_before_started() -> None:
    now = [0.0]
    sleeps: list[float] = []

    def sleep(seconds: float) -> None:
        sleeps.append(round(seconds, 9))
        now[0] += seconds

    pacer = Pacer(0.1, clock=lambda: now[0], sleep=sleep)
    pacer.wait()  # the first tick at once
    now[0] += 0.03  # the tick takes 30 ms
    pacer.wait()
    now[0] += 0.25  # a tick that overruns its period: the next follows at once, no burst after
    pacer.wait()
    pacer.wait()
    assert sleeps == [0.07, 0.1]


@pytest.mark.parametrize("hz", [0, -1, math.nan, math.inf, -math.inf, MAX_TICK_HZ * 1.001, 1e308, True, "5"])
def test_a_tick_rate_is_a_positive_finite_number_up_to_the_maximum(hz: Any) -> None:
    with pytest.raises(InputError, match=r"tick rate must be a number of ticks per second in \(0, 1000\]"):
        TickRate(hz)


def test_runs_tick_at_the_rate_asked_for() -> None:
    """N ticks at F Hz take at least (N - 1) / F seconds (the first tick waits for nothing); only a
    lower bound is checked, as a busy machine may always be slower."""
    hz = 50.0
    task, tree = _kitchen()
    started = time.monotonic()
    run = simulate(tree, task, max_ticks=50, live=LiveOptions(TICKS, TickRate(hz)))
    elapsed = time.monotonic() - started
    assert run.reached(task.resolve_goal(MILK).ids)
    assert run.ticks == 3 * TICKS + 1
    assert elapsed >= 0.8 * (run.ticks - 1) / hz, elapsed
    robot = SlowRobot(task)
    started = time.monotonic()
    report = Runtime(_scenario(task), MILK, robot.actions(), robot.observe, tick_hz=hz).run(50)
    elapsed = time.monotonic() - started
    assert report.succeeded
    assert report.ticks == 3 * TICKS + 1
    assert elapsed >= 0.8 * (report.ticks - 1) / hz, elapsed
    with pytest.raises(InputError, match="tick rate"):
        Runtime(_scenario(task), MILK, robot.actions(), robot.observe, tick_hz=0)


# ============================================================ hbtp run
@pytest.fixture(scope="module")
def coffee_tree(tmp_path_factory: pytest.TempPathFactory, robowaiter: Scenario) -> Path:
    """RoboWaiter's coffee to the bar (five actions), planned and written as a tree file."""
    result = plan(robowaiter.task, COFFEE, "obtea", mutexes=robowaiter.mutexes)
    assert result.solved
    path = tmp_path_factory.mktemp("trees") / "coffee.json"
    path.write_text(tree_to_json(tree_of(result), robowaiter.task, scenario="robowaiter", goal=COFFEE), "utf-8")
    return path


@pytest.fixture(scope="module")
def replanned_tree(tmp_path_factory: pytest.TempPathFactory, robowaiter: Scenario) -> Path:
    """A RoboWaiter tree that knows only the last step (put the coffee held on the bar): no condition
    holds at s0, so its first tick re-plans."""
    task = robowaiter.task
    last = Sequence((_condition(task, "Holding(Coffee)", "RobotNear(Bar2)"), _action(task, "PutDown(Coffee,Bar2)")))
    path = tmp_path_factory.mktemp("trees") / "last-step.json"
    tree = Fallback((_condition(task, COFFEE), last))
    path.write_text(tree_to_json(tree, task, scenario="robowaiter", goal=COFFEE), "utf-8")
    return path


def test_hbtp_run_counts_the_halts_in_its_record(engine: Engine, coffee_tree: Path) -> None:
    args = [str(coffee_tree), "--engine", engine.value, "--action-ticks", str(TICKS), "--json"]
    reached = CliRunner().invoke(run_command, args)
    assert reached.exit_code == 0, reached.output
    record = json.loads(reached.output)
    assert (record["reached"], record["halts"], record["ticks"], len(record["executed"])) == (True, 0, 5 * TICKS + 1, 5)
    cut = CliRunner().invoke(run_command, [*args, "--max-ticks", "2"])
    assert cut.exit_code == 1, cut.output
    record = json.loads(cut.output)
    assert (record["status"], record["halts"], record["executed"]) == ("running", 1, [])
    text = CliRunner().invoke(run_command, [str(coffee_tree), "--engine", engine.value, "--action-ticks", "3",
                                            "--max-ticks", "4"])  # fmt: skip
    # the first action applied after its third tick, the second halted at the limit
    assert "tick limit: 4 tick(s), cost 5, 1 action(s), 1 halt(s)\nexecutes: Make(Coffee)\n" in text.output
    replanning = CliRunner().invoke(run_command, [*args, "--replan", "2", "--perturb", "0.3", "--runs", "3"])
    assert replanning.exit_code in (0, 1), replanning.output
    record = json.loads(replanning.output)
    assert record["halts"] == sum(row["halts"] for row in record["results"])


def test_hbtp_run_ticks_at_the_rate_asked_for(coffee_tree: Path) -> None:
    hz = 40.0
    started = time.monotonic()
    result = CliRunner().invoke(run_command, [str(coffee_tree), "--tick-hz", str(hz), "--action-ticks", "2", "--json"])
    elapsed = time.monotonic() - started
    assert result.exit_code == 0, result.output
    ticks = json.loads(result.output)["ticks"]
    assert ticks == 5 * 2 + 1
    assert elapsed >= 0.8 * (ticks - 1) / hz, elapsed


@pytest.mark.parametrize(
    ("extra", "message"),
    [
        (["--tick-hz", "0"], "Invalid value for '--tick-hz': the tick rate must be a number of ticks per second"),
        (["--tick-hz", "-2"], "in (0, 1000], not -2.0"),
        (["--tick-hz", "nan"], "in (0, 1000], not nan"),
        (["--tick-hz", "inf"], "in (0, 1000], not inf"),
        (["--tick-hz", "1e9"], "in (0, 1000], not 1000000000.0"),
        (["--action-ticks", "0"], "Invalid value for '--action-ticks'"),
        (["--engine", "btcpp", "--groot", "1667", "--groot-wait", "nan"], "must be a finite number of seconds >= 0"),
        (["--engine", "btcpp", "--groot", "1667", "--groot-wait", "-1"], "must be a finite number of seconds >= 0"),
        (["--groot-wait", "1"], "--groot-wait waits for Groot2: give --groot PORT"),
    ],
)
def test_bad_live_options_exit_2_with_one_line(coffee_tree: Path, extra: list[str], message: str) -> None:
    result = CliRunner().invoke(run_command, [str(coffee_tree), *extra])
    assert result.exit_code == 2, result.output
    lines = [line for line in result.output.splitlines() if message in line]
    assert len(lines) == 1, result.output


def test_a_groot2_port_in_use_is_a_one_line_error(coffee_tree: Path, capsys: pytest.CaptureFixture[str]) -> None:
    pytest.importorskip("behaviortreepy")
    with socket.socket() as holder:
        holder.bind(("127.0.0.1", 0))
        holder.listen()
        port = holder.getsockname()[1]
        for extra in ([], ["--replan", "2"]):
            assert main(["run", str(coffee_tree), "--engine", "btcpp", "--groot", str(port), *extra]) == 2
            error = capsys.readouterr().err
            assert error.startswith(f"hbtp: error: cannot publish to Groot2 on port {port}: "), error
            assert error.count("\n") == 1, error


def test_btlog_records_every_tree_of_a_run_with_replans(tmp_path: Path) -> None:
    pytest.importorskip("behaviortreepy")
    task = kitchen_builder().build()
    log_file = tmp_path / "run.btlog"
    assert btlog_paths(log_file, 3) == [log_file, tmp_path / "run.1.btlog", tmp_path / "run.2.btlog"]
    opened = _event_at(task, 2, add=("IsOpen(fridge)",), remove=("IsClose(fridge)",))
    result = run_replanning(
        _scenario(task), task.resolve_goal(MILK), _walk_only(task), max_ticks=50, disturbance=opened,
        options=ReplanOptions(engine=Engine.BTCPP), live=LiveOptions(TICKS), watch=Watch(btlog=log_file),
    )  # fmt: skip
    assert result.reached(task.resolve_goal(MILK).ids)
    first, second = (read_btlog(path) for path in btlog_paths(log_file, 2))
    assert not (tmp_path / "run.2.btlog").exists()
    assert [t.status for t in first.transitions if t.name == "Walk(fridge)"] == ["running", "idle"]  # halted
    assert "PutIn" not in first.xml
    assert "PutIn(milk,fridge)" in second.xml
    names = {a.name for a in task.actions}
    assert [n for n in second.started() if n in names] == ["Walk(fridge)", "PutIn(milk,fridge)"]


def test_hbtp_run_replans_with_btlog_and_groot(
    replanned_tree: Path, tmp_path: Path, capsys: pytest.CaptureFixture[str]
) -> None:
    """``--replan`` with ``--groot``: each tree a re-plan swaps in is published on the same port (a
    client asking for the tree gets the new XML); ``--btlog`` writes a log per tree."""
    pytest.importorskip("behaviortreepy")
    groot_client = pytest.importorskip("groot_client", reason="pyzmq (the dev extra) for a Groot2 client")
    port = _free_port()
    log_file = tmp_path / "run.btlog"
    xmls: list[str] = []  # each tree published, in order
    stop = threading.Event()

    def watch() -> None:
        # The tree is asked again and again: BT.CPP's binding gives every publisher the same tree id.
        with groot_client.GrootClient(port, timeout_s=0.2) as client:
            while not stop.is_set():
                tree = client.request(groot_client.FULL_TREE)
                if tree is not None and (not xmls or xmls[-1] != tree.body.decode("utf-8")):
                    xmls.append(tree.body.decode("utf-8"))
                time.sleep(0.01)

    watcher = threading.Thread(target=watch, daemon=True)
    watcher.start()
    argv = ["run", str(replanned_tree), "--engine", "btcpp", "--replan", "3", "--groot", str(port)]
    argv += ["--groot-wait", "1", "--tick-hz", "20", "--action-ticks", str(TICKS), "--btlog", str(log_file), "--json"]
    started = time.monotonic()
    try:
        code = main(argv)
    finally:
        elapsed = time.monotonic() - started
        stop.set()
        watcher.join(5)
    assert code == 0, capsys.readouterr().err
    record = json.loads(capsys.readouterr().out)
    assert elapsed >= 1.0  # the wait for Groot2
    (row,) = record["results"]
    assert row["reached"]
    assert [r["reason"] for r in row["replans"]] == ["no condition of the tree holds"]
    assert (row["ticks"], row["halts"]) == (5 * TICKS + 1, 0)
    paths = btlog_paths(log_file, 2)
    assert record["btlog"] == [str(path) for path in paths]
    first, second = (read_btlog(path) for path in paths)
    assert "MoveTo" not in first.xml
    assert [n for n in second.started() if "(" in n] == row["executed"]
    assert len(xmls) == 2, xmls
    assert "MoveTo" not in xmls[0]
    assert "MoveTo(Coffee)" in xmls[1]


# ============================================================ the live view
def _run_live(tree: Path, port: int) -> subprocess.Popen[str]:
    argv = [sys.executable, "-m", "hbtp", "run", str(tree), "--engine", "btcpp", "--tick-hz", "20"]
    argv += ["--groot", str(port), "--groot-wait", "2", "--action-ticks", "2"]
    return subprocess.Popen(argv, stdout=subprocess.PIPE, stderr=subprocess.PIPE, text=True)


@pytest.fixture
def live_run(coffee_tree: Path) -> Iterator[tuple[subprocess.Popen[str], int]]:
    pytest.importorskip("behaviortreepy")
    port = _free_port()
    process = _run_live(coffee_tree, port)
    try:
        yield process, port
    finally:
        if process.poll() is None:
            process.kill()
            process.communicate(timeout=30)


def test_a_live_run_can_be_watched_in_groot2(live_run: tuple[subprocess.Popen[str], int]) -> None:
    """``hbtp run --engine btcpp --tick-hz 20 --groot PORT --groot-wait 2`` in a process of its own;
    a Groot2-protocol client on 127.0.0.1:PORT gets the tree's XML and sees its nodes change status."""
    groot_client = pytest.importorskip("groot_client", reason="pyzmq (the dev extra) for a Groot2 client")
    process, port = live_run
    deadline = time.monotonic() + 60
    with groot_client.GrootClient(port) as client:
        tree = None
        while tree is None and process.poll() is None and time.monotonic() < deadline:
            tree = client.request(groot_client.FULL_TREE)
        assert tree is not None, "no answer from the Groot2 publisher"
        xml = tree.body.decode("utf-8")
        assert all(part in xml for part in ('<BehaviorTree ID="MainTree"', "MoveTo(Coffee)", "PutDown(Coffee,Bar2)"))
        snapshots: list[dict[int, int]] = []
        while process.poll() is None and time.monotonic() < deadline:
            reply = client.request(groot_client.STATUS)
            if reply is not None:
                assert reply.tree_id == tree.tree_id
                now = groot_client.statuses(reply.body)
                if not snapshots or now != snapshots[-1]:
                    snapshots.append(now)
            time.sleep(0.02)
    out, err = process.communicate(timeout=30)
    assert process.returncode == 0, err
    assert out.startswith("BehaviorTree.CPP: goal reached: 11 tick(s)")
    assert len(snapshots) >= 2, snapshots  # the statuses changed while the client watched
    assert any(status == 1 for snapshot in snapshots for status in snapshot.values())  # a node RUNNING
