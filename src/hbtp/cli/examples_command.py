"""``hbtp examples generate``: the demonstrations hbtp makes for a domain without an example pool."""

from __future__ import annotations

import click

from hbtp.cli.dataset_commands import generation_options, with_options, write_generated
from hbtp.cli.options import ScenarioSource, scenario_options
from hbtp.llm.demonstrations import PoolSettings
from hbtp.planning.generate import Sampling


@click.group()
def examples() -> None:
    """Few-shot demonstrations (example pools) for the LLM prompt."""


@examples.command("generate")
@scenario_options
@with_options(generation_options(PoolSettings().count))
def generate_examples(source: ScenarioSource, count: int, seed: int, max_expansions: int, output: str | None) -> int:
    """Generate demonstrations: sampled goals of 1-3 literals with their optimal plans, in the dataset
    format (use them with `hbtp plan --examples-from FILE`). With the defaults, these are the
    demonstrations a domain without a pool gets automatically."""
    settings = PoolSettings()
    sampling = Sampling(seed=seed, max_expansions=max_expansions)
    return write_generated(source.load(), settings.level, count, sampling, output)
