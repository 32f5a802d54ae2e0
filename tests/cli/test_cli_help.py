"""Every option of every ``hbtp`` command has a help text, and every argument is named in its
command's description (issue 14, item 13: ``--tree``, ``--seed``, ``--feedback-rounds`` had none)."""

from __future__ import annotations

from collections.abc import Iterator

import click
import pytest

from hbtp.cli import cli, main


def _commands(command: click.Command, path: tuple[str, ...]) -> Iterator[tuple[str, click.Command]]:
    yield " ".join(path), command
    if isinstance(command, click.Group):  # a LazyGroup imports its commands here
        context = click.Context(command)
        for name in command.list_commands(context):
            sub = command.get_command(context, name)
            assert sub is not None, name
            yield from _commands(sub, (*path, name))


COMMANDS = dict(_commands(cli, ("hbtp",)))


def test_the_commands_are_all_found() -> None:
    assert {"hbtp plan", "hbtp run", "hbtp bench table2", "hbtp bench robustness", "hbtp dataset validate"} <= set(
        COMMANDS
    )


@pytest.mark.parametrize("name", sorted(COMMANDS))
def test_every_option_has_help_and_every_argument_is_described(name: str) -> None:
    command = COMMANDS[name]
    assert (command.help or "").strip(), f"{name} has no description"
    missing = [
        "/".join(param.opts)
        for param in command.params
        if isinstance(param, click.Option) and not param.hidden and not (param.help or "").strip()
    ]
    assert missing == [], f"{name}: options without help: {missing}"
    for param in command.params:
        if isinstance(param, click.Argument):
            assert param.human_readable_name in (command.help or ""), f"{name}: {param.human_readable_name}"


@pytest.mark.parametrize(
    ("option", "word"),
    [("--tree", "solution path"), ("--seed", "Seed"), ("--feedback-rounds", "feedback"), ("--goal", "@FILE")],
)
def test_plan_help_shows_the_options_of_the_issue(capsys: pytest.CaptureFixture[str], option: str, word: str) -> None:
    (param,) = [p for p in COMMANDS["hbtp plan"].params if option in p.opts]
    assert isinstance(param, click.Option)
    assert word in (param.help or "")
    assert main(["plan", "--help"]) == 0
    shown = " ".join(capsys.readouterr().out.split())
    assert " ".join((param.help or "").split()[:4]) in shown  # (click may break a line at a hyphen)
