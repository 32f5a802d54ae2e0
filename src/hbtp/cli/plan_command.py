"""``hbtp plan``: plan a behavior tree for a goal."""

from __future__ import annotations

import logging
import sys
from dataclasses import dataclass, replace
from pathlib import Path
from typing import Any, cast

import click

from hbtp.bt import Node, render_text, size, tree_of
from hbtp.bt.compact import compact
from hbtp.bt.export import export_tree, format_from_extension
from hbtp.bt.jsonio import goal_text, tree_to_json
from hbtp.bt.treefile import pddl_record
from hbtp.cli.exit_codes import plan_exit_code
from hbtp.cli.export_command import export_options
from hbtp.cli.goal_input import GOAL_HELP, read_goal
from hbtp.cli.hints_file import load_hints
from hbtp.cli.instruction_input import INSTRUCTION_HELP, choose_goal
from hbtp.cli.options import (
    ScenarioSource,
    backend_options,
    echo_json,
    examples_option,
    feedback_rounds_option,
    option_group,
    output_option,
    retrieval_option,
    round_time_limit_option,
    scenario_options,
    time_limit_option,
)
from hbtp.cli.tree_input import pddl_files
from hbtp.domains import Scenario
from hbtp.errors import InputError
from hbtp.files import write_all_atomically
from hbtp.llm.backend import Backend
from hbtp.llm.backends.local import LocalBackend
from hbtp.llm.backends.registry import BackendOptions, auto_backend, make_backend
from hbtp.llm.pool import example_pool
from hbtp.llm.prompt import PromptOptions
from hbtp.logic.task import Goal
from hbtp.memory import memory_cap
from hbtp.pipeline import DEFAULT_PROBE_SECONDS, AutoResult, LoopOptions, LoopResult, plan_auto, run_hbtp
from hbtp.pipeline.instruct import GoalChoice
from hbtp.pipeline.loop import Progress
from hbtp.planning import PLANNER_DESCRIPTIONS, PLANNERS, Limits, plan
from hbtp.planning.heuristics import DEFAULT_HEURISTIC, HEURISTICS, HeuristicName
from hbtp.planning.planners import check_alpha, planner_config
from hbtp.planning.result import PlanResult, Status

log = logging.getLogger(__name__)


@dataclass(frozen=True)
class SearchRequest:
    """How to search: the planner, its hints, action space, heuristic and limits."""

    planner: str
    hints_source: str  # none, oracle, or a file
    space: str | None  # None: pruned with hints, else full
    heuristic: str
    alpha: float
    time_limit: float
    max_expansions: int | None
    extra_expansions: int
    memory_mb: float | None
    symmetry: bool

    def limits(self) -> Limits:
        return Limits(time_s=self.time_limit, max_expansions=self.max_expansions, memory_mb=self.memory_mb)


search_options = option_group(
    "search",
    SearchRequest,
    click.option(
        "-p",
        "--planner",
        type=click.Choice(list(PLANNERS)),
        default="hbtp-s",
        show_default=True,
        help="; ".join(f"{name}: {text}" for name, text in PLANNER_DESCRIPTIONS.items()),
    ),
    click.option(
        "--hints",
        "hints_source",
        default="none",
        show_default=True,
        help="none, oracle, or a record/LLM-reply file.",
    ),
    click.option("--space", type=click.Choice(["full", "pruned"]), help="Action space (default: pruned with hints)."),
    click.option(
        "--heuristic",
        type=click.Choice(list(HEURISTICS)),
        default=DEFAULT_HEURISTIC,
        show_default=True,
        help="LLM-free admissible heuristic: lm (landmarks, max with hmax), lmcut (also h² and LM-cut: stronger, "
        "costlier; for IPC-style PDDL domains), seq (lmcut and the state equation: counts, prunes conditions no "
        "state can hold; lp extra), hmax, or none (the paper's planners).",
    ),
    click.option(
        "--alpha", type=float, default=10_000, show_default=True, help="HBTP-O discount divisor, from 1 to 10^9."
    ),
    time_limit_option,
    click.option("--max-expansions", type=int, help="Stop after this many expanded conditions."),
    click.option(
        "--robust",
        "extra_expansions",
        type=click.IntRange(0),
        default=0,
        show_default=True,
        help="Explore N more conditions after the solution: a larger tree that recovers from more disturbances.",
    ),
    click.option("--memory-mb", type=float, help="Stop when the process grows beyond this size."),
    click.option(
        "--symmetry",
        is_flag=True,
        help="Prune conditions symmetric to explored ones (interchangeable objects, e.g. gripper's balls): "
        "still optimal, far faster on such tasks, but a smaller tree that reacts to fewer disturbances. "
        "Without --llm only.",
    ),
)


@dataclass(frozen=True)
class Outputs:
    """What ``hbtp plan`` shows and writes: the tree's shape, the files, the terminal or JSON output."""

    tree_kind: str
    compact: bool
    out_file: str | None
    partial: bool  # write the tree of an unsolved run too
    export_file: str | None
    export_format: str | None
    as_json: bool
    max_branches: int


output_options = option_group(
    "outputs",
    Outputs,
    click.option(
        "--tree",
        "tree_kind",
        type=click.Choice(["full", "path"]),
        default="full",
        show_default=True,
        help="full: every explored condition (acts from more states); path: only the solution path.",
    ),
    click.option("--compact", is_flag=True, help="Merge conditions shared by adjacent branches (same behaviour)."),
    output_option("-o", "--out", "out_file", help="Write the tree as JSON."),
    click.option("--partial", is_flag=True, help="When not solved, still write the partial tree (-o, --export)."),
    export_options,
    click.option("--json", "as_json", is_flag=True, help="Print the result as JSON instead of the tree."),
    click.option("--max-branches", type=int, default=40, show_default=True, help="Branches shown in the terminal."),
)


#: Backends whose answers come from an optimal plan of the whole world.
ORACLE_SPECS = ("oracle", "noisy-oracle")


@dataclass(frozen=True)
class LlmRequest:
    """The LLM loop's options; ``llm_spec`` ``None``: no LLM (plan once, with ``--hints``)."""

    llm_spec: str | None
    backend: BackendOptions
    feedback_rounds: int
    grammar_retries: int
    examples: int
    examples_from: str | None
    retrieval: str
    round_time_limit: float
    no_fallback: bool
    seed: int
    record: str | None
    auto_probe: float
    grounding: str | None

    def pruned(self, source: ScenarioSource) -> bool:
        """Whether the loop prunes the world before grounding it: ``--grounding``, by default for a
        --pddl world with a model backend (the oracles plan in the whole world anyway)."""
        if self.grounding is not None:
            return self.grounding == "pruned"
        spec = self.llm_spec or ""
        return source.pddl is not None and spec not in ORACLE_SPECS and auto_backend(spec) is None

    def loop_options(self, search: SearchRequest, progress: Progress | None = None) -> LoopOptions:
        return LoopOptions(
            planner=search.planner,
            feedback_rounds=self.feedback_rounds,
            grammar_retries=self.grammar_retries,
            round_time_limit=self.round_time_limit,
            fallback=not self.no_fallback,
            fallback_time_limit=search.time_limit,
            fallback_heuristic=cast(HeuristicName, search.heuristic),
            prompt=PromptOptions(examples=self.examples, retrieval=self.retrieval),
            time_limit=search.time_limit,  # -t bounds the whole loop: LLM calls, rounds and the fallback
            progress=progress,
        )


llm_options = option_group(
    "llm",
    LlmRequest,
    click.option(
        "--llm",
        "llm_spec",
        help="Ask an LLM for hints: local, openai, oracle, noisy-oracle or replay:FILE; auto:BACKEND (auto: "
        "auto:local) plans LLM-free first and asks BACKEND only when that finds no verdict in --auto-probe seconds.",
    ),
    backend_options,
    feedback_rounds_option(
        "With --llm: rounds that ask again, with the failed search as feedback, before the fallback."
    ),
    click.option(
        "--grammar-retries",
        type=click.IntRange(0, 10),
        default=2,
        show_default=True,
        help="With --llm: times a reply that breaks the answer grammar is sent back for repair.",
    ),
    examples_option,
    click.option("--examples-from", type=click.Path(dir_okay=False), help="Your own example pool (dataset file)."),
    retrieval_option,
    round_time_limit_option,
    click.option("--no-fallback", is_flag=True, help="Do not plan in the full space after the last round."),
    click.option(
        "--seed", type=int, default=0, show_default=True, help="Seed of the LLM backend (sampling, noisy-oracle)."
    ),
    output_option("--record", help="Record every LLM exchange to this JSONL file."),
    click.option(
        "--grounding",
        type=click.Choice(["full", "pruned"]),
        help="With --llm: ground the whole world first (full), or only the space the LLM's hints name, "
        "the whole world only if the fallback needs it (pruned). Default: pruned for --pddl with a model "
        "backend (local, openai, replay), else full.",
    ),
    click.option(
        "--auto-probe",
        type=click.FloatRange(min=0, min_open=True, max=1e9),
        default=DEFAULT_PROBE_SECONDS,
        show_default=True,
        help="With --llm auto:BACKEND: seconds of LLM-free planning before the LLM is asked (about one model call).",
    ),
)


@dataclass(frozen=True)
class PlanRequest:
    """Everything ``hbtp plan`` was asked to do."""

    source: ScenarioSource
    goal: str | None  # None: the --pddl problem's :goal
    search: SearchRequest
    outputs: Outputs
    llm: LlmRequest
    instruction: str | None = None  # --instruction: the goal comes from the LLM
    chosen: GoalChoice | None = None  # what the LLM made of the instruction


@click.command("plan")
@scenario_options
@click.option("-g", "--goal", help=GOAL_HELP + " Default: the --pddl problem's :goal.")
@click.option("-i", "--instruction", help=INSTRUCTION_HELP)
@search_options
@output_options
@llm_options
def plan_command(
    source: ScenarioSource,
    goal: str | None,
    instruction: str | None,
    search: SearchRequest,
    outputs: Outputs,
    llm: LlmRequest,
) -> int:
    """Plan a behavior tree that reaches GOAL; exit code 0 when solved, 1 when not."""
    with memory_cap(search.memory_mb):  # bounds the whole command, from its start
        return run_plan(PlanRequest(source, goal, search, outputs, llm, instruction))


def run_plan(request: PlanRequest) -> int:
    """Plan as ``request`` says, report, and return the exit code."""
    search = request.search
    # One deadline for the whole command: loading, grounding, heuristic set-up and every search.
    limits = search.limits().starting_now()
    if request.instruction is not None:
        request = _goal_of_instruction(request, limits)
    spec = request.llm.llm_spec
    if spec is not None and request.llm.pruned(request.source):
        return _run_pruned(spec, request, limits)
    loaded = request.source.load(deadline=limits.deadline)
    goal_source = read_goal(request.goal) if request.goal is not None else loaded.problem_goal()
    loaded, goal = loaded.resolve_goal(goal_source)
    check_alpha(search.alpha)
    report = _Report(loaded, goal, request)
    if spec is not None and search.symmetry:
        raise InputError("--symmetry applies to planning without an LLM (drop --llm or --symmetry)")
    if spec is not None and auto_backend(spec) is not None:
        auto = _run_auto(spec, request, loaded, goal, limits)
        return report.finish(auto.result, "llm" if auto.asked_llm else "none", auto.loop, auto)
    if spec is not None:
        loop = _run_llm(spec, request, loaded, goal)
        return report.finish(loop.result, "llm", loop)
    hints = load_hints(search.hints_source, loaded, goal, limits)
    if hints is None:  # hints name actions of the whole grounding; a search without them needs fewer
        loaded = loaded.for_goal(goal)
        report = _Report(loaded, goal, request)
    space = search.space or ("pruned" if hints is not None else "full")
    config = planner_config(
        search.planner, heuristic=cast(HeuristicName, search.heuristic), alpha=search.alpha, symmetry=search.symmetry
    )
    result = plan(
        loaded.task,
        goal,
        config,
        hints=hints,
        space="pruned" if space == "pruned" else "full",
        mutexes=loaded.mutexes,
        limits=limits,
        extra_expansions=search.extra_expansions,
    )
    hints_label = search.hints_source if search.hints_source in ("none", "oracle") else "file"
    return report.finish(result, hints_label, None)


def _goal_of_instruction(request: PlanRequest, limits: Limits) -> PlanRequest:
    """``request`` with the goal the LLM made of its instruction (see :mod:`hbtp.cli.instruction_input`)."""
    if request.goal is not None:
        raise InputError("give the goal (-g) or an instruction (--instruction), not both")
    options = request.llm
    loaded = request.source.load(deadline=limits.deadline)
    backend = replace(options.backend, seed=options.seed, record=options.record)
    choice = choose_goal(
        loaded, request.instruction or "", options.llm_spec, backend, rounds=options.feedback_rounds,
        as_json=request.outputs.as_json,
    )  # fmt: skip
    return replace(request, goal=choice.goal, chosen=choice)


def _run_llm(spec: str, request: PlanRequest, loaded: Scenario, goal: Goal) -> LoopResult:
    """The HBTP loop with the LLM ``spec``: ask, plan in the pruned space, feed back, fall back."""
    options = request.llm
    _check_llm(request)
    progress = _progress(request.outputs.as_json)
    llm = _backend(spec, request, loaded, progress)
    try:
        pool = example_pool(loaded, options.examples_from)
        return run_hbtp(loaded, goal, llm, pool, options.loop_options(request.search, progress))
    finally:
        llm.close()


def _run_pruned(spec: str, request: PlanRequest, limits: Limits) -> int:
    """The HBTP loop in a world pruned before grounding: its action names listed, each round's space
    grounded alone, the whole world only for the fallback; the tree belongs to the part it came from."""
    if auto_backend(spec) is not None:
        raise InputError("--grounding pruned does not go with --llm auto (its probe plans in the whole world)")
    _check_llm(request)
    world = request.source.load_pruned(deadline=limits.deadline)
    empty = world.part(frozenset(), frozenset())
    goal_source = read_goal(request.goal) if request.goal is not None else empty.problem_goal()
    goal = empty.resolve_goal(goal_source)[1]
    check_alpha(request.search.alpha)
    options = request.llm
    progress = _progress(request.outputs.as_json)
    # An oracle answers from an optimal plan of a whole world of its own (the loop's stays pruned);
    # a model needs no world at all.
    oracle = spec.split(":")[0] in ORACLE_SPECS
    answering = request.source.load(deadline=limits.deadline) if oracle else empty
    llm = _backend(spec, request, answering, progress)
    try:
        pool = example_pool(world, options.examples_from)
        loop_options = options.loop_options(request.search, progress)
        if limits.deadline is not None:  # -t counts from the start of the command (loading included)
            loop_options = replace(loop_options, time_limit=max(limits.deadline.remaining(), 1e-9))
        loop = run_hbtp(world, goal, llm, pool, loop_options)
    finally:
        llm.close()
    grounding = {
        "kind": "pruned",
        "actions": len(world.names.actions),
        "listed_s": round(world.load_seconds, 6),
        "grounded_actions": len(loop.scenario.task.actions),
        "whole_grounded": world.grounded,
    }
    report = _Report(loop.scenario, loop.scenario.resolve_goal(goal)[1], request, grounding)
    return report.finish(loop.result, "llm", loop)


def _run_auto(spec: str, request: PlanRequest, loaded: Scenario, goal: Goal, limits: Limits) -> AutoResult:
    """``--llm auto:BACKEND``: LLM-free for ``--auto-probe`` seconds, then (only then) the HBTP loop
    with BACKEND, all within what is left of ``-t``."""
    options = request.llm
    _check_llm(request)
    inner = auto_backend(spec)
    assert inner is not None
    progress = _progress(request.outputs.as_json)
    loop_options = options.loop_options(request.search, progress)
    if limits.deadline is not None:  # -t counts from the start of the command (loading included)
        loop_options = replace(loop_options, time_limit=max(limits.deadline.remaining(), 0.0))
    return plan_auto(
        loaded,
        goal,
        lambda: _backend(inner, request, loaded, progress),
        lambda: example_pool(loaded, options.examples_from),
        loop_options,
        options.auto_probe,
    )


def _check_llm(request: PlanRequest) -> None:
    if request.search.hints_source != "none":
        raise InputError("use either --llm or --hints, not both")
    if not request.llm.round_time_limit > 0:
        raise InputError(f"--round-time-limit must be positive, not {request.llm.round_time_limit}")


def _backend(spec: str, request: PlanRequest, loaded: Scenario, progress: Progress | None) -> Backend:
    """The backend ``spec`` with the command's options; a local model loaded now when progress is shown."""
    options = request.llm
    llm = make_backend(spec, loaded, replace(options.backend, seed=options.seed, record=options.record))
    if progress is not None:
        try:
            _load(llm, progress)
        except BaseException:
            llm.close()
            raise
    return llm


def _progress(as_json: bool) -> Progress | None:
    """What the LLM loop is doing, on stderr, when stderr is a terminal and the output is not JSON."""
    if as_json or not sys.stderr.isatty():
        return None

    def show(message: str) -> None:
        click.echo(f"hbtp: {message}", err=True)

    return show


def _load(backend: Backend, progress: Progress) -> None:
    """Load a local model now, saying so (it is assembled on first use, then loaded in seconds)."""
    inner = getattr(backend, "inner", backend)  # --record wraps the backend
    if isinstance(inner, LocalBackend) and not inner.loaded:
        progress(f"loading the local model {inner.name} (assembled into the model cache on first use)")
        inner.load()
        progress(f"model loaded in {inner.load_seconds or 0:.1f} s")


@dataclass(frozen=True)
class _Report:
    """Writes, shows and judges the outcome of one ``hbtp plan``."""

    loaded: Scenario
    goal: Goal
    request: PlanRequest
    #: How a world pruned before grounding was grounded (``None``: grounded whole first).
    grounding: dict[str, Any] | None = None

    def finish(
        self, result: PlanResult, hints_label: str, loop: LoopResult | None, auto: AutoResult | None = None
    ) -> int:
        """Write the files, print the result, and return the exit code."""
        outputs = self.request.outputs
        tree = self._tree(result)
        self._write(result, tree)
        if outputs.as_json:
            self._print_json(result, tree, hints_label, loop, auto)
        else:
            if auto is not None:
                click.echo(_auto_summary(auto))
            self._print_text(result, tree, loop)
        return int(plan_exit_code(result.status))

    def _tree(self, result: PlanResult) -> Node | None:
        """The tree to show and write: none for an unsolved search unless the full tree was asked for."""
        outputs = self.request.outputs
        if not result.expansions or not (result.solved or outputs.tree_kind == "full"):
            return None
        tree = tree_of(result, outputs.tree_kind)
        return compact(tree) if outputs.compact else tree

    def _write(self, result: PlanResult, tree: Node | None) -> None:
        """The -o and --export files, all together or none; an unsolved run's tree only with --partial."""
        outputs = self.request.outputs
        targets = [name for name in (outputs.out_file, outputs.export_file) if name]
        if not targets:
            return
        if not result.solved and (tree is None or not outputs.partial):
            hint = " (give --partial to write the partial tree)" if tree is not None else ""
            log.warning("not solved: nothing written to %s%s", ", ".join(targets), hint)
            return
        if tree is None:
            return
        if not result.solved:
            log.warning(
                "not solved: writing the partial tree to %s; it does not reach the goal from the initial state",
                ", ".join(targets),
            )
        write_all_atomically(self._files(result, tree))

    def _files(self, result: PlanResult, tree: Node) -> dict[Path, str | bytes]:
        outputs, task, name = self.request.outputs, self.loaded.task, self.loaded.name
        files: dict[Path, str | bytes] = {}
        if outputs.export_file:
            chosen = outputs.export_format or format_from_extension(outputs.export_file)
            files[Path(outputs.export_file)] = export_tree(tree, task, chosen, scenario=name, goal=goal_text(self.goal))
        if outputs.out_file:
            # the PDDL files are recorded so that run/verify can reload the scenario
            pddl = pddl_record(pddl_files(self.request.source), outputs.out_file, warn=True)
            files[Path(outputs.out_file)] = tree_to_json(
                tree, task, scenario=name, goal=self.goal, complete=result.solved, pddl=pddl
            )
        return files

    def _print_json(
        self, result: PlanResult, tree: Node | None, hints_label: str, loop: LoopResult | None, auto: AutoResult | None
    ) -> None:
        record = result.to_dict(self.loaded.task)
        record["scenario"] = self.loaded.name
        record["hints"] = hints_label
        if tree is not None:
            shape = size(tree)
            record["tree"] = {"kind": self.request.outputs.tree_kind, "nodes": shape.nodes, "depth": shape.depth}
        if loop is not None:
            record["llm"] = loop.to_dict()
        if auto is not None:
            record["auto"] = auto.to_dict()
        if self.grounding is not None:
            record["grounding"] = self.grounding
        if self.request.chosen is not None:
            record["instruction"] = self.request.chosen.to_dict()
        echo_json(record)

    def _print_text(self, result: PlanResult, tree: Node | None, loop: LoopResult | None) -> None:
        task = self.loaded.task
        if self.grounding is not None:
            click.echo(_grounding_summary(self.grounding))
        if loop is not None:
            click.echo(_loop_summary(loop))
        stats = result.stats
        click.echo(
            f"{result.status.value}: D(T)={result.cost}  explored |S-|={stats.explored}  "
            f"generated={stats.generated}  time={stats.time_s * 1000:.1f} ms  |A|={stats.action_space}"
            + (f"  ({result.message})" if result.message else "")
        )
        if result.solved:
            click.echo("executes: " + (" -> ".join(task.actions[i].name for i in result.executed) or "(nothing)"))
        if tree is not None:
            click.echo(render_text(tree, task, max_children=self.request.outputs.max_branches))


def _grounding_summary(grounding: dict[str, Any]) -> str:
    """How a world pruned before grounding was grounded."""
    if grounding["whole_grounded"]:
        whole = "the whole world was grounded (for the fallback or the demonstrations)"
    else:
        whole = "the whole world was not grounded"
    return (
        f"grounding: pruned: the tree's space has {grounding['grounded_actions']} of {grounding['actions']} "
        f"actions (names listed in {grounding['listed_s']:.2f} s); {whole}"
    )


def _auto_summary(auto: AutoResult) -> str:
    """Which path of ``--llm auto`` produced the result."""
    status, budget = auto.probe.status.value, auto.probe_budget_s
    probe = f"auto: LLM-free probe {status} in {auto.probe_s * 1000:.1f} ms (budget {budget:g} s)"
    if auto.asked_llm:
        return probe + "; asked the LLM"
    if auto.probe.status in (Status.SOLVED, Status.UNSOLVABLE):
        return probe + "; the LLM was not asked"
    return probe + "; no time left to ask the LLM"


def _loop_summary(loop: LoopResult) -> str:
    """The LLM loop's outcome, then one line per round."""
    lines = [
        f"LLM: {loop.outcome} after {len(loop.rounds)} round(s), LLM {loop.llm_seconds:.2f} s, "
        f"planning {loop.planning_seconds * 1000:.1f} ms"
    ]
    lines += [
        f"  round {r.round}: {r.status}, |A-|={r.action_space}" + (f", {r.error}" if r.error else "")
        for r in loop.rounds
    ]
    return "\n".join(lines)
