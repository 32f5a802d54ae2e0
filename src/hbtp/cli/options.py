"""Options and helpers shared by the commands."""

from __future__ import annotations

import functools
import inspect
import json
import math
from collections.abc import Callable, Iterable
from dataclasses import dataclass
from pathlib import Path
from typing import Any, TypeVar, cast

import click

from hbtp.deadline import DEFAULT_TIME_LIMIT, Deadline
from hbtp.domains import Scenario, load_pddl_scenario, load_scenario, scenario_names
from hbtp.domains.pruned import PrunedWorld
from hbtp.domains.scenarios import ScenarioOptions, read_mutex_file
from hbtp.errors import InputError
from hbtp.files import check_output
from hbtp.llm.backends.adapters import AdapterChoice
from hbtp.llm.backends.registry import BackendOptions
from hbtp.llm.prompt import RETRIEVALS, Retrieval

F = TypeVar("F", bound=Callable[..., Any])


@dataclass(frozen=True)
class ScenarioSource:
    """Which scenario a command works on: a shipped one, or the user's PDDL with its options.

    ``irreflexive`` (with ``pddl``) names relations that never hold between an object and itself
    (the shipped scenarios declare theirs): the actions that add one between an object and itself
    are left out unless ``keep_self_placements`` (:mod:`hbtp.domains.irreflexive`)."""

    scenario: str | None = None
    pddl: tuple[str, str] | None = None
    object_categories: tuple[str, ...] = ()
    keep_fluent: tuple[str, ...] = ()
    mutex_file: str | None = None
    irreflexive: tuple[str, ...] = ()
    keep_self_placements: bool = False

    @property
    def given(self) -> bool:
        return bool(self.scenario or self.pddl)

    def load(self, default: str | None = None, *, deadline: Deadline | None = None) -> Scenario:
        """The scenario; ``default`` (a shipped scenario's name, e.g. recorded in a tree file) when
        neither --scenario nor --pddl was given. ``deadline`` bounds reading, grounding and mutex
        inference of --pddl files (:class:`~hbtp.deadline.TimeLimitReached`, exit code 1)."""
        scenario, pddl = self.scenario, self.pddl
        if scenario and pddl:
            raise InputError("give either --scenario or --pddl, not both")
        if not scenario and not pddl and default in scenario_names():
            scenario = default
        if scenario:
            self._check_shipped()
            return load_scenario(scenario, keep_self_placements=self.keep_self_placements)
        if pddl:
            return load_pddl_scenario(pddl[0], pddl[1], self._pddl_options(), deadline=deadline)
        raise InputError(f"choose a scenario with --scenario ({', '.join(scenario_names())}) or --pddl DOMAIN PROBLEM")

    def load_pruned(self, *, deadline: Deadline | None = None) -> PrunedWorld:
        """The world, its action names listed and nothing grounded (see :mod:`hbtp.domains.pruned`)."""
        if self.scenario and self.pddl:
            raise InputError("give either --scenario or --pddl, not both")
        if self.scenario:
            self._check_shipped()
            shipped = load_scenario(self.scenario, keep_self_placements=self.keep_self_placements)
            options = ScenarioOptions.shipped(self.scenario, keep_self_placements=self.keep_self_placements)
            return PrunedWorld.load(shipped.domain_file, shipped.problem_file, options, deadline=deadline)
        if self.pddl:
            return PrunedWorld.load(self.pddl[0], self.pddl[1], self._pddl_options(), deadline=deadline)
        raise InputError(f"choose a scenario with --scenario ({', '.join(scenario_names())}) or --pddl DOMAIN PROBLEM")

    def _check_shipped(self) -> None:
        """A shipped scenario brings its own options: refuse those of --pddl."""
        if self.object_categories or self.keep_fluent or self.mutex_file or self.irreflexive:
            raise InputError("--objects, --keep-fluent, --irreflexive and --mutex go with --pddl")

    def _pddl_options(self) -> ScenarioOptions:
        declared = read_mutex_file(self.mutex_file) if self.mutex_file else {"groups": [], "nogoods": []}
        return ScenarioOptions(
            keep_fluent=self.keep_fluent,
            objects=self.object_categories,
            mutex_groups=declared["groups"],
            mutex_nogoods=declared["nogoods"],
            irreflexive=self.irreflexive,
            keep_self_placements=self.keep_self_placements,
        )


def option_group(name: str, build: Callable[..., Any], *options: Callable[[Any], Any]) -> Callable[[F], F]:
    """A decorator that adds ``options`` (click option decorators, in their ``--help`` order) to a
    command and hands their values to it as one argument: ``name=build(**values)``, ``build``
    taking one keyword argument per option (its parameter name; a nested group's ``name``)."""
    names = list(inspect.signature(build).parameters)

    def decorate(function: F) -> F:
        @functools.wraps(function)
        def wrapper(*args: Any, **kwargs: Any) -> Any:
            values = {key: kwargs.pop(key) for key in names}
            return function(*args, **kwargs, **{name: build(**values)})

        decorated: Any = wrapper
        for option in reversed(options):
            decorated = option(decorated)
        return cast(F, decorated)

    return decorate


def _scenario_source(
    scenario: str | None,
    pddl: tuple[str, str] | None,
    object_categories: tuple[str, ...],
    keep_fluent: tuple[str, ...],
    mutex_file: str | None,
    irreflexive: tuple[str, ...],
    keep_self_placements: bool,
) -> ScenarioSource:
    return ScenarioSource(
        scenario,
        pddl or None,
        tuple(object_categories),
        tuple(keep_fluent),
        mutex_file,
        tuple(irreflexive),
        keep_self_placements,
    )


#: ``--scenario NAME`` or ``--pddl DOMAIN PROBLEM`` (with ``--mutex FILE``, ``--objects CAT``,
#: ``--keep-fluent PRED``, ``--irreflexive PRED``) and ``--keep-self-placements``, handed to the
#: command as one ``source: ScenarioSource`` argument.
scenario_options = option_group(
    "source",
    _scenario_source,
    click.option("-s", "--scenario", metavar="NAME", help=f"A shipped scenario: {', '.join(scenario_names())}."),
    click.option(
        "--pddl", nargs=2, type=click.Path(dir_okay=False), metavar="DOMAIN PROBLEM", help="Your own PDDL files."
    ),
    click.option(
        "--objects", "object_categories", multiple=True, help="With --pddl: static categories that form the objects O."
    ),
    click.option(
        "--keep-fluent", multiple=True, help="With --pddl: a predicate no action changes that stays in the state."
    ),
    click.option(
        "--mutex", "mutex_file", type=click.Path(dir_okay=False), help="TOML file of declared mutexes (with --pddl)."
    ),
    click.option(
        "--irreflexive",
        multiple=True,
        metavar="PRED",
        help="With --pddl: a relation that never holds between an object and itself (IsOn); "
        "the actions that add one, P(x,x), are left out.",
    ),
    click.option(
        "--keep-self-placements",
        is_flag=True,
        help="Keep the actions that put an object on or in itself (RobotHow's LeftPut(chair,chair)): "
        "the paper's action space.",
    ),
)


def checked_output(ctx: click.Context, param: click.Parameter, value: str | None) -> str | None:
    """An option's output file, refused before any work when hbtp must not write it: an existing
    target that is not a regular file or is a symbolic link, or a missing folder
    (:func:`hbtp.files.check_output`). The writers check again when they write."""
    if value is not None:
        check_output(Path(value))
    return value


def output_option(*declarations: str, help: str, required: bool = False) -> Callable[[F], F]:
    """An option naming a file the command writes (``--out FILE``), checked by :func:`checked_output`."""
    return click.option(
        *declarations, type=click.Path(dir_okay=False), callback=checked_output, required=required, help=help
    )


#: ``-t SECONDS``: one limit for the whole command (loading, grounding, every LLM call and search).
time_limit_option = click.option(
    "-t",
    "--time-limit",
    type=float,
    default=DEFAULT_TIME_LIMIT,
    show_default=True,
    help="Seconds for the whole command.",
)


def echo_json(data: Any) -> None:
    click.echo(json.dumps(data, indent=1, ensure_ascii=False))


def comma_choices(text: str, choices: Iterable[str], hint: str, what: str) -> tuple[str, ...]:
    """``a,b,c`` checked against ``choices`` (a click usage error names the unknown ones)."""
    allowed = set(choices)
    chosen = tuple(part.strip() for part in text.split(",") if part.strip())
    unknown = [part for part in chosen if part not in allowed]
    if unknown or not chosen:
        raise click.BadParameter(f"unknown {what}(s) {', '.join(unknown) or '(none)'}", param_hint=hint)
    return chosen


def comma_numbers(text: str, hint: str, upper: float = 1.0) -> tuple[float, ...]:
    """``0,0.5,1`` as numbers between 0 and ``upper``."""
    try:
        values = tuple(float(part) for part in text.split(",") if part.strip())
    except ValueError:
        raise click.BadParameter(f"expected comma-separated numbers, not {text!r}", param_hint=hint) from None
    if not values or any(not 0.0 <= v <= upper for v in values):
        raise click.BadParameter(f"every value must be between 0 and {upper}", param_hint=hint)
    return values


def _positive_seconds(context: click.Context, parameter: click.Parameter, value: float) -> float:
    if not (value > 0 and math.isfinite(value)):  # also nan and inf
        raise click.BadParameter(f"must be a positive number of seconds, not {value}")
    return value


@dataclass(frozen=True)
class LocalModelOptions:
    """The options of the local model (``--model-path``, ``--threads``, ``--prompt-cache``, ``--adapter``)."""

    model_path: str | None
    threads: int | None
    prompt_cache: bool
    adapter: AdapterChoice


def _backend(
    model: str | None,
    base_url: str | None,
    api_key: str | None,
    llm_timeout: float,
    local: LocalModelOptions,
    noise_drop: float,
    noise_insert: float,
    no_constraints: bool,
) -> BackendOptions:
    return BackendOptions(
        model=model,
        base_url=base_url,
        api_key=api_key,
        timeout=llm_timeout,
        model_path=local.model_path,
        threads=local.threads,
        prompt_cache=local.prompt_cache,
        drop=noise_drop,
        insert=noise_insert,
        constrain=not no_constraints,
        adapter=local.adapter,
    )


local_model_options = option_group(
    "local",
    LocalModelOptions,
    click.option("--model-path", help="GGUF file for --llm local (default: the packaged Gemma-3 270M)."),
    click.option("--threads", type=int, help="CPU threads for --llm local."),
    click.option(
        "--prompt-cache",
        is_flag=True,
        help="--llm local: reuse the prompt cache (faster; answers may then depend on the order of requests).",
    ),
    click.option(
        "--adapter",
        default="auto",
        show_default=True,
        callback=lambda _context, _parameter, value: AdapterChoice.parse(value),
        help="--llm local: the LoRA adapter that teaches the model the world: auto (the scenario's shipped "
        "one, or the one hbtp train --pddl left for these PDDL files), none, or a file.",
    ),
)


#: The LLM back-end options (``--model``, ``--base-url``, ``--api-key``, ``--llm-timeout``, the local
#: model's, ``--noise-drop``, ``--noise-insert``, ``--no-constraints``), passed on as ``backend: BackendOptions``.
backend_options = option_group(
    "backend",
    _backend,
    click.option("--model", help="LLM model name (openai; default $HBTP_LLM_MODEL)."),
    click.option("--base-url", help="OpenAI-compatible server URL (default $OPENAI_BASE_URL)."),
    click.option("--api-key", help="API key (default $OPENAI_API_KEY; never stored)."),
    click.option(
        "--llm-timeout",
        type=float,
        default=60.0,
        show_default=True,
        callback=_positive_seconds,
        help="Seconds for one LLM call (its retries and reading the reply included).",
    ),
    local_model_options,
    click.option("--noise-drop", type=float, default=0.3, show_default=True, help="noisy-oracle: fraction dropped."),
    click.option(
        "--noise-insert", type=float, default=0.3, show_default=True, help="noisy-oracle: wrong actions added."
    ),
    click.option(
        "--no-constraints",
        is_flag=True,
        help="Free-text replies: no grammar (local) and no response_format schema (openai), for servers "
        "that reject them (a refusal is also detected and the call answered without).",
    ),
)


def feedback_rounds_option(help: str) -> Callable[[F], F]:
    """``--feedback-rounds`` of the LLM loop, with the command's ``help``."""
    return click.option("--feedback-rounds", type=click.IntRange(0, 10), default=3, show_default=True, help=help)


#: ``--examples``, ``--retrieval`` and ``--round-time-limit`` of the LLM loop (``hbtp plan``, ``bench table2``).
examples_option = click.option(
    "--examples", type=click.IntRange(0, 50), default=5, show_default=True, help="Few-shot demonstrations."
)
retrieval_option = click.option(
    "--retrieval",
    type=click.Choice(list(RETRIEVALS)),
    default="lexical",
    show_default=True,
    callback=lambda _context, _parameter, value: Retrieval.named(value),
    help="How demonstrations are chosen (embeddings: the optional extra).",
)
round_time_limit_option = click.option(
    "--round-time-limit", type=float, default=5.0, show_default=True, help="Planning seconds per round."
)
