"""Options and helpers shared by the commands."""

from __future__ import annotations

import functools
import json
from collections.abc import Callable, Iterable
from dataclasses import dataclass
from pathlib import Path
from typing import Any, TypeVar, cast

import click

from hbtp.domains import Scenario, load_pddl_scenario, load_scenario, scenario_names
from hbtp.domains.scenarios import read_mutex_file
from hbtp.errors import InputError
from hbtp.files import write_all_atomically

F = TypeVar("F", bound=Callable[..., Any])


@dataclass(frozen=True)
class ScenarioSource:
    """Which scenario a command works on: a shipped one, or the user's PDDL with its options."""

    scenario: str | None = None
    pddl: tuple[str, str] | None = None
    object_categories: tuple[str, ...] = ()
    keep_fluent: tuple[str, ...] = ()
    mutex_file: str | None = None

    @property
    def given(self) -> bool:
        return bool(self.scenario or self.pddl)

    def load(self, default: str | None = None) -> Scenario:
        """The scenario; ``default`` (a shipped scenario's name, e.g. recorded in a tree file) when
        neither --scenario nor --pddl was given."""
        scenario, pddl = self.scenario, self.pddl
        if scenario and pddl:
            raise InputError("give either --scenario or --pddl, not both")
        if not scenario and not pddl and default in scenario_names():
            scenario = default
        if scenario:
            if self.object_categories or self.keep_fluent or self.mutex_file:
                raise InputError("--objects, --keep-fluent and --mutex go with --pddl")
            return load_scenario(scenario)
        if pddl:
            declared = read_mutex_file(self.mutex_file) if self.mutex_file else {"groups": [], "nogoods": []}
            return load_pddl_scenario(
                pddl[0],
                pddl[1],
                keep_fluent=self.keep_fluent,
                objects=self.object_categories,
                mutex_groups=declared["groups"],
                mutex_nogoods=declared["nogoods"],
            )
        raise InputError(f"choose a scenario with --scenario ({', '.join(scenario_names())}) or --pddl DOMAIN PROBLEM")


def scenario_options(function: F) -> F:
    """``--scenario NAME`` or ``--pddl DOMAIN PROBLEM`` (with ``--mutex FILE``, ``--objects CAT``,
    ``--keep-fluent PRED``), handed to the command as one ``source: ScenarioSource`` argument."""

    @functools.wraps(function)
    def wrapper(
        *args: Any,
        scenario: str | None,
        pddl: tuple[str, str] | None,
        object_categories: tuple[str, ...],
        keep_fluent: tuple[str, ...],
        mutex_file: str | None,
        **kwargs: Any,
    ) -> Any:
        source = ScenarioSource(scenario, pddl or None, tuple(object_categories), tuple(keep_fluent), mutex_file)
        return function(*args, source=source, **kwargs)

    decorated: Any = wrapper
    decorated = click.option(
        "--mutex", "mutex_file", type=click.Path(dir_okay=False), help="TOML file of declared mutexes (with --pddl)."
    )(decorated)
    decorated = click.option(
        "--keep-fluent", multiple=True, help="With --pddl: a predicate no action changes that stays in the state."
    )(decorated)
    decorated = click.option(
        "--objects", "object_categories", multiple=True, help="With --pddl: static categories that form the objects O."
    )(decorated)
    decorated = click.option(
        "--pddl", nargs=2, type=click.Path(dir_okay=False), metavar="DOMAIN PROBLEM", help="Your own PDDL files."
    )(decorated)
    decorated = click.option(
        "-s", "--scenario", metavar="NAME", help=f"A shipped scenario: {', '.join(scenario_names())}."
    )(decorated)
    return cast(F, decorated)


def echo_json(data: Any) -> None:
    click.echo(json.dumps(data, indent=1, ensure_ascii=False))


def write_files_atomically(files: dict[Path, str]) -> None:
    """Write every file or none (see :func:`hbtp.files.write_all_atomically`)."""
    write_all_atomically(dict(files))


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
