"""``hbtp train``: teach the local model a world (see :mod:`hbtp.train`)."""

from __future__ import annotations

import shlex
import sys
from collections.abc import Iterator
from dataclasses import dataclass
from pathlib import Path
from typing import TYPE_CHECKING

import click

from hbtp.cli.options import ScenarioSource, echo_json, option_group, output_option, scenario_options
from hbtp.errors import InputError
from hbtp.train.lora import TrainSettings

if TYPE_CHECKING:
    from hbtp.train.evaluate import HeldOutScore
    from hbtp.train.run import TrainOutcome


def _progress(steps: Iterator[int], start: int, total: int) -> Iterator[int]:
    """A progress bar with the time left, on standard error."""
    from tqdm import tqdm

    yield from tqdm(steps, initial=start, total=total, desc="training", unit="step", file=sys.stderr, leave=False)


def _settings(epochs: int, rank: int, learning_rate: float, batch: int, seed: int, threads: int) -> TrainSettings:
    return TrainSettings(
        rank=rank, alpha=2 * rank, learning_rate=learning_rate, epochs=epochs, batch=batch, seed=seed, threads=threads
    )


#: How to train (``--epochs``, ``--rank``, ``--learning-rate``, ``--batch``, ``--seed``, ``--threads``).
settings_options = option_group(
    "settings",
    _settings,
    click.option("--epochs", type=click.IntRange(1, 50), default=2, show_default=True, help="Passes over the data."),
    click.option("--rank", type=click.IntRange(1, 128), default=8, show_default=True, help="The adapter's LoRA rank."),
    click.option("--learning-rate", type=click.FloatRange(0, 1, min_open=True), default=1e-3, show_default=True,
                 help="AdamW's learning rate (warm-up, then linear decay)."),
    click.option("--batch", type=click.IntRange(1, 256), default=8, show_default=True, help="Examples per step."),
    click.option("--seed", type=int, default=0, show_default=True, help="Seed of the goals, the split and the order."),
    click.option("--threads", type=click.IntRange(1, 256), default=2, show_default=True, help="CPU threads."),
)  # fmt: skip


@dataclass(frozen=True)
class Judging:
    """Which models are judged on the held-back goals: the taught one (unless ``--no-eval``), and the
    base model too with ``--baseline``."""

    evaluate: bool = True
    baseline: bool = False


def _judging(no_eval: bool, baseline: bool) -> Judging:
    return Judging(evaluate=not no_eval, baseline=baseline)


#: ``--no-eval`` and ``--baseline``.
judging_options = option_group(
    "judging",
    _judging,
    click.option("--no-eval", is_flag=True, help="Do not judge the model on the held-back goals."),
    click.option(
        "--baseline",
        is_flag=True,
        help="Judge the base model too (few-shot, as --llm local without an adapter) on the same held-back goals.",
    ),
)


@dataclass(frozen=True)
class Labels:
    """What the examples teach: goals -> plans (``--hints``), instructions -> goals (``--instructions``);
    and whether the plans are abridged (``--abridge``)."""

    instructions: bool = True
    abridge: bool = False
    hints: bool = True


#: ``--instructions/--no-instructions``, ``--abridge`` and ``--hints/--no-hints``.
label_options = option_group(
    "labels",
    Labels,
    click.option(
        "--instructions/--no-instructions",
        default=True,
        show_default=True,
        help="Teach instructions -> goals too (goals said in words by the verbaliser), beside goals -> hints.",
    ),
    click.option(
        "--abridge",
        is_flag=True,
        help="Teach plans without the steps the check of a reply puts back (shorter replies, faster answers).",
    ),
    click.option(
        "--hints/--no-hints",
        default=True,
        show_default=True,
        help="Teach goals -> hints (the plan, its predicates and objects); --no-hints with --instructions makes an "
        "adapter that only reads instructions.",
    ),
)


@click.command("train")
@scenario_options
@click.option(
    "-n",
    "--count",
    type=click.IntRange(10, 100_000),
    default=2_000,
    show_default=True,
    help="Goals to sample and label with the planner (some are held back).",
)
@click.option(
    "--held-out",
    type=click.FloatRange(0, 0.5),
    default=0.1,
    show_default=True,
    help="Share of the goals held back to measure the model (never trained on).",
)
@settings_options
@output_option(
    "-o",
    "--out",
    "out_file",
    help="The adapter to write (default: the cache, where --llm local finds it for this world).",
)
@click.option("--work", type=click.Path(file_okay=False), help="Checkpoints and examples (default: the cache).")
@click.option(
    "-t",
    "--time-limit",
    type=click.FloatRange(0, min_open=True),
    help="Seconds of training at most; the same command then goes on from the checkpoint.",
)
@label_options
@judging_options
@click.option("--json", "as_json", is_flag=True, help="Print the outcome as JSON.")
def train_command(
    source: ScenarioSource,
    count: int,
    held_out: float,
    settings: TrainSettings,
    out_file: str | None,
    work: str | None,
    time_limit: float | None,
    labels: Labels,
    judging: Judging,
    as_json: bool,
) -> int:
    """Teach the local model (Gemma-3 270M) a scenario or your PDDL world: goals sampled and labelled
    by the optimal planner, a LoRA adapter trained on them, judged on held-back goals. Needs the
    train extra (pip install -e '.[train]')."""
    from hbtp.llm.backends.adapters import cache_folder
    from hbtp.train.run import TrainRequest, run_training

    if source.scenario is None and source.pddl is None:
        raise InputError("choose a scenario with --scenario or your PDDL with --pddl DOMAIN PROBLEM")
    loaded = source.load()
    where: dict[str, object] = {"scenario": source.scenario} if source.scenario else {"pddl": list(source.pddl or ())}
    request = TrainRequest(
        loaded, where, count, held_out, settings, Path(out_file) if out_file else None,
        Path(work) if work else None, time_limit, judging.evaluate, labels.instructions, _command_line(),
        judging.baseline, labels.abridge, labels.hints,
    )  # fmt: skip
    outcome = run_training(request, cache_folder().parent / "train", None if as_json else _progress)
    if as_json:
        echo_json(outcome.to_dict())
    else:
        _show(outcome)
    return 0


def _command_line() -> str:
    """The command as typed (kept in the report beside the adapter), the program's folder left out."""
    return " ".join(["hbtp", *(shlex.quote(arg) for arg in sys.argv[1:])])


def _show(outcome: TrainOutcome) -> None:
    facts = outcome.to_dict()
    click.echo(
        f"wrote {facts['adapter']} ({facts['bytes'] / 1e6:.1f} MB): {facts['train_examples']} examples, "
        f"{facts['steps']} steps, loss {facts['first_loss']:.3f} -> {facts['last_loss']:.3f}, "
        f"{facts['training_s']:.0f} s of training"
    )
    for name, score in (("", outcome.score), ("the base model: ", outcome.base_score)):
        if score is not None:
            _show_score(name, score)


def _show_score(name: str, score: HeldOutScore) -> None:
    if score.examples:
        click.echo(
            f"{name}held back {score.examples} goals: NF {score.nf:.0%}, exact plan {score.exact:.0%}, "
            f"predicates and objects covered {score.covered:.0%}, median {score.median_seconds:.2f} s per answer"
        )
    if score.instructions:
        click.echo(
            f"{name}held back {score.instructions} instructions: goal exact {score.instruction_exact:.0%} "
            f"(refusals among them: {score.refusals}, refused {score.refused:.0%})"
        )


__all__ = ["train_command"]
