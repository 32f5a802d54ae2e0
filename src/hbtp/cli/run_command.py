"""``hbtp run`` and ``hbtp verify``: simulate or statically check a tree written by ``hbtp plan -o``.

Exit codes (also when the commands are invoked on their own, as click commands): 0 the goal was
reached (every run, with ``--runs``) / the verifier found no problem; 1 it was not / it found one;
2 bad input (a file that is not JSON or not a tree, an unknown node type, literal or action, a
probability outside [0, 1]).
"""

from __future__ import annotations

import functools
import logging
from collections.abc import Callable
from pathlib import Path
from typing import Any, TypeVar

import click

from hbtp.bt.disturb import check_probability, disturbed_runs, summarise_runs
from hbtp.bt.jsonio import tree_from_json
from hbtp.bt.nodes import Node
from hbtp.bt.simulate import DEFAULT_MAX_TICKS, Run, simulate, trace_to_jsonl
from hbtp.bt.verify import verify
from hbtp.cli.options import ScenarioSource, echo_json, scenario_options, write_files_atomically
from hbtp.domains import Scenario
from hbtp.errors import HbtpError, InputError
from hbtp.logic.task import Goal

log = logging.getLogger(__name__)

F = TypeVar("F", bound=Callable[..., Any])

EXIT_OK, EXIT_FAILED, EXIT_INPUT = 0, 1, 2


class InputFailure(click.ClickException):
    """Bad input, reported in one line with exit code 2."""

    exit_code = EXIT_INPUT


def exit_codes(function: F) -> F:
    """Turn hbtp's input errors into exit code 2 and the command's returned code into its exit
    code, both under ``hbtp`` and when the command is invoked alone (``CliRunner``)."""

    @functools.wraps(function)
    def wrapper(*args: Any, **kwargs: Any) -> Any:
        try:
            code = function(*args, **kwargs)
        except InputError as error:
            raise InputFailure(str(error)) from None
        except HbtpError as error:
            raise click.ClickException(str(error)) from None
        raise click.exceptions.Exit(int(code))

    return wrapper  # type: ignore[return-value]


def load_tree(path: str, loaded: Scenario, goal_text: str | None) -> tuple[Node, Goal | None]:
    """The tree of a JSON file and its goal (``goal_text``, else the file's, else ``None``)."""
    try:
        text = Path(path).read_text(encoding="utf-8")
    except OSError as error:
        raise InputError(f"{path}: cannot read the tree: {error.strerror}") from None
    except UnicodeDecodeError:
        raise InputError(f"{path}: not a text file") from None
    tree, meta = tree_from_json(text, loaded.task, source=path)
    stored = meta.get("scenario")
    if isinstance(stored, str) and stored and stored != loaded.name:
        log.warning("%s was written for scenario %r, read with %r", path, stored, loaded.name)
    goal_source = goal_text if goal_text else meta.get("goal")
    if goal_source is not None and not isinstance(goal_source, str):
        raise InputError(f"{path}: the goal must be a string")
    goal = loaded.task.resolve_goal(goal_source) if goal_source else None
    return tree, goal


def _describe_run(run: Run, reached: bool) -> str:
    outcome = (
        "goal reached" if reached else ("tick limit" if run.hit_limit else f"{run.status.value}, goal not reached")
    )
    return f"{outcome}: {run.ticks} tick(s), cost {run.cost}, {len(run.executed)} action(s)"


def _number(value: Any, sign: bool = False) -> str:
    if value is None:
        return "-"
    return f"{value:+.2f}" if sign else f"{value:.2f}"


@click.command("run")
@click.argument("tree_file", type=click.Path(dir_okay=False))
@scenario_options
@click.option("-g", "--goal", "goal_text", help="Goal to reach (default: the goal stored in the tree file).")
@click.option("--perturb", type=float, default=0.0, show_default=True, help="Probability of an event before each tick.")
@click.option("--runs", type=int, default=1, show_default=True, help="Perturbed runs (with --perturb).")
@click.option("--seed", type=int, default=0, show_default=True, help="Seed of the perturbations.")
@click.option("--max-ticks", type=int, default=DEFAULT_MAX_TICKS, show_default=True, help="Give up after this many.")
@click.option("--trace", "trace_file", type=click.Path(dir_okay=False), help="Write a tick-by-tick JSONL trace.")
@click.option("--json", "as_json", is_flag=True, help="Print the result as JSON.")
@exit_codes
def run_command(
    tree_file: str,
    source: ScenarioSource,
    goal_text: str | None,
    perturb: float,
    runs: int,
    seed: int,
    max_ticks: int,
    trace_file: str | None,
    as_json: bool,
) -> int:
    """Run the tree of TREE_FILE from s0 (with random external events under --perturb).

    Exit code 0 when the goal was reached (in every run), 1 when not, 2 on bad input. Without a goal
    (none given, none in the file) a run succeeds when the root returns SUCCESS.
    """
    try:
        check_probability(perturb)
    except InputError as error:
        raise click.BadParameter(str(error), param_hint="--perturb") from None
    if runs < 1:
        raise click.BadParameter("must be at least 1", param_hint="--runs")
    if max_ticks < 1:
        raise click.BadParameter("must be at least 1", param_hint="--max-ticks")
    loaded = source.load()
    task = loaded.task
    tree, goal = load_tree(tree_file, loaded, goal_text)
    goal_ids = goal.ids if goal is not None else frozenset()
    trace = trace_file is not None
    base = simulate(tree, task, max_ticks=max_ticks, trace=trace and perturb == 0)
    header: dict[str, Any] = {
        "tree": tree_file,
        "scenario": loaded.name,
        "goal": str(goal) if goal is not None else None,
    }
    if perturb == 0:
        reached = base.reached(goal_ids)
        if trace_file:
            write_files_atomically({Path(trace_file): trace_to_jsonl(base, task)})
        if as_json:
            echo_json({**header, "reached": reached, **base.to_dict(task)})
        else:
            click.echo(_describe_run(base, reached))
            click.echo("executes: " + (" -> ".join(task.actions[i].name for i in base.executed) or "(nothing)"))
        return EXIT_OK if reached else EXIT_FAILED
    results = disturbed_runs(tree, task, loaded.mutexes, perturb, runs, seed, max_ticks=max_ticks, trace=trace)
    stats = summarise_runs(base, results, goal_ids)
    every = stats["successes"] == len(results)
    if trace_file:
        text = "".join(trace_to_jsonl(run, task, run_index=i) for i, run in enumerate(results))
        write_files_atomically({Path(trace_file): text})
    if as_json:
        echo_json(
            {
                **header,
                "p": perturb,
                "seed": seed,
                "reached": every,
                **stats,
                "base": base.to_dict(task),
                "results": [{"reached": r.reached(goal_ids), **r.to_dict(task)} for r in results],
            }
        )
    else:
        click.echo(
            f"{stats['successes']}/{len(results)} perturbed run(s) reached the goal (p={perturb}, seed {seed}); "
            f"{_number(stats['mean_events'])} event(s) per run"
        )
        click.echo(
            f"successful runs: mean ticks {_number(stats['mean_ticks'])} ({_number(stats['mean_extra_ticks'], True)}), "
            f"mean cost {_number(stats['mean_cost'])} ({_number(stats['mean_extra_cost'], True)})"
        )
        click.echo(f"undisturbed: {_describe_run(base, base.reached(goal_ids))}")
    return EXIT_OK if every else EXIT_FAILED


@click.command("verify")
@click.argument("tree_file", type=click.Path(dir_okay=False))
@scenario_options
@click.option("-g", "--goal", "goal_text", help="Goal (default: the goal stored in the tree file).")
@click.option("--json", "as_json", is_flag=True, help="Print the result as JSON.")
@exit_codes
def verify_command(
    tree_file: str,
    source: ScenarioSource,
    goal_text: str | None,
    as_json: bool,
) -> int:
    """Check the tree of TREE_FILE without running it: guarded actions, goal check, progress.

    Exit code 0 when no problem is found, 1 when one is (the first node at fault is named), 2 on
    bad input.
    """
    loaded = source.load()
    tree, goal = load_tree(tree_file, loaded, goal_text)
    if goal is None:
        raise InputError(f"{tree_file}: the tree file states no goal; give one with --goal")
    result = verify(tree, loaded.task, goal.ids)
    if as_json:
        echo_json({"tree": tree_file, "scenario": loaded.name, "goal": str(goal), **result.to_dict()})
    else:
        click.echo(result.summary())
    return EXIT_OK if result.ok else EXIT_FAILED


__all__ = ["InputFailure", "exit_codes", "load_tree", "run_command", "verify_command"]
