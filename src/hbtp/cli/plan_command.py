"""``hbtp plan``: its options, read once into one typed request (:class:`PlanRequest`).

Every mode is a value from the option callbacks on: ``--llm`` an :class:`~hbtp.llm.backends.registry.LlmSpec`,
``--hints`` a :class:`~hbtp.cli.hints_file.HintsSource`, ``--space`` a
:class:`~hbtp.planning.planners.Space`, ``--grounding`` a :class:`Grounding`, ``--heuristic`` a checked
heuristic name. :func:`hbtp.cli.plan_run.run_plan` does what the request says.
"""

from __future__ import annotations

import enum
import logging
from dataclasses import dataclass, replace

import click

from hbtp.cli.export_command import export_options
from hbtp.cli.goal_input import GOAL_HELP
from hbtp.cli.hints_file import HintsSource
from hbtp.cli.instruction_input import INSTRUCTION_HELP
from hbtp.cli.options import (
    ScenarioSource,
    backend_options,
    examples_option,
    feedback_rounds_option,
    option_group,
    output_option,
    retrieval_option,
    round_time_limit_option,
    scenario_options,
    time_limit_option,
)
from hbtp.llm.backends.registry import BackendOptions, LlmSpec
from hbtp.llm.prompt import PromptOptions, Retrieval
from hbtp.memory import memory_cap
from hbtp.pipeline import DEFAULT_PROBE_SECONDS, LoopOptions
from hbtp.pipeline.loop import Progress
from hbtp.planning import PLANNER_DESCRIPTIONS, PLANNERS, Limits
from hbtp.planning.heuristic_names import DEFAULT_HEURISTIC, HEURISTICS, HeuristicName, heuristic_named
from hbtp.planning.planners import Space

log = logging.getLogger(__name__)


@dataclass(frozen=True)
class SearchRequest:
    """How to search: the planner, its hints, action space, heuristic and limits."""

    planner: str
    hints: HintsSource
    space: Space | None  # None: pruned with hints, else full
    heuristic: HeuristicName
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
        default="none",
        show_default=True,
        callback=lambda _context, _parameter, value: HintsSource.parse(value),
        help="none, oracle, or a record/LLM-reply file.",
    ),
    click.option(
        "--space",
        type=click.Choice([space.value for space in Space]),
        callback=lambda _context, _parameter, value: None if value is None else Space(value),
        help="Action space (default: pruned with hints).",
    ),
    click.option(
        "--heuristic",
        type=click.Choice(list(HEURISTICS)),
        default=DEFAULT_HEURISTIC.value,
        show_default=True,
        callback=lambda _context, _parameter, value: heuristic_named(value),
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


class Grounding(enum.Enum):
    """``--grounding``: ground the whole world first, or only the spaces the LLM's hints name."""

    FULL = "full"
    PRUNED = "pruned"


@dataclass(frozen=True)
class LlmRequest:
    """The LLM's options; ``llm`` ``None``: no LLM (plan once, with ``--hints``)."""

    llm: LlmSpec | None
    backend: BackendOptions
    feedback_rounds: int
    grammar_retries: int
    examples: int
    examples_from: str | None
    retrieval: Retrieval
    round_time_limit: float
    no_fallback: bool
    seed: int
    record: str | None
    auto_probe: float
    grounding: Grounding | None

    def backend_options(self) -> BackendOptions:
        """The backend's options with the seed and the record file of the command."""
        return replace(self.backend, seed=self.seed, record=self.record)

    def pruned(self, source: ScenarioSource) -> bool:
        """Whether the loop prunes the world before grounding it: ``--grounding``, by default for a
        --pddl world with a model backend (the oracles plan in the whole world anyway)."""
        if self.grounding is not None:
            return self.grounding is Grounding.PRUNED
        return source.pddl is not None and self.llm is not None and self.llm.kind.is_model and not self.llm.auto

    def loop_options(self, search: SearchRequest, progress: Progress | None) -> LoopOptions:
        """The loop's options (the deadline of ``-t`` is given to the loop beside them)."""
        return LoopOptions(
            planner=search.planner,
            feedback_rounds=self.feedback_rounds,
            grammar_retries=self.grammar_retries,
            round_time_limit=self.round_time_limit,
            fallback=not self.no_fallback,
            fallback_time_limit=search.time_limit,
            fallback_heuristic=search.heuristic,
            prompt=PromptOptions(examples=self.examples, retrieval=self.retrieval),
            progress=progress,
        )


llm_options = option_group(
    "llm",
    LlmRequest,
    click.option(
        "--llm",
        callback=lambda _context, _parameter, value: None if value is None else LlmSpec.parse(value),
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
        type=click.Choice([grounding.value for grounding in Grounding]),
        callback=lambda _context, _parameter, value: None if value is None else Grounding(value),
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
    from hbtp.cli.plan_run import run_plan

    with memory_cap(search.memory_mb):  # bounds the whole command, from its start
        return run_plan(PlanRequest(source, goal, search, outputs, llm, instruction))


__all__ = ["Grounding", "LlmRequest", "Outputs", "PlanRequest", "SearchRequest", "plan_command"]
