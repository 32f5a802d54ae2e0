"""``hbtp plan``: plan a behavior tree for a goal."""

from __future__ import annotations

from dataclasses import replace
from pathlib import Path
from typing import cast

import click

from hbtp.bt import render_text, size, tree_of
from hbtp.bt.compact import compact
from hbtp.bt.jsonio import tree_to_json
from hbtp.cli.export_command import export_options, write_export
from hbtp.cli.options import (
    ScenarioSource,
    backend_options,
    echo_json,
    scenario_options,
    write_files_atomically,
)
from hbtp.datasets import read_dataset_file
from hbtp.datasets.records import Record
from hbtp.domains import Scenario
from hbtp.errors import DatasetError, InputError
from hbtp.llm.backends.registry import BackendOptions, make_backend
from hbtp.llm.parse import parse_reply
from hbtp.llm.pool import example_pool
from hbtp.llm.prompt import RETRIEVALS, PromptOptions
from hbtp.logic.task import Goal
from hbtp.pipeline import LoopOptions, LoopResult, run_hbtp
from hbtp.planning import PLANNER_DESCRIPTIONS, PLANNERS, Hints, Limits, hints_from_record, plan
from hbtp.planning.heuristics import HEURISTICS, HeuristicName
from hbtp.planning.oracle import oracle_hints
from hbtp.planning.result import PlanResult


def load_hints(source: str, loaded: Scenario, goal: Goal, limits: Limits) -> Hints | None:
    """``none``, ``oracle`` (an optimal plan) or a file: a dataset record or a raw LLM reply."""
    if source == "none":
        return None
    if source == "oracle":
        return oracle_hints(loaded.task, goal, loaded.mutexes, limits)
    path = Path(source)
    try:
        text = path.read_text(encoding="utf-8")
    except OSError as error:
        raise InputError(f"{source}: cannot read hints file: {error.strerror}") from None
    try:
        records = read_dataset_file(path)
    except DatasetError:
        records = []
    if records:
        wanted = goal.ids
        matching = [r for r in records if _goal_ids(loaded, r) == wanted]
        if matching:
            return hints_from_record(matching[0])
        if len(records) == 1:
            return hints_from_record(records[0])
        raise InputError(f"{source}: none of its {len(records)} records has the goal {goal}")
    parsed = parse_reply(text)
    if not parsed.found:
        raise InputError(
            f"{source}: no hints found (expected 'Optimal Actions:' / 'Vital Action Predicates:' / "
            "'Vital Objects:' lines, or 'Heuristic Path:' / 'Relevant ...')"
        )
    return parsed.hints


def _goal_ids(loaded: Scenario, record: Record) -> frozenset[int] | None:
    try:
        return loaded.task.resolve_goal(record.goal).ids
    except InputError:
        return None


@click.command("plan")
@scenario_options
@click.option("-g", "--goal", required=True, help='Goal, e.g. "IsIn_milk_fridge & IsClose_fridge".')
@click.option(
    "-p",
    "--planner",
    type=click.Choice(list(PLANNERS)),
    default="hbtp-s",
    show_default=True,
    help="; ".join(f"{name}: {text}" for name, text in PLANNER_DESCRIPTIONS.items()),
)
@click.option(
    "--hints", "hints_source", default="none", show_default=True, help="none, oracle, or a record/LLM-reply file."
)
@click.option("--space", type=click.Choice(["full", "pruned"]), help="Action space (default: pruned with hints).")
@click.option(
    "--heuristic",
    type=click.Choice(list(HEURISTICS)),
    default="lm",
    show_default=True,
    help="LLM-free admissible heuristic: lm (landmarks, max with hmax), hmax, or none (the paper's planners).",
)
@click.option("--alpha", type=float, default=10_000, show_default=True, help="HBTP-O discount divisor.")
@click.option("-t", "--time-limit", type=float, default=60.0, show_default=True, help="Seconds.")
@click.option("--max-expansions", type=int, help="Stop after this many expanded conditions.")
@click.option(
    "--robust",
    "extra_expansions",
    type=click.IntRange(0),
    default=0,
    show_default=True,
    help="Explore N more conditions after the solution: a larger tree that recovers from more disturbances.",
)
@click.option("--memory-mb", type=float, help="Stop when the process grows beyond this size.")
@click.option("--tree", "tree_kind", type=click.Choice(["full", "path"]), default="full", show_default=True)
@click.option("--compact", is_flag=True, help="Merge conditions shared by adjacent branches (same behaviour).")
@click.option("-o", "--out", "out_file", type=click.Path(dir_okay=False), help="Write the tree as JSON.")
@export_options
@click.option("--json", "as_json", is_flag=True, help="Print the result as JSON instead of the tree.")
@click.option("--max-branches", type=int, default=40, show_default=True, help="Branches shown in the terminal.")
@click.option("--llm", "llm_spec", help="Ask an LLM for hints: local, openai, oracle, noisy-oracle or replay:FILE.")
@backend_options
@click.option("--feedback-rounds", type=click.IntRange(0, 10), default=3, show_default=True)
@click.option("--grammar-retries", type=click.IntRange(0, 10), default=2, show_default=True)
@click.option("--examples", type=click.IntRange(0, 50), default=5, show_default=True, help="Few-shot demonstrations.")
@click.option("--examples-from", type=click.Path(dir_okay=False), help="Your own example pool (dataset file).")
@click.option(
    "--retrieval",
    type=click.Choice(list(RETRIEVALS)),
    default="lexical",
    show_default=True,
    help="How demonstrations are chosen (embeddings: the optional extra).",
)
@click.option("--round-time-limit", type=float, default=5.0, show_default=True, help="Planning seconds per round.")
@click.option("--no-fallback", is_flag=True, help="Do not plan in the full space after the last round.")
@click.option("--seed", type=int, default=0, show_default=True)
@click.option("--record", type=click.Path(dir_okay=False), help="Record every LLM exchange to this JSONL file.")
def plan_command(
    source: ScenarioSource,
    goal: str,
    planner: str,
    hints_source: str,
    space: str | None,
    heuristic: str,
    alpha: float,
    time_limit: float,
    max_expansions: int | None,
    extra_expansions: int,
    memory_mb: float | None,
    tree_kind: str,
    compact: bool,
    out_file: str | None,
    as_json: bool,
    max_branches: int,
    export_file: str | None,
    export_format: str | None,
    llm_spec: str | None,
    backend: BackendOptions,
    feedback_rounds: int,
    grammar_retries: int,
    examples: int,
    examples_from: str | None,
    retrieval: str,
    round_time_limit: float,
    no_fallback: bool,
    seed: int,
    record: str | None,
) -> int:
    """Plan a behavior tree that reaches GOAL; exit code 0 when solved, 1 when not."""
    limits = Limits(time_s=time_limit, max_expansions=max_expansions, memory_mb=memory_mb)
    loaded = source.load()
    task = loaded.task
    resolved = task.resolve_goal(goal)
    loop = None
    if llm_spec is not None:
        if hints_source != "none":
            raise InputError("use either --llm or --hints, not both")
        if not round_time_limit > 0:
            raise InputError(f"--round-time-limit must be positive, not {round_time_limit}")
        llm = make_backend(llm_spec, loaded, replace(backend, seed=seed, record=record))
        options = LoopOptions(
            planner=planner,
            feedback_rounds=feedback_rounds,
            grammar_retries=grammar_retries,
            round_time_limit=round_time_limit,
            fallback=not no_fallback,
            fallback_time_limit=time_limit,
            fallback_heuristic=cast(HeuristicName, heuristic),
            prompt=PromptOptions(
                examples=examples, style="completion" if llm_spec == "local" else "chat", retrieval=retrieval
            ),
        )
        try:
            loop = run_hbtp(loaded, resolved, llm, example_pool(loaded, examples_from), options)
        finally:
            llm.close()
        return _report(
            loop.result, loaded, resolved, (tree_kind, compact), (out_file, export_file, export_format), as_json,
            max_branches,
            "llm", loop,
        )  # fmt: skip
    hints = load_hints(hints_source, loaded, resolved, limits)
    chosen_space = space or ("pruned" if hints is not None else "full")
    result = plan(
        task,
        resolved,
        planner,
        hints=hints,
        space="pruned" if chosen_space == "pruned" else "full",
        mutexes=loaded.mutexes,
        heuristic=cast(HeuristicName, heuristic),
        alpha=int(alpha) if float(alpha).is_integer() else alpha,
        limits=limits,
        extra_expansions=extra_expansions,
    )
    hints_label = hints_source if hints_source in ("none", "oracle") else "file"
    return _report(
        result, loaded, resolved, (tree_kind, compact), (out_file, export_file, export_format), as_json,
        max_branches,
        hints_label, None,
    )  # fmt: skip


def _report(
    result: PlanResult,
    loaded: Scenario,
    resolved: Goal,
    tree_shape: tuple[str, bool],
    outputs: tuple[str | None, str | None, str | None],
    as_json: bool,
    max_branches: int,
    hints_label: str,
    loop: LoopResult | None,
) -> int:
    task = loaded.task
    out_file, export_file, export_format = outputs
    tree_kind, compacted = tree_shape
    tree = tree_of(result, tree_kind) if result.expansions and (result.solved or tree_kind == "full") else None
    if tree is not None and compacted:
        tree = compact(tree)
    if export_file and tree is not None:  # first: a failed export must not leave the JSON written
        write_export(tree, task, export_file, export_format, scenario=loaded.name, goal=str(resolved))
    if out_file and tree is not None:
        write_files_atomically({Path(out_file): tree_to_json(tree, task, scenario=loaded.name, goal=str(resolved))})
    if as_json:
        record = result.to_dict(task)
        record["scenario"] = loaded.name
        record["hints"] = hints_label
        if tree is not None:
            nodes, depth = size(tree)
            record["tree"] = {"kind": tree_kind, "nodes": nodes, "depth": depth}
        if loop is not None:
            record["llm"] = loop.to_dict()
        echo_json(record)
    else:
        if loop is not None:
            click.echo(
                f"LLM: {loop.outcome} after {len(loop.rounds)} round(s), LLM {loop.llm_seconds:.2f} s, "
                f"planning {loop.planning_seconds * 1000:.1f} ms"
                + "".join(
                    f"\n  round {r.round}: {r.status}, |A-|={r.action_space}" + (f", {r.error}" if r.error else "")
                    for r in loop.rounds
                )
            )
        stats = result.stats
        click.echo(
            f"{result.status.value}: D(T)={result.cost}  explored |S-|={stats.explored}  "
            f"generated={stats.generated}  time={stats.time_s * 1000:.1f} ms  |A|={stats.action_space}"
            + (f"  ({result.message})" if result.message else "")
        )
        if result.solved:
            click.echo("executes: " + (" -> ".join(task.actions[i].name for i in result.executed) or "(nothing)"))
        if tree is not None:
            click.echo(render_text(tree, task, max_children=max_branches))
    return 0 if result.solved else 1
