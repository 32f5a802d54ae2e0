"""The one table of ``hbtp``'s exit codes, and the one form of its error messages.

=====  ==================================================================================
code   meaning
=====  ==================================================================================
0      success: solved, goal reached, nothing wrong found
1      not solved (unsolvable, time or node limit), goal not reached, verification failed,
       or a dataset with invalid records
2      bad input or usage, or an LLM backend that cannot run: one line ``hbtp: error: ...``
3      an internal error (a bug, also one inside a search: run with ``--debug`` for the traceback
       and please report it)
130    interrupted (Ctrl-C)
=====  ==================================================================================

Every error is reported on standard error as one line that starts with :data:`ERROR_PREFIX`
(click's usage errors keep their usage line above it).
"""

from __future__ import annotations

import enum
import re
from typing import IO, TYPE_CHECKING, Any

import click

from hbtp.errors import HbtpError, PlanningError

if TYPE_CHECKING:
    from hbtp.planning.result import Status

ERROR_PREFIX = "hbtp: error: "


class ExitCode(enum.IntEnum):
    OK = 0
    NOT_SOLVED = 1
    INPUT = 2
    INTERNAL = 3
    INTERRUPTED = 130


#: The longest run of input (a name, a token: characters without white space) a message echoes.
MAX_ECHO = 200
#: The longest message a line carries.
MAX_LINE = 2_000
_LONG_RUN = re.compile(rf"\S{{{MAX_ECHO + 1},}}")


def shorten(text: str) -> str:
    """``text`` with every run of more than :data:`MAX_ECHO` non-space characters cut (and its
    length said), and cut after :data:`MAX_LINE` characters: input echoed in full once made a
    2 MB error line."""
    text = _LONG_RUN.sub(lambda run: f"{run.group()[:MAX_ECHO]}... ({len(run.group()):,} characters)", text)
    return text if len(text) <= MAX_LINE else f"{text[:MAX_LINE]}... ({len(text):,} characters)"


def error_line(message: str) -> str:
    """``hbtp: error: message`` on one line (a multi-line message is joined with ``; ``), echoed
    input shortened (:func:`shorten`)."""
    parts = [part.strip() for part in str(message).splitlines() if part.strip()]
    return ERROR_PREFIX + shorten("; ".join(parts))


def exit_code_for(error: HbtpError) -> ExitCode:
    """The exit code of an hbtp error: 1 for a planning run that cannot start, else 2."""
    return ExitCode.NOT_SOLVED if isinstance(error, PlanningError) else ExitCode.INPUT


def plan_exit_code(status: Status) -> ExitCode:
    """The exit code of a planning run that ended with ``status``: 0 solved, 3 an internal error of
    the search, 1 otherwise (unsolvable, a time, node or memory limit)."""
    from hbtp.planning.result import Status  # here, not at the top: `hbtp --version` stays light

    if status.solved:
        return ExitCode.OK
    return ExitCode.INTERNAL if status is Status.ERROR else ExitCode.NOT_SOLVED


class CommandError(click.ClickException):
    """Bad input that ends a command with exit code 2 and one ``hbtp: error: ...`` line, under
    ``hbtp`` and when a command is invoked on its own (click's ``CliRunner``)."""

    exit_code = int(ExitCode.INPUT)

    def show(self, file: IO[Any] | None = None) -> None:
        click.echo(error_line(self.format_message()), file=file, err=file is None)


class NotSolvedError(CommandError):
    """Like :class:`CommandError`, with exit code 1 (a planning run that cannot start)."""

    exit_code = int(ExitCode.NOT_SOLVED)


def command_error(error: HbtpError) -> CommandError:
    """The click exception that reports ``error`` with its exit code (:func:`exit_code_for`)."""
    kind = NotSolvedError if exit_code_for(error) is ExitCode.NOT_SOLVED else CommandError
    return kind(str(error))


__all__ = [
    "ERROR_PREFIX",
    "CommandError",
    "ExitCode",
    "NotSolvedError",
    "command_error",
    "error_line",
    "exit_code_for",
    "plan_exit_code",
]
