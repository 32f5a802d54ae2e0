"""Options and helpers shared by the commands."""

from __future__ import annotations

import json
from collections.abc import Callable
from pathlib import Path
from typing import Any, TypeVar

import click

from hbtp.domains import Scenario, load_pddl_scenario, load_scenario, scenario_names
from hbtp.domains.scenarios import read_mutex_file
from hbtp.errors import InputError
from hbtp.files import write_all_atomically

F = TypeVar("F", bound=Callable[..., Any])


def scenario_options(function: F) -> F:
    """``--scenario NAME`` or ``--pddl DOMAIN PROBLEM`` (with ``--mutex FILE``, ``--objects CAT``)."""
    function = click.option(
        "--mutex", "mutex_file", type=click.Path(dir_okay=False), help="TOML file of declared mutexes (with --pddl)."
    )(function)
    function = click.option(
        "--keep-fluent", multiple=True, help="With --pddl: a predicate no action changes that stays in the state."
    )(function)
    function = click.option(
        "--objects", "object_categories", multiple=True, help="With --pddl: static categories that form the objects O."
    )(function)
    function = click.option(
        "--pddl", nargs=2, type=click.Path(dir_okay=False), metavar="DOMAIN PROBLEM", help="Your own PDDL files."
    )(function)
    function = click.option(
        "-s", "--scenario", metavar="NAME", help=f"A shipped scenario: {', '.join(scenario_names())}."
    )(function)
    return function


def load_selected(
    scenario: str | None,
    pddl: tuple[str, str] | None,
    object_categories: tuple[str, ...] = (),
    keep_fluent: tuple[str, ...] = (),
    mutex_file: str | None = None,
) -> Scenario:
    if scenario and pddl:
        raise InputError("give either --scenario or --pddl, not both")
    if scenario:
        if object_categories or keep_fluent or mutex_file:
            raise InputError("--objects, --keep-fluent and --mutex go with --pddl")
        return load_scenario(scenario)
    if pddl:
        declared = read_mutex_file(mutex_file) if mutex_file else {"groups": [], "nogoods": []}
        return load_pddl_scenario(
            pddl[0],
            pddl[1],
            keep_fluent=keep_fluent,
            objects=object_categories,
            mutex_groups=declared["groups"],
            mutex_nogoods=declared["nogoods"],
        )
    raise InputError(f"choose a scenario with --scenario ({', '.join(scenario_names())}) or --pddl DOMAIN PROBLEM")


def echo_json(data: Any) -> None:
    click.echo(json.dumps(data, indent=1, ensure_ascii=False))


def write_files_atomically(files: dict[Path, str]) -> None:
    """Write every file or none (see :func:`hbtp.files.write_all_atomically`)."""
    write_all_atomically(dict(files))
