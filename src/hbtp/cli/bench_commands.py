"""``hbtp bench ...``: rerun the paper's experiments."""

from __future__ import annotations

from collections.abc import Iterable
from dataclasses import replace
from pathlib import Path

import click

from hbtp.bench.fig3 import Fig3Config, run_fig3
from hbtp.bench.fig4 import Fig4Config, run_fig4
from hbtp.bench.instructions import InstructionsBench, report, run_instructions
from hbtp.bench.payoff import SETS, PayoffConfig, run_payoff
from hbtp.bench.pddl_suite import PddlConfig, run_pddl
from hbtp.bench.runner import EXECUTORS, Execution, Executor
from hbtp.bench.suite import PARTS, SuiteConfig, run_suite
from hbtp.bench.table1 import Table1Config, run_table1
from hbtp.bench.table2 import BackendRecipe, Table2Config, run_table2, write_table2_report
from hbtp.cli.lazy import LazyGroup
from hbtp.cli.options import (
    backend_options,
    comma_choices,
    comma_numbers,
    examples_option,
    feedback_rounds_option,
    option_group,
    retrieval_option,
    round_time_limit_option,
)
from hbtp.datasets import read_dataset_file
from hbtp.domains import scenario_names
from hbtp.llm.backends.registry import BackendKind, BackendOptions, LlmSpec, make_goal_backend
from hbtp.llm.prompt import PromptOptions, Retrieval
from hbtp.pipeline import LoopOptions
from hbtp.planning import PLANNERS
from hbtp.planning.generate import LEVELS
from hbtp.planning.heuristic_names import HEURISTICS, HeuristicName, heuristic_named
from hbtp.planning.planners import Space

#: Options several benchmarks share.
out_dir_option = click.option(
    "-o",
    "--out",
    "out_dir",
    required=True,
    type=click.Path(file_okay=False),
    help="Output folder (results.jsonl, summary.json); re-running resumes.",
)
planners_option = click.option(
    "--planners", default=",".join(PLANNERS), show_default=True, help="Comma-separated planners."
)
heuristic_option = click.option(
    "--heuristic",
    type=click.Choice(list(HEURISTICS)),
    default="none",
    show_default=True,
    callback=lambda _context, _parameter, value: heuristic_named(value),
    help="LLM-free heuristic (none: the paper's planners).",
)
task_time_limit_option = click.option(
    "-t", "--time-limit", type=float, default=5.0, show_default=True, help="Seconds per task."
)


def _execution(jobs: int, executor: str, kill_after: float | None, no_progress: bool, fresh_workers: bool) -> Execution:
    return Execution(
        executor=Executor(executor),
        jobs=jobs,
        kill_after=kill_after,
        progress=not no_progress,
        fresh_workers=fresh_workers,
    )


#: ``--jobs``, ``--executor``, ``--kill-after``, ``--no-progress``, ``--fresh-workers``, passed on as ``execution``.
execution_options = option_group(
    "execution",
    _execution,
    click.option("-j", "--jobs", type=click.IntRange(1, 512), default=1, show_default=True, help="Runs in parallel."),
    click.option(
        "--executor",
        type=click.Choice(list(EXECUTORS)),
        default="local",
        show_default=True,
        help="local: worker processes; ray: a Ray cluster ($RAY_ADDRESS) or a local Ray; inline: this process.",
    ),
    click.option(
        "--kill-after",
        type=click.FloatRange(min=0, min_open=True),
        help="Hard limit in seconds per run: the worker is killed (default: from the benchmark's time limits).",
    ),
    click.option("--no-progress", is_flag=True, help="No progress bar."),
    click.option(
        "--fresh-workers",
        is_flag=True,
        help="local: a new worker process for every run (a run's peak memory is its own; slower: "
        "nothing a worker loaded is kept for the next run).",
    ),
)


@click.group(cls=LazyGroup, lazy={"robustness": "hbtp.cli.robustness_command:robustness"})
def bench() -> None:
    """Reproduce the paper's tables (results.jsonl + summary.json; re-running resumes)."""


@bench.command("table1")
@click.option(
    "--space",
    type=click.Choice(["pruned", "full"]),
    default="pruned",
    show_default=True,
    help="Action space: pruned from each record's hints, or every action.",
)
@planners_option
@click.option(
    "--hints",
    type=click.Choice(["oracle", "none"]),
    default="oracle",
    show_default=True,
    help="oracle: each record's optimal actions as the heuristic path; none: no heuristic path.",
)
@heuristic_option
@task_time_limit_option
@click.option("--limit", type=int, help="Only the first N tasks.")
@out_dir_option
@execution_options
def table1(
    space: str,
    planners: str,
    hints: str,
    heuristic: HeuristicName,
    time_limit: float,
    limit: int | None,
    out_dir: str,
    execution: Execution,
) -> int:
    """Table I: the four planners on the 100 Table I tasks (RobotHow)."""
    chosen = comma_choices(planners, PLANNERS, "--planners", "planner")
    if not time_limit > 0:
        raise click.BadParameter("must be a positive number of seconds", param_hint="--time-limit")
    config = Table1Config(
        space=Space(space),
        planners=chosen,
        hints="none" if hints == "none" else "oracle",
        heuristic=heuristic,
        time_limit=time_limit,
        limit=limit,
    )
    summary = run_table1(config, Path(out_dir), execution)
    header = f"{'planner':8} {'solved':>7} {'timeouts':>8} {'|S-|':>8} {'D(T)':>8} {'mean ms':>9} {'median ms':>10}"
    click.echo(header)
    for name, row in summary["planners"].items():
        explored = f"{row['mean_explored']:.2f}" if row["mean_explored"] is not None else "-"
        cost = f"{row['mean_cost']:.2f}" if row["mean_cost"] is not None else "-"
        click.echo(
            f"{name:8} {row['solved']:>3}/{row['tasks']:<3} {row['timeouts']:>8} {explored:>8} {cost:>8} "
            f"{(row['mean_time_s'] or 0) * 1000:>9.2f} {(row['median_time_s'] or 0) * 1000:>10.2f}"
        )
    click.echo(f"wrote {Path(out_dir) / 'results.jsonl'} and {Path(out_dir) / 'summary.json'}")
    return 0


def _table2_loop(
    planner: str, feedback_rounds: int, examples: int, retrieval: Retrieval, round_time_limit: float
) -> LoopOptions:
    prompt = PromptOptions(examples=examples, retrieval=retrieval)  # the style is the backend's own
    return LoopOptions(
        planner=planner, feedback_rounds=feedback_rounds, round_time_limit=round_time_limit, prompt=prompt
    )


#: ``bench table2``'s LLM loop: ``--planner``, ``--feedback-rounds``, ``--examples``, ``--retrieval``,
#: ``--round-time-limit``, passed on as ``loop: LoopOptions``.
table2_loop_options = option_group(
    "loop",
    _table2_loop,
    click.option(
        "--planner",
        type=click.Choice(list(PLANNERS)),
        default="hbtp-s",
        show_default=True,
        help="Planner of every round.",
    ),
    feedback_rounds_option("Rounds that ask again with the failed search as feedback."),
    examples_option,
    retrieval_option,
    round_time_limit_option,
)


@bench.command("table2")
@click.option("-s", "--scenario", "scenarios", multiple=True, help="Scenario(s); default all four.")
@click.option(
    "--llm",
    "llm_spec",
    callback=lambda _context, _parameter, value: None if value is None else LlmSpec.parse(value),
    help="Backend (see hbtp plan --llm); default oracle, or none with --hints-from.",
)
@click.option(
    "--hints-from",
    type=click.Path(dir_okay=False),
    help="Dataset file whose records are the first-round replies; --llm then answers the feedback rounds.",
)
@backend_options
@table2_loop_options
@click.option("--runs", type=click.IntRange(1, 100), default=1, show_default=True, help="Repeat with seeds 0..N-1.")
@click.option(
    "--b-time-limit",
    type=click.FloatRange(min=0),
    default=10.0,
    show_default=True,
    help="Seconds for B-Time (OBTEA, full space, no heuristic) per task; 0 skips it.",
)
@click.option("--limit", type=int, help="Only the first N tasks.")
@out_dir_option
@execution_options
def table2(
    scenarios: tuple[str, ...],
    llm_spec: LlmSpec | None,
    hints_from: str | None,
    backend: BackendOptions,
    loop: LoopOptions,
    runs: int,
    b_time_limit: float,
    limit: int | None,
    out_dir: str,
    execution: Execution,
) -> int:
    """Table II: LLM reasoning with HBTP on the scenarios' test sets (NF / 1F / 3F success)."""
    names = scenarios or scenario_names()
    records = read_dataset_file(hints_from) if hints_from else None
    if records is None and llm_spec is None:
        llm_spec = LlmSpec(BackendKind.ORACLE)
    label = (
        f"hints-from:{Path(hints_from).name}" + (f"+{llm_spec}" if llm_spec else "") if hints_from else str(llm_spec)
    )
    recipe = BackendRecipe(llm_spec, backend, tuple(records) if records is not None else None)
    rows = []
    for name in names:
        config = Table2Config(
            scenario=name, backend=label, runs=runs, limit=limit, loop=loop, b_time_limit=b_time_limit
        )
        rows.append(run_table2(config, recipe, Path(out_dir) / name, execution))
    write_table2_report(Path(out_dir), rows)
    click.echo(f"{'scenario':15} {'NF%':>6} {'1F%':>6} {'3F%':>6} {'final%':>7} {'|A-|':>6} {'|p^|':>5} {'|S-|':>7}"
               f" {'plan ms':>8} {'LLM s':>6}   paper NF/1F/3F")  # fmt: skip
    for row in rows:
        paper = row["paper"]
        click.echo(
            f"{row['scenario']:15} {row['NF']:>6} {row['1F']:>6} {row['3F']:>6} {row['final']:>7} "
            f"{_fmt(row['A_minus'])} {_fmt(row['p_hat'], 5)} {_fmt(row['explored'], 7)} "
            f"{(row['mean_planning_s'] or 0) * 1000:>8.2f} {row['mean_llm_s'] or 0:>6.2f}   "
            f"{paper.get('NF')}/{paper.get('1F')}/{paper.get('3F')}"
        )
    click.echo(f"wrote {Path(out_dir)}/<scenario>/results.jsonl and summary.json")
    return 0


def _fmt(value: float | None, width: int = 6) -> str:
    return f"{value:>{width}.2f}" if value is not None else f"{'-':>{width}}"


@bench.command("fig4")
@click.option(
    "--correct-rates",
    default="0,0.25,0.5,0.75,1",
    show_default=True,
    help="Comma-separated chances that each optimal action is kept in the heuristic path.",
)
@click.option(
    "--error-rates",
    default="0,0.5,1",
    show_default=True,
    help="Comma-separated numbers of wrong actions inserted, as fractions of |p*| (at most 10).",
)
@click.option(
    "--seeds", type=click.IntRange(1, 100), default=3, show_default=True, help="Noisy paths per task and cell."
)
@click.option("-t", "--time-limit", type=float, default=5.0, show_default=True, help="Seconds per run.")
@click.option("--limit", type=int, help="Only the first N tasks.")
@out_dir_option
@execution_options
def fig4(
    correct_rates: str, error_rates: str, seeds: int, time_limit: float, limit: int | None, out_dir: str,
    execution: Execution,
) -> int:  # fmt: skip
    """Figure 4: |S-| and D(T) of HBTP-O and HBTP-S as the heuristic path gets more right or wrong."""
    config = Fig4Config(
        correct_rates=comma_numbers(correct_rates, "--correct-rates"),
        error_rates=comma_numbers(error_rates, "--error-rates", upper=10.0),
        seeds=seeds,
        time_limit=time_limit,
        limit=limit,
    )
    summary = run_fig4(config, Path(out_dir), execution)
    click.echo(f"{'planner':8} {'ER':>4} {'correct':>8} {'solved':>8} {'|S-|':>8} {'D(T)':>8}")
    for cell in summary["cells"]:
        click.echo(
            f"{cell['planner']:8} {cell['error']:>4} {cell['correct']:>8} {cell['solved']:>4}/{cell['runs']:<3} "
            f"{_fmt(cell['mean_explored'], 8)} {_fmt(cell['mean_cost'], 8)}"
        )
    click.echo(f"wrote {Path(out_dir)}/results.jsonl, summary.json (and fig4.png with the plot extra)")
    return 0


@bench.command("fig3")
@click.option("--scales", default="1,1.5,2,2.5,3", show_default=True, help="Object multipliers of RobotHow.")
@planners_option
@click.option(
    "--space",
    type=click.Choice(["full", "pruned"]),
    default="full",
    show_default=True,
    help="Action space: every action, or pruned from each record's hints.",
)
@heuristic_option
@task_time_limit_option
@click.option("--limit", type=int, default=20, show_default=True, help="Table I tasks per scale.")
@out_dir_option
@execution_options
def fig3(
    scales: str, planners: str, space: str, heuristic: HeuristicName, time_limit: float, limit: int, out_dir: str,
    execution: Execution,
) -> int:  # fmt: skip
    """Figure 3: planning time against the action-space size (RobotHow grown by cloning objects) and |p*|."""
    factors = comma_numbers(scales, "--scales", upper=20.0)
    if any(f < 1.0 for f in factors):
        raise click.BadParameter("every scale must be at least 1", param_hint="--scales")
    config = Fig3Config(
        scales=factors,
        planners=comma_choices(planners, PLANNERS, "--planners", "planner"),
        space=Space(space),
        heuristic=heuristic,
        time_limit=time_limit,
        limit=limit,
    )
    summary = run_fig3(config, Path(out_dir), execution)
    click.echo(f"{'scale':>6} {'|A|':>7} {'planner':8} {'solved':>8} {'mean ms':>10} {'median ms':>10}")
    for cell in summary["by_action_space"]:
        click.echo(
            f"{cell['scale']:>6} {cell['actions']:>7} {cell['planner']:8} {cell['solved']:>4}/{cell['tasks']:<3} "
            f"{(cell['mean_time_s'] or 0) * 1000:>10.1f} {(cell['median_time_s'] or 0) * 1000:>10.1f}"
        )
    click.echo(f"wrote {Path(out_dir)}/results.jsonl, summary.json (and fig3.png with the plot extra)")
    return 0


@bench.command("all")
@click.option("--quick", is_flag=True, help="A few tasks per cell and shorter limits (a few minutes).")
@click.option("--only", "parts", default=",".join(PARTS), show_default=True, help="Comma-separated parts.")
@click.option(
    "--llm",
    "llm_spec",
    default="local",
    show_default=True,
    callback=lambda _context, _parameter, value: None if value is None else LlmSpec.parse(value),
    help="Table II backend (see hbtp plan --llm).",
)
@backend_options
@click.option("--runs", type=click.IntRange(1, 100), default=1, show_default=True, help="Table II runs (seeds).")
@out_dir_option
@execution_options
def bench_all(
    quick: bool,
    parts: str,
    llm_spec: LlmSpec,
    backend: BackendOptions,
    runs: int,
    out_dir: str,
    execution: Execution,
) -> int:
    """Every table and figure of the paper: DIR/report.md, DIR/summary.json, and one folder per part."""
    config = SuiteConfig(quick=quick, parts=comma_choices(parts, PARTS, "--only", "part"), runs=runs)
    run_suite(config, BackendRecipe(llm_spec, backend), Path(out_dir), execution)
    click.echo(f"wrote {Path(out_dir) / 'report.md'} and {Path(out_dir) / 'summary.json'}")
    return 0


#: ``bench payoff`` without ``--quick`` / with it: sets, levels, scales, tasks per cell, seconds.
PAYOFF_DEFAULTS = (SETS, ("easy", "medium", "hard"), (1.0, 3.0, 6.0), 5, 60.0)
PAYOFF_QUICK = (("robowaiter", "robothow-small"), ("easy",), (1.0, 1.5), 2, 10.0)
PAYOFF_LLMS = ("oracle", "noisy-oracle", "local", "openai")


def _listed(
    text: str | None, default: tuple[str, ...], choices: Iterable[str], hint: str, what: str
) -> tuple[str, ...]:
    """``--sets`` / ``--levels``: the default when not given, nothing for ``none``, else checked names."""
    if text is None:
        return default
    return () if text == "none" else comma_choices(text, choices, hint, what)


def _payoff_axes(
    sets: str | None, levels: str | None, scales: str | None, tasks: int | None, time_limit: float | None, quick: bool
) -> PayoffConfig:
    """The cells of ``bench payoff`` (its backends and loop are set by the command)."""
    default_sets, default_levels, default_scales, default_tasks, default_limit = (
        PAYOFF_QUICK if quick else PAYOFF_DEFAULTS
    )
    chosen_sets = _listed(sets, default_sets, scenario_names(), "--sets", "scenario")
    chosen_levels = _listed(levels, default_levels, LEVELS, "--levels", "level")
    factors = default_scales if scales is None else () if scales == "none" else comma_numbers(scales, "--scales", 20.0)
    if any(f < 1.0 for f in factors):
        raise click.BadParameter("every scale must be at least 1", param_hint="--scales")
    if not (chosen_sets or chosen_levels or factors):
        raise click.BadParameter("nothing to run: give some --sets, --levels or --scales", param_hint="--sets")
    limit = default_limit if time_limit is None else time_limit
    if not (limit > 0 and limit < float("inf")):
        raise click.BadParameter("must be a positive number of seconds", param_hint="--time-limit")
    return PayoffConfig(
        sets=chosen_sets, levels=chosen_levels, scales=factors, tasks=tasks or default_tasks, time_limit=limit
    )


#: ``--sets``, ``--levels``, ``--scales``, ``--tasks``, ``-t``, ``--quick``, passed on as ``axes: PayoffConfig``.
payoff_axes_options = option_group(
    "axes",
    _payoff_axes,
    click.option("--sets", help="Comma-separated Table II sets, or none (default: all four; --quick: two)."),
    click.option("--levels", help="Generated RobotHow task levels, or none (default easy,medium,hard; --quick: easy)."),
    click.option("--scales", help="RobotHow grown by these factors, or none (default 1,3,6; --quick: 1,1.5)."),
    click.option("--tasks", type=click.IntRange(1, 100), help="Tasks per cell (default 5; --quick: 2)."),
    click.option("-t", "--time-limit", type=float, help="Seconds per LLM-free search and the fallback (default 60)."),
    click.option("--quick", is_flag=True, help="Two small sets, easy tasks, two small worlds, two tasks, 10 s."),
)


@bench.command("payoff")
@click.option("--llm", default="oracle,noisy-oracle", show_default=True, help="Comma-separated LLM backends.")
@click.option(
    "--pruned",
    is_flag=True,
    help="Also run each backend in the world pruned before grounding (hbtp-pruned:BACKEND: only the "
    "hints' space is grounded, the whole world only for the fallback).",
)
@payoff_axes_options
@backend_options
@table2_loop_options
@out_dir_option
@execution_options
def payoff(
    llm: str,
    pruned: bool,
    axes: PayoffConfig,
    backend: BackendOptions,
    loop: LoopOptions,
    out_dir: str,
    execution: Execution,
) -> int:
    """When does the LLM pay? Time to a verified tree, LLM-guided HBTP against the best LLM-free planner."""
    backends = tuple(part.strip() for part in llm.split(",") if part.strip())
    unknown = [b for b in backends if b not in PAYOFF_LLMS and not b.startswith("replay:")]
    if unknown or not backends:
        raise click.BadParameter(f"unknown backend(s) {', '.join(unknown) or '(none)'}", param_hint="--llm")
    config = replace(axes, backends=backends, loop=loop, pruned=pruned)
    summary = run_payoff(config, backend, Path(out_dir), execution)
    click.echo(f"{'cell':15} {'|A|':>7} {'configuration':20} {'verified':>8} {'total s':>8} {'solve s':>8}"
               f" {'ratio':>6}")  # fmt: skip
    for cell in summary["cells"]:
        for name, stats in cell["configs"].items():
            ratio = cell["against"].get(name, {}).get("median_ratio_total")
            click.echo(
                f"{cell['cell']:15} {cell['actions'] or 0:>7} {name:20} {stats['verified']:>4}/{stats['tasks']:<3} "
                f"{_fmt(stats['median_total_s'], 8)} {_fmt(stats['median_solve_s'], 8)} {_fmt(ratio)}"
            )
    for axis, by_name in summary["crossings"].items():
        for name, found in by_name.items():
            click.echo(f"{axis}: {name} faster (median total) in: {', '.join(found['total_s']['faster_in']) or 'none'}")
    click.echo(f"wrote {Path(out_dir)}/results.jsonl, summary.json, report.md (and payoff.png with the plot extra)")
    return 0


@bench.command("pddl")
@click.argument("folder", metavar="DIR", type=click.Path(path_type=Path))
@click.option("--planners", default="obtea", show_default=True, help="Comma-separated planners.")
@click.option(
    "--heuristic",
    type=click.Choice(list(HEURISTICS)),
    default=PddlConfig.heuristic.value,
    show_default=True,
    callback=lambda _context, _parameter, value: heuristic_named(value),
    help="LLM-free heuristic (seq: lmcut and the state equation, the strongest; needs the lp extra).",
)
@click.option(
    "-t", "--time-limit", type=float, default=60.0, show_default=True, help="Seconds per run (load, then search)."
)
@click.option("--validate", is_flag=True, help="Fast Downward's optimal cost where DIR has none (validate extra).")
@click.option(
    "--symmetry/--no-symmetry",
    default=True,
    show_default=True,
    help="Prune conditions symmetric to explored ones (interchangeable objects): still optimal, smaller trees.",
)
@out_dir_option
@execution_options
def pddl(
    folder: Path,
    planners: str,
    heuristic: HeuristicName,
    time_limit: float,
    validate: bool,
    symmetry: bool,
    out_dir: str,
    execution: Execution,
) -> int:
    """Every DIR/<domain>/domain.pddl with each other .pddl there: coverage, cost, time, optimal costs
    (DIR/fd_optimal_costs.json, or Fast Downward with --validate)."""
    if not (time_limit > 0 and time_limit < float("inf")):
        raise click.BadParameter("must be a positive number of seconds", param_hint="--time-limit")
    chosen = comma_choices(planners, PLANNERS, "--planners", "planner")
    config = PddlConfig(chosen, heuristic, time_limit, validate, symmetry)
    summary = run_pddl(folder, config, Path(out_dir), execution)
    click.echo(f"{'planner':8} {'verified':>9} {'median s':>9}   per domain")
    for name, row in summary["planners"].items():
        domains = " ".join(f"{d}:{n}" for d, n in row["by_domain"].items())
        click.echo(f"{name:8} {row['verified']:>4}/{row['instances']:<4} {_fmt(row['median_time_s'], 9)}   {domains}")
    for m in summary["mismatches"]:
        click.echo(f"MISMATCH {m['domain']}/{m['instance']} {m['planner']}: cost {m['cost']}, optimal "
                   f"{m['reference_cost']} ({m['reference_source']})")  # fmt: skip
    click.echo(f"{len(summary['mismatches'])} mismatch(es) in {summary['compared']} compared runs")
    click.echo(f"wrote {Path(out_dir)}/results.jsonl, summary.json, report.md (and coverage.png with the plot extra)")
    return 0


@bench.command("instructions")
@click.option("-s", "--scenario", "scenarios", multiple=True, help="Scenario(s); default all four.")
@click.option(
    "--llm",
    "llm_spec",
    default="local",
    show_default=True,
    callback=lambda _context, _parameter, value: None if value is None else LlmSpec.parse(value),
    help="local, openai, oracle or replay:FILE.",
)
@click.option("--limit", type=click.IntRange(min=1), help="Only the first N records per scenario.")
@click.option(
    "--phrasings", type=click.IntRange(1, 10), default=2, show_default=True, help="Phrasings asked per record."
)
@click.option(
    "--lacking/--no-lacking",
    default=True,
    show_default=True,
    help="Also ask, per record, its goal with one object swapped for a thing the world lacks, "
    "said in words; it must be refused (kind 'lacking', not in 'all').",
)
@feedback_rounds_option("Answers asked again, with the objections to the last, before giving up.")
@backend_options
@out_dir_option
def instructions(
    scenarios: tuple[str, ...],
    llm_spec: LlmSpec,
    limit: int | None,
    phrasings: int,
    lacking: bool,
    feedback_rounds: int,
    backend: BackendOptions,
    out_dir: str,
) -> int:
    """Instructions to goals: accuracy, rounds, LLM time and end-to-end success on the instruction dataset."""
    chosen = tuple(scenarios) or scenario_names()
    bench_config = InstructionsBench(chosen, str(llm_spec), limit, phrasings, feedback_rounds, lacking=lacking)
    summary = run_instructions(
        bench_config, lambda scenario: make_goal_backend(llm_spec, scenario, backend), Path(out_dir)
    )
    click.echo(report(summary).rstrip())
    click.echo(f"wrote {Path(out_dir)}/results.jsonl, summary.json, report.md")
    return 0
