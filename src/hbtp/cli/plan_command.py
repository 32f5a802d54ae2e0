"""``hbtp plan``: plan a behavior tree for a goal."""

from __future__ import annotations

import logging
from dataclasses import dataclass, replace
from pathlib import Path
from typing import cast

import click

from hbtp.bt import render_text, size, tree_of
from hbtp.bt.compact import compact
from hbtp.bt.export import export_tree, format_from_extension
from hbtp.bt.jsonio import goal_text, tree_to_json
from hbtp.bt.treefile import pddl_record
from hbtp.cli.export_command import export_options
from hbtp.cli.goal_input import GOAL_HELP, read_goal
from hbtp.cli.hints_file import load_hints
from hbtp.cli.options import (
    ScenarioSource,
    backend_options,
    echo_json,
    scenario_options,
)
from hbtp.cli.tree_input import pddl_files
from hbtp.domains import Scenario
from hbtp.errors import InputError
from hbtp.files import write_all_atomically
from hbtp.llm.backends.registry import BackendOptions, make_backend
from hbtp.llm.pool import example_pool
from hbtp.llm.prompt import RETRIEVALS, PromptOptions
from hbtp.logic.task import Goal
from hbtp.pipeline import LoopOptions, LoopResult, run_hbtp
from hbtp.planning import PLANNER_DESCRIPTIONS, PLANNERS, Limits, plan
from hbtp.planning.heuristics import HEURISTICS, HeuristicName
from hbtp.planning.planners import check_alpha
from hbtp.planning.result import PlanResult

log = logging.getLogger(__name__)


@click.command("plan")
@scenario_options
@click.option("-g", "--goal", required=True, help=GOAL_HELP)
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
@click.option("--alpha", type=float, default=10_000, show_default=True, help="HBTP-O discount divisor, from 1 to 10^9.")
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
@click.option(
    "--tree",
    "tree_kind",
    type=click.Choice(["full", "path"]),
    default="full",
    show_default=True,
    help="full: every explored condition (acts from more states); path: only the solution path.",
)
@click.option("--compact", is_flag=True, help="Merge conditions shared by adjacent branches (same behaviour).")
@click.option("-o", "--out", "out_file", type=click.Path(dir_okay=False), help="Write the tree as JSON.")
@click.option("--partial", is_flag=True, help="When not solved, still write the partial tree (-o, --export).")
@export_options
@click.option("--json", "as_json", is_flag=True, help="Print the result as JSON instead of the tree.")
@click.option("--max-branches", type=int, default=40, show_default=True, help="Branches shown in the terminal.")
@click.option("--llm", "llm_spec", help="Ask an LLM for hints: local, openai, oracle, noisy-oracle or replay:FILE.")
@backend_options
@click.option(
    "--feedback-rounds",
    type=click.IntRange(0, 10),
    default=3,
    show_default=True,
    help="With --llm: rounds that ask again, with the failed search as feedback, before the fallback.",
)
@click.option(
    "--grammar-retries",
    type=click.IntRange(0, 10),
    default=2,
    show_default=True,
    help="With --llm: times a reply that breaks the answer grammar is sent back for repair.",
)
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
@click.option(
    "--seed", type=int, default=0, show_default=True, help="Seed of the LLM backend (sampling, noisy-oracle)."
)
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
    partial: bool,
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
    # One deadline for the whole command: loading, grounding, heuristic set-up and every search.
    limits = Limits(time_s=time_limit, max_expansions=max_expansions, memory_mb=memory_mb).starting_now()
    loaded = source.load(deadline=limits.deadline)
    task = loaded.task
    resolved = task.resolve_goal(read_goal(goal))
    check_alpha(alpha)
    outputs = Outputs(tree_kind, compact, out_file, export_file, export_format, partial, source, as_json, max_branches)
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
            time_limit=time_limit,  # -t bounds the whole loop: LLM calls, rounds and the fallback
        )
        try:
            loop = run_hbtp(loaded, resolved, llm, example_pool(loaded, examples_from), options)
        finally:
            llm.close()
        return _report(loop.result, loaded, resolved, outputs, "llm", loop)
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
    return _report(result, loaded, resolved, outputs, hints_label, None)


@dataclass(frozen=True)
class Outputs:
    """What ``hbtp plan`` shows and writes: the tree's shape, the files, the terminal or JSON output."""

    tree_kind: str
    compact: bool
    out_file: str | None
    export_file: str | None
    export_format: str | None
    partial: bool  # write the tree of an unsolved run too
    source: ScenarioSource  # recorded in the tree file so that run/verify can reload the scenario
    as_json: bool
    max_branches: int


def _report(
    result: PlanResult,
    loaded: Scenario,
    resolved: Goal,
    outputs: Outputs,
    hints_label: str,
    loop: LoopResult | None,
) -> int:
    task = loaded.task
    out_file, export_file, export_format = outputs.out_file, outputs.export_file, outputs.export_format
    tree_kind = outputs.tree_kind
    tree = tree_of(result, tree_kind) if result.expansions and (result.solved or tree_kind == "full") else None
    if tree is not None and outputs.compact:
        tree = compact(tree)
    targets = [name for name in (out_file, export_file) if name]
    if targets and not result.solved and (tree is None or not outputs.partial):
        hint = " (give --partial to write the partial tree)" if tree is not None else ""
        log.warning("not solved: nothing written to %s%s", ", ".join(targets), hint)
    elif targets and tree is not None:
        if not result.solved:
            log.warning(
                "not solved: writing the partial tree to %s; it does not reach the goal from the initial state",
                ", ".join(targets),
            )
        files: dict[Path, str | bytes] = {}  # written all together or not at all
        if export_file:
            chosen = export_format or format_from_extension(export_file)
            files[Path(export_file)] = export_tree(tree, task, chosen, scenario=loaded.name, goal=goal_text(resolved))
        if out_file:
            files[Path(out_file)] = tree_to_json(
                tree,
                task,
                scenario=loaded.name,
                goal=resolved,
                complete=result.solved,
                pddl=pddl_record(pddl_files(outputs.source), out_file),
            )
        write_all_atomically(files)
    if outputs.as_json:
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
            click.echo(render_text(tree, task, max_children=outputs.max_branches))
    return 0 if result.solved else 1
