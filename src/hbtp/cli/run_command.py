"""``hbtp run`` and ``hbtp verify``: simulate or statically check a tree written by ``hbtp plan``.

The tree file is hbtp JSON or BehaviorTree.CPP XML (see :mod:`hbtp.cli.tree_input`: the scenario and
goal recorded in it are used unless ``--scenario``/``--pddl``/``--goal`` are given).

``hbtp run`` ticks as fast as it can unless ``--tick-hz F`` holds a rate; ``--action-ticks N`` makes
each action RUNNING for N ticks before its effects apply (an action the tree stops ticking before
then is halted; the halts are counted); with ``--engine btcpp``, ``--groot PORT`` publishes every
tree of the run to Groot2 (``--groot-wait S``: S seconds for Groot2 to connect before the first tick)
and ``--btlog FILE`` logs every tree (:func:`hbtp.bt.btlog.btlog_paths`), re-plans included.

Exit codes (also when the commands are invoked on their own, as click commands): 0 the goal was
reached (every run, with ``--runs``) / the verifier proved that the tree reaches the goal from the
initial state; 1 it was not / it did not; 2 bad input (a file that is not a tree, an unknown node
type, literal or action, a probability outside [0, 1]).
"""

from __future__ import annotations

import functools
import logging
import math
from collections.abc import Callable, Sequence
from dataclasses import dataclass
from pathlib import Path
from typing import Any, TypeVar

import click

from hbtp.bt.btcpp_engine import BtcppEngine, Watch
from hbtp.bt.btlog import btlog_paths
from hbtp.bt.disturb import check_probability, seeded_disturbances, summarise_runs
from hbtp.bt.engines import Engine
from hbtp.bt.jsonio import goal_text
from hbtp.bt.live import LiveOptions
from hbtp.bt.simulate import DEFAULT_MAX_TICKS, Run, simulate, trace_to_jsonl
from hbtp.bt.verify import verify
from hbtp.cli.exit_codes import CommandError, ExitCode, command_error
from hbtp.cli.options import ScenarioSource, echo_json, option_group, output_option, scenario_options
from hbtp.cli.tree_input import TreeInput, load_tree_input
from hbtp.errors import HbtpError, InputError
from hbtp.files import write_all_atomically
from hbtp.logic.execution import Disturbance
from hbtp.logic.task import GoalIds, GroundTask
from hbtp.pacing import MAX_TICK_HZ, TickRate
from hbtp.replanning import (
    KeptSearch,
    ReplanningRun,
    ReplanOptions,
    replanning_summary,
    replanning_trace_jsonl,
    run_replanning,
)

log = logging.getLogger(__name__)

F = TypeVar("F", bound=Callable[..., Any])

EXIT_OK, EXIT_FAILED, EXIT_INPUT = ExitCode.OK, ExitCode.NOT_SOLVED, ExitCode.INPUT

#: Steps of an ``executes:`` line shown before the rest is summarised.
SHOWN_STEPS = 30


InputFailure = CommandError  # bad input, reported in one line with exit code 2


def exit_codes(function: F) -> F:
    """Turn hbtp's errors into their exit code (:func:`hbtp.cli.exit_codes.exit_code_for`) and one
    ``hbtp: error:`` line, and the command's returned code into its exit code, both under ``hbtp``
    and when the command is invoked alone (``CliRunner``)."""

    @functools.wraps(function)
    def wrapper(*args: Any, **kwargs: Any) -> Any:
        try:
            code = function(*args, **kwargs)
        except HbtpError as error:
            raise command_error(error) from None
        raise click.exceptions.Exit(int(code))

    return wrapper  # type: ignore[return-value]


def abbreviate_steps(names: Sequence[str], shown: int = SHOWN_STEPS) -> str:
    """``A -> B -> B -> B`` as ``A -> B ×3``: repeated actions and repeated cycles of up to four
    actions (``(Open(x) -> Close(x)) ×50``) are counted, and after ``shown`` steps the rest is
    summarised (``... 12 more action(s)``)."""
    if not names:
        return "(nothing)"
    steps: list[str] = []
    position = 0
    while position < len(names):
        best_length, best_times = 1, 1
        for length in range(1, 5):
            block = names[position : position + length]
            if len(block) < length:
                break
            times = 1
            while names[position + times * length : position + (times + 1) * length] == block:
                times += 1
            if times > 1 and times * length > best_times * best_length:
                best_length, best_times = length, times
        block = names[position : position + best_length]
        text = " -> ".join(block) if best_length == 1 else "(" + " -> ".join(block) + ")"
        steps.append(f"{text} ×{best_times}" if best_times > 1 else text)
        position += best_length * best_times
    if len(steps) > shown:
        rest = len(steps) - shown
        steps = [*steps[:shown], f"... {rest} more step(s)"]
    return " -> ".join(steps)


def _describe_run(run: Run, reached: bool) -> str:
    outcome = (
        "goal reached" if reached else ("tick limit" if run.hit_limit else f"{run.status.value}, goal not reached")
    )
    halts = f", {run.halts} halt(s)" if run.halts else ""
    return f"{outcome}: {run.ticks} tick(s), cost {run.cost}, {len(run.executed)} action(s){halts}"


def _number(value: Any, sign: bool = False) -> str:
    if value is None:
        return "-"
    return f"{value:+.2f}" if sign else f"{value:.2f}"


@dataclass(frozen=True)
class RunRequest:
    """What ``hbtp run`` was asked to do with the tree."""

    perturb: float
    runs: int
    seed: int
    max_ticks: int
    replan: int
    replan_full_space: bool
    engine: Engine
    action_ticks: int
    tick_hz: TickRate | None
    groot: int | None
    groot_wait: float
    btlog: str | None
    trace_file: str | None
    as_json: bool

    @property
    def live(self) -> LiveOptions:
        return LiveOptions(self.action_ticks, self.tick_hz)

    def watch(self, *, log: bool = True, first: bool = True) -> Watch | None:
        """Who watches a BT.CPP run (``log``: this run writes --btlog; ``first``: the command's first
        run, the one that waits for Groot2), ``None`` when nobody does."""
        btlog = Path(self.btlog) if log and self.btlog else None
        if self.groot is None and btlog is None:
            return None
        return Watch(self.groot, btlog, self.groot_wait if first else 0.0)


def _tick_rate(_context: click.Context, _parameter: click.Parameter, value: float | None) -> TickRate | None:
    if value is None:
        return None
    try:
        return TickRate(value)
    except InputError as error:
        raise click.BadParameter(str(error)) from None


def _groot_wait(_context: click.Context, _parameter: click.Parameter, value: float) -> float:
    if not (0 <= value < math.inf):  # also nan
        raise click.BadParameter(f"must be a finite number of seconds >= 0, not {value}")
    return value


run_options = option_group(
    "request",
    RunRequest,
    click.option(
        "--perturb", type=float, default=0.0, show_default=True, help="Probability of an event before each tick."
    ),
    click.option("--runs", type=int, default=1, show_default=True, help="Perturbed runs (with --perturb)."),
    click.option("--seed", type=int, default=0, show_default=True, help="Seed of the perturbations."),
    click.option(
        "--max-ticks", type=int, default=DEFAULT_MAX_TICKS, show_default=True, help="Give up after this many."
    ),
    click.option(
        "--replan",
        type=click.IntRange(0),
        default=0,
        show_default=True,
        help="Re-plan from the state (OBTEA) when no condition of the tree holds, "
        "at most this many times per run; 0: never. A tree file that records the hints it was planned "
        "with (an LLM's) is re-planned in their space first, widened by the objects the state changed.",
    ),
    click.option(
        "--replan-full-space",
        is_flag=True,
        help="Re-plan in the full space only (the optimal tree from the state), not the hints' space first.",
    ),
    click.option(
        "--engine",
        type=click.Choice([engine.value for engine in Engine]),
        default=Engine.HBTP.value,
        show_default=True,
        callback=lambda _context, _parameter, value: Engine(value),
        help="Who ticks the tree: hbtp's own engine, py_trees (the tree as exported with --format btcpp, "
        "loaded by py_trees' BT.CPP-XML reader) or BehaviorTree.CPP itself (behaviortreepy; the tree as "
        "exported with --format btcpp-named); hbtp's executor applies the actions and the disturbances.",
    ),
    click.option(
        "--action-ticks",
        type=click.IntRange(1),
        default=1,
        show_default=True,
        help="Ticks each action runs before its effects apply; an action the tree stops ticking before then "
        "is halted (and has no effect).",
    ),
    click.option(
        "--tick-hz",
        type=float,
        callback=_tick_rate,
        help=f"Tick at most this many times a second (0 < F <= {MAX_TICK_HZ:g}), sleeping between ticks "
        "(default: as fast as possible).",
    ),
    click.option(
        "--groot",
        type=click.IntRange(1, 65535),
        help="With --engine btcpp: publish the running tree (each tree, with --replan) to Groot2 on this port "
        "(Groot2's default: 1667; it also uses the next port).",
    ),
    click.option(
        "--groot-wait",
        type=float,
        default=0.0,
        callback=_groot_wait,
        help="With --groot: seconds to wait for Groot2 to connect before the first tick (the whole time: "
        "BT.CPP's binding cannot tell when a client connects).",
    ),
    output_option(
        "--btlog",
        help="With --engine btcpp (one run): write BehaviorTree.CPP's FileLogger2 log, which Groot2 replays "
        "(with --replan, each later tree to FILE with .1, .2, ... before its suffix).",
    ),
    output_option("--trace", "trace_file", help="Write a tick-by-tick JSONL trace."),
    click.option("--json", "as_json", is_flag=True, help="Print the result as JSON."),
)


@click.command("run")
@click.argument("tree_file", type=click.Path(dir_okay=False))
@scenario_options
@click.option("-g", "--goal", "goal_option", help="Goal to reach (default: the goal stored in the tree file).")
@run_options
@exit_codes
def run_command(tree_file: str, source: ScenarioSource, goal_option: str | None, request: RunRequest) -> int:
    """Run the tree of TREE_FILE from s0 (with random external events under --perturb).

    Exit code 0 when the goal was reached (in every run), 1 when not, 2 on bad input. Without a goal
    (none given, none in the file) a run succeeds when the root returns SUCCESS.
    """
    _check_options(request.perturb, request.runs, request.max_ticks)
    read = load_tree_input(tree_file, source, goal_option)
    watched = request.groot is not None or request.btlog
    if watched and request.engine is not Engine.BTCPP:
        raise InputError("--groot and --btlog watch BehaviorTree.CPP: give --engine btcpp")
    if request.groot_wait and request.groot is None:
        raise InputError("--groot-wait waits for Groot2: give --groot PORT")
    if request.btlog and (request.perturb > 0 or request.replan) and request.runs > 1:
        raise InputError("--btlog logs one run: give --runs 1")
    request.engine.require()
    if request.replan:
        return _run_replanning(read, tree_file, request)
    return _run_tree(read, tree_file, request)


#: One run of the tree: ``(disturbance, trace, log) -> Run`` (``log``: write --btlog of this run).
Runner = Callable[[Disturbance | None, bool, bool], Run]


def _runner(read: TreeInput, request: RunRequest) -> Runner:
    """Runs of the tree ticked by ``--engine`` in hbtp's executor (with BT.CPP: watched by --groot,
    logged by --btlog)."""
    task, max_ticks, live = read.scenario.task, request.max_ticks, request.live
    if request.engine is Engine.BTCPP:
        engine = BtcppEngine(read.tree, task)
        started: list[bool] = []

        def btcpp(disturbance: Disturbance | None, trace: bool, log: bool) -> Run:
            watch = request.watch(log=log, first=not started)
            started.append(True)
            return engine.run(max_ticks=max_ticks, disturbance=disturbance, watch=watch, trace=trace, live=live)

        return btcpp
    policy = request.engine.policy(read.tree, task)

    def run(disturbance: Disturbance | None, trace: bool, log: bool) -> Run:
        try:
            return simulate(
                read.tree, task, max_ticks=max_ticks, disturbance=disturbance, trace=trace, policy=policy, live=live
            )
        finally:
            policy.halt()  # the run ends (also on Ctrl-C): an action still running is halted

    return run


def _run_tree(read: TreeInput, tree_file: str, request: RunRequest) -> int:
    """The tree ticked by ``--engine``: once, or ``--runs`` times under ``--perturb``."""
    task, perturb, trace_file, engine = read.scenario.task, request.perturb, request.trace_file, request.engine
    goal_ids: GoalIds = read.goal if read.goal is not None else frozenset()
    run = _runner(read, request)
    base = run(None, trace_file is not None and perturb == 0, perturb == 0)
    header: dict[str, Any] = {
        "tree": tree_file,
        "scenario": read.scenario.name,
        "goal": goal_text(read.goal) if read.goal is not None else None,
        "engine": engine.value,
    }
    prefix = "" if engine is Engine.HBTP else f"{engine.label}: "
    if perturb == 0:
        reached = base.reached(goal_ids)
        _write_traces(trace_file, [base], task, numbered=False)
        if request.as_json:
            echo_json({**header, "reached": reached, **base.to_dict(task)})
        else:
            click.echo(prefix + _describe_run(base, reached))
            click.echo("executes: " + abbreviate_steps([task.actions[i].name for i in base.executed]))
        return EXIT_OK if reached else EXIT_FAILED
    disturbances = seeded_disturbances(task, read.scenario.mutexes, perturb, request.runs, request.seed)
    results = [run(disturbance, trace_file is not None, True) for disturbance in disturbances]
    stats = {**summarise_runs(base, results, goal_ids), "halts": sum(r.halts for r in results)}
    _write_traces(trace_file, results, task, numbered=True)
    if request.as_json:
        rows = [{"reached": r.reached(goal_ids), **r.to_dict(task)} for r in results]
        settings = {"p": perturb, "seed": request.seed, "reached": stats["successes"] == len(results)}
        echo_json({**header, **settings, **stats, "base": base.to_dict(task), "results": rows})
    else:
        if prefix:
            click.echo(prefix.rstrip(" "))
        _echo_disturbed(stats, base.reached(goal_ids), base, perturb, request.seed)
    return EXIT_OK if stats["successes"] == len(results) else EXIT_FAILED


def _run_replanning(read: TreeInput, tree_file: str, request: RunRequest) -> int:
    """``hbtp run --replan N``: every run re-plans (at most N times) when the tree has no answer."""
    perturb, runs, seed, max_ticks = request.perturb, request.runs, request.seed, request.max_ticks
    replan, trace_file, engine = request.replan, request.trace_file, request.engine
    if read.goal is None:
        raise InputError("--replan needs a goal to plan for: give -g, or a tree file that records one")
    task, goal = read.scenario.task, read.goal
    undisturbed = engine.policy(read.tree, task)
    try:  # the yardstick of the runs' extra ticks: as many ticks per action, not paced
        base = simulate(
            read.tree, task, max_ticks=max_ticks, policy=undisturbed, live=LiveOptions(request.action_ticks)
        )
    finally:
        undisturbed.halt()
    # The runs share one kept search (as replanning_runs does): a re-plan continues the runs' before it.
    # The hints the file records were for its own goal: another goal (-g) re-plans in the full space.
    own = read.file.hints is not None and read.file.resolve_goal(task) == goal
    hints = read.file.hints if own and not request.replan_full_space else None
    options = ReplanOptions(max_replans=replan, engine=engine, kept=KeptSearch(), hints=hints)
    results = [
        run_replanning(
            read.scenario, goal, read.tree, max_ticks=max_ticks, disturbance=disturbance, options=options,
            trace=trace_file is not None, live=request.live, watch=request.watch(first=index == 0),
        )
        for index, disturbance in enumerate(seeded_disturbances(task, read.scenario.mutexes, perturb, runs, seed))
    ]  # fmt: skip
    stats = {**replanning_summary(base, results, goal), "halts": sum(r.run.halts for r in results)}
    if trace_file:
        text = "".join(replanning_trace_jsonl(r, task, run_index=i) for i, r in enumerate(results))
        write_all_atomically({Path(trace_file): text})
    reached = stats["successes"] == len(results)
    if request.as_json:
        _echo_replanning_json(read, tree_file, request, stats, results)
    else:
        if engine is not Engine.HBTP:
            click.echo(f"{engine.label}:")
        _echo_disturbed(stats, base.reached(goal), base, perturb, seed)
        median = stats["median_replan_ms"]
        space = f" ({stats['pruned_replans']} in the hints' space)" if hints is not None else ""
        click.echo(
            f"re-plans: {stats['replans']} in all{space}, median {_number(median)} ms; "
            f"{stats['unsolvable_runs']} run(s) ended with the goal unreachable from their state"
        )
        for result in results:
            if result.gave_up is not None:
                click.echo(f"  gave up: {result.gave_up}")
    return EXIT_OK if reached else EXIT_FAILED


def _echo_replanning_json(
    read: TreeInput, tree_file: str, request: RunRequest, stats: dict[str, Any], results: Sequence[ReplanningRun]
) -> None:
    task, goal = read.scenario.task, read.goal
    assert goal is not None, "--replan checked that the run has a goal"
    rows = [
        {"reached": r.reached(goal), **r.run.to_dict(task), "replans": [x.to_dict() for x in r.replans],
         "gave_up": r.gave_up}
        for r in results
    ]  # fmt: skip
    header = {
        "tree": tree_file,
        "scenario": read.scenario.name,
        "goal": goal_text(goal),
        "engine": request.engine.value,
    }
    settings: dict[str, Any] = {"p": request.perturb, "seed": request.seed, "replan": request.replan}
    if request.btlog:  # one run (checked): the log of each tree it ticked
        trees = 1 + sum(r.tree is not None for r in results[0].replans)
        settings["btlog"] = [str(path) for path in btlog_paths(Path(request.btlog), trees)]
    echo_json({**header, **settings, "reached": stats["successes"] == len(results), **stats, "results": rows})


def _check_options(perturb: float, runs: int, max_ticks: int) -> None:
    try:
        check_probability(perturb)
    except InputError as error:
        raise click.BadParameter(str(error), param_hint="--perturb") from None
    if runs < 1:
        raise click.BadParameter("must be at least 1", param_hint="--runs")
    if max_ticks < 1:
        raise click.BadParameter("must be at least 1", param_hint="--max-ticks")


def _write_traces(trace_file: str | None, runs: Sequence[Run], task: GroundTask, *, numbered: bool) -> None:
    """The runs' traces as JSON lines in ``trace_file`` (if given), each line with its run's
    number when ``numbered``."""
    if trace_file:
        text = "".join(trace_to_jsonl(run, task, run_index=i if numbered else None) for i, run in enumerate(runs))
        write_all_atomically({Path(trace_file): text})


def _echo_disturbed(stats: dict[str, Any], base_reached: bool, base: Run, perturb: float, seed: int) -> None:
    click.echo(
        f"{stats['successes']}/{stats['runs']} perturbed run(s) reached the goal (p={perturb}, seed {seed}); "
        f"{_number(stats['mean_events'])} event(s) per run"
        + (f", {stats['halts']} halt(s) in all" if stats["halts"] else "")
    )
    click.echo(
        f"successful runs: mean ticks {_number(stats['mean_ticks'])} ({_number(stats['mean_extra_ticks'], True)}), "
        f"mean cost {_number(stats['mean_cost'])} ({_number(stats['mean_extra_cost'], True)})"
    )
    click.echo(f"undisturbed: {_describe_run(base, base_reached)}")


@click.command("verify")
@click.argument("tree_file", type=click.Path(dir_okay=False))
@scenario_options
@click.option("-g", "--goal", "goal_option", help="Goal (default: the goal stored in the tree file).")
@click.option("--json", "as_json", is_flag=True, help="Print the result as JSON.")
@exit_codes
def verify_command(
    tree_file: str,
    source: ScenarioSource,
    goal_option: str | None,
    as_json: bool,
) -> int:
    """Check the tree of TREE_FILE without running it: guarded actions, goal check, progress.

    Exit code 0 when the tree is proved to reach the goal from the initial state, 1 when not (the
    first node at fault is named; a partial tree fails), 2 on bad input.
    """
    read = load_tree_input(tree_file, source, goal_option)
    loaded, tree, goal = read.scenario, read.tree, read.goal
    if goal is None:
        raise InputError(f"{tree_file}: the tree file states no goal; give one with --goal")
    result = verify(tree, loaded.task, goal, from_initial_state=True)
    if as_json:
        echo_json({"tree": tree_file, "scenario": loaded.name, "goal": goal_text(goal), **result.to_dict()})
    else:
        click.echo(result.summary())
    return EXIT_OK if result.ok else EXIT_FAILED


__all__ = ["InputFailure", "abbreviate_steps", "exit_codes", "run_command", "verify_command"]
