"""The ``hbtp`` command line.

Exit codes (one table, :class:`hbtp.cli.exit_codes.ExitCode`): 0 success; 1 the task was not solved
(unsolvable, time or node limit), a run did not reach the goal, a tree failed verification, or a
dataset has invalid records; 2 bad input or usage, or an LLM backend that cannot run; 3 an internal
error (a bug: run with ``--debug`` for the traceback and please report it). Every error is one line
on standard error starting with ``hbtp: error:``. A closed standard output (``hbtp plan ... | head``)
does not change the exit code: the rest of the output is discarded.
"""

from __future__ import annotations

import contextlib
import errno
import logging
import os
import sys
import time
import traceback
from typing import IO, Any, cast

import click

from hbtp import __version__
from hbtp.cli.exit_codes import ExitCode, error_line, exit_code_for, shorten
from hbtp.cli.lazy import LazyGroup
from hbtp.collector import searches_frozen
from hbtp.errors import HbtpError

#: Each command and where it lives (``module:attribute``): a command's module, and what it needs, is
#: imported only when that command runs (``hbtp --version`` imports none of them).
COMMANDS: dict[str, str] = {
    "bench": "hbtp.cli.bench_commands:bench",
    "dataset": "hbtp.cli.dataset_commands:dataset",
    "examples": "hbtp.cli.examples_command:examples",
    "export": "hbtp.cli.export_command:export_command",
    "export-pddl": "hbtp.cli.domain_commands:export_pddl",
    "ground": "hbtp.cli.domain_commands:ground",
    "plan": "hbtp.cli.plan_command:plan_command",
    "run": "hbtp.cli.run_command:run_command",
    "scenarios": "hbtp.cli.domain_commands:scenarios",
    "train": "hbtp.cli.train_command:train_command",
    "validate-optimal": "hbtp.cli.validate_command:validate_optimal",
    "verify": "hbtp.cli.run_command:verify_command",
    "view": "hbtp.cli.view_command:view_command",
}


EXIT_OK, EXIT_NOT_SOLVED, EXIT_INPUT, EXIT_INTERNAL = (
    ExitCode.OK,
    ExitCode.NOT_SOLVED,
    ExitCode.INPUT,
    ExitCode.INTERNAL,
)


#: Seconds from a command's start during which its warnings are held (see :class:`_CommandLog`).
HOLD_WARNINGS_S = 2.0


class _CommandLog(logging.Handler):
    """The log of one command on standard error, echoed input shortened.

    Without ``-v``, the warnings of the command's first :data:`HOLD_WARNINGS_S` seconds are held:
    when the command then fails (bad input is found at once), its error is the only line, ending
    with how many warnings ``-v`` shows; otherwise they are written once the hold is over or the
    command ends. Later records are written as they come."""

    def __init__(self) -> None:
        super().__init__()
        self.setFormatter(logging.Formatter("%(levelname)s %(name)s: %(message)s"))
        self.until = time.monotonic() + HOLD_WARNINGS_S
        self.held: list[logging.LogRecord] | None = []

    def emit(self, record: logging.LogRecord) -> None:
        if self.held is not None and time.monotonic() < self.until:
            self.held.append(record)
            return
        self.write_held()
        self._write(record)

    def _write(self, record: logging.LogRecord) -> None:
        with contextlib.suppress(OSError, ValueError):  # a closed standard error
            sys.stderr.write(shorten(self.format(record)) + "\n")

    def write_held(self) -> None:
        """Write the held records (and hold no more)."""
        held, self.held = self.held or [], None
        for record in held:
            self._write(record)

    def drop(self) -> int:
        """Forget the held records (an error is being reported instead); how many there were."""
        held, self.held = self.held or [], None
        return len(held)


@click.group(cls=LazyGroup, lazy=COMMANDS, context_settings={"help_option_names": ["-h", "--help"]})
@click.version_option(__version__, prog_name="hbtp")
@click.option("-v", "--verbose", count=True, help="More log output on stderr (-vv for debug).")
@click.option("--debug", is_flag=True, help="Show tracebacks of errors.")
@click.pass_context
def cli(context: click.Context, verbose: int, debug: bool) -> None:
    """hbtp: plan behavior trees that provably reach a goal, guided by LLM reasoning."""
    level = logging.WARNING if verbose == 0 else logging.INFO if verbose == 1 else logging.DEBUG
    logging.getLogger().setLevel(level)
    if verbose and isinstance(context.obj, _CommandLog):
        context.obj.write_held()  # with -v, everything as it comes


class _PipeSafeOutput:
    """Standard output that survives a closed pipe: on EPIPE the file descriptor is pointed at
    ``os.devnull`` (the recipe of Python's ``signal`` documentation) and the rest of the output is
    dropped, so the command finishes and exits with its own code."""

    def __init__(self, stream: IO[str]) -> None:
        self._stream = stream
        self.broken = False

    def _discard(self) -> None:
        self.broken = True
        try:
            devnull = os.open(os.devnull, os.O_WRONLY)
            os.dup2(devnull, self._stream.fileno())
            os.close(devnull)
        except (OSError, ValueError, AttributeError):  # not a real file (tests capture it)
            pass

    def write(self, text: str) -> int:
        if not self.broken:
            try:
                return self._stream.write(text)
            except OSError as error:
                if not _is_broken_pipe(error):
                    raise
                self._discard()
        return len(text)

    def flush(self) -> None:
        if not self.broken:
            try:
                self._stream.flush()
            except OSError as error:
                if not _is_broken_pipe(error):
                    raise
                self._discard()

    def __getattr__(self, name: str) -> Any:
        return getattr(self._stream, name)


def _is_broken_pipe(error: OSError) -> bool:
    return isinstance(error, BrokenPipeError) or error.errno == errno.EPIPE


def _click_message(error: click.ClickException) -> str:
    """Click's message, ending for a usage error with where the help is."""
    message = error.format_message()
    if isinstance(error, click.UsageError) and error.ctx is not None:
        help_option = next(iter(error.ctx.help_option_names), None)
        if help_option is not None and error.ctx.command.get_help_option(error.ctx) is not None:
            message += f" (see '{error.ctx.command_path} {help_option}')"
    return message


def _run(args: list[str], debug: bool, command_log: _CommandLog) -> int:
    """The command's exit code; an error is reported as its one line (see :class:`_CommandLog`)."""

    def report(message: str) -> None:
        held = command_log.drop()
        note = f" ({held} warning{'s' if held > 1 else ''} before it: -v shows {'them' if held > 1 else 'it'})"
        click.echo(error_line(message + (note if held else "")), err=True)

    try:
        result = cli.main(args=args, prog_name="hbtp", standalone_mode=False, obj=command_log)
    except click.exceptions.Exit as stop:
        return int(stop.exit_code)
    except click.exceptions.NoArgsIsHelpError as error:  # a bare `hbtp`: the help, exit code 2 as click does
        error.show()
        return ExitCode.INPUT
    except click.ClickException as error:
        report(_click_message(error))
        return error.exit_code if error.exit_code in (ExitCode.NOT_SOLVED, ExitCode.INPUT) else ExitCode.INPUT
    except click.Abort:
        report("aborted")
        return ExitCode.INPUT
    except HbtpError as error:
        if debug:
            traceback.print_exc()
        report(str(error))
        return exit_code_for(error)
    except KeyboardInterrupt:
        click.echo("hbtp: interrupted", err=True)
        return ExitCode.INTERRUPTED
    except Exception as error:  # a bug: say so in one line unless --debug
        if debug:
            traceback.print_exc()
        report(f"internal error: {type(error).__name__}: {error} (run with --debug for details)")
        return ExitCode.INTERNAL
    return result if isinstance(result, int) else ExitCode.OK


def main(argv: list[str] | None = None) -> int:
    """Run the command line; returns the exit code (see :mod:`hbtp.cli.exit_codes`)."""
    args = list(sys.argv[1:] if argv is None else argv)
    original = sys.stdout
    output = cast(IO[str], _PipeSafeOutput(original))
    sys.stdout = output
    root = logging.getLogger()
    command_log, level = _CommandLog(), root.level
    root.addHandler(command_log)
    try:
        with searches_frozen():  # a command is a short-lived process (see hbtp.collector)
            code = _run(args, "--debug" in args, command_log)
        output.flush()
    finally:
        command_log.write_held()
        root.removeHandler(command_log)
        root.setLevel(level)
        if sys.stdout is output:
            sys.stdout = original
    return int(code)


__all__ = ["EXIT_INPUT", "EXIT_INTERNAL", "EXIT_NOT_SOLVED", "EXIT_OK", "ExitCode", "cli", "main"]
