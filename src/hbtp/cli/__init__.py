"""The ``hbtp`` command line.

Exit codes (one table, :class:`hbtp.cli.exit_codes.ExitCode`): 0 success; 1 the task was not solved
(unsolvable, time or node limit), a run did not reach the goal, a tree failed verification, or a
dataset has invalid records; 2 bad input or usage, or an LLM backend that cannot run; 3 an internal
error (a bug: run with ``--debug`` for the traceback and please report it). Every error is one line
on standard error starting with ``hbtp: error:``. A closed standard output (``hbtp plan ... | head``)
does not change the exit code: the rest of the output is discarded.
"""

from __future__ import annotations

import errno
import logging
import os
import sys
import traceback
from typing import IO, Any, cast

import click

from hbtp import __version__
from hbtp.cli.bench_commands import bench
from hbtp.cli.dataset_commands import dataset
from hbtp.cli.domain_commands import export_pddl, ground, scenarios
from hbtp.cli.examples_command import examples
from hbtp.cli.exit_codes import ExitCode, error_line, exit_code_for
from hbtp.cli.export_command import export_command
from hbtp.cli.plan_command import plan_command
from hbtp.cli.robustness_command import robustness
from hbtp.cli.run_command import run_command, verify_command
from hbtp.cli.validate_command import validate_optimal
from hbtp.cli.view_command import view_command
from hbtp.errors import HbtpError

EXIT_OK, EXIT_NOT_SOLVED, EXIT_INPUT, EXIT_INTERNAL = (
    ExitCode.OK,
    ExitCode.NOT_SOLVED,
    ExitCode.INPUT,
    ExitCode.INTERNAL,
)


@click.group(context_settings={"help_option_names": ["-h", "--help"]})
@click.version_option(__version__, prog_name="hbtp")
@click.option("-v", "--verbose", count=True, help="More log output on stderr (-vv for debug).")
@click.option("--debug", is_flag=True, help="Show tracebacks of errors.")
def cli(verbose: int, debug: bool) -> None:
    """hbtp: plan behavior trees that provably reach a goal, guided by LLM reasoning."""
    level = logging.WARNING if verbose == 0 else logging.INFO if verbose == 1 else logging.DEBUG
    logging.basicConfig(level=level, format="%(levelname)s %(name)s: %(message)s", stream=sys.stderr)


cli.add_command(scenarios)
cli.add_command(ground)
cli.add_command(export_pddl)
cli.add_command(dataset)
cli.add_command(plan_command)
cli.add_command(bench)
cli.add_command(export_command)
cli.add_command(run_command)
cli.add_command(verify_command)
cli.add_command(view_command)
bench.add_command(robustness)
cli.add_command(validate_optimal)
cli.add_command(examples)


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


def _report_click_error(error: click.ClickException) -> int:
    """The one ``hbtp: error:`` line, ending for a usage error with where the help is; the help
    for a bare ``hbtp`` (exit code 2, as click does)."""
    if isinstance(error, click.exceptions.NoArgsIsHelpError):
        error.show()
        return ExitCode.INPUT
    message = error.format_message()
    if isinstance(error, click.UsageError) and error.ctx is not None:
        help_option = next(iter(error.ctx.help_option_names), None)
        if help_option is not None and error.ctx.command.get_help_option(error.ctx) is not None:
            message += f" (see '{error.ctx.command_path} {help_option}')"
    click.echo(error_line(message), err=True)
    return error.exit_code if error.exit_code in (ExitCode.NOT_SOLVED, ExitCode.INPUT) else ExitCode.INPUT


def _run(args: list[str], debug: bool) -> int:
    try:
        result = cli.main(args=args, prog_name="hbtp", standalone_mode=False)
    except click.exceptions.Exit as stop:
        return int(stop.exit_code)
    except click.ClickException as error:
        return _report_click_error(error)
    except click.Abort:
        click.echo(error_line("aborted"), err=True)
        return ExitCode.INPUT
    except HbtpError as error:
        if debug:
            traceback.print_exc()
        click.echo(error_line(str(error)), err=True)
        return exit_code_for(error)
    except KeyboardInterrupt:
        click.echo("hbtp: interrupted", err=True)
        return ExitCode.INTERRUPTED
    except Exception as error:  # a bug: say so in one line unless --debug
        if debug:
            traceback.print_exc()
        click.echo(
            error_line(f"internal error: {type(error).__name__}: {error} (run with --debug for details)"), err=True
        )
        return ExitCode.INTERNAL
    return result if isinstance(result, int) else ExitCode.OK


def main(argv: list[str] | None = None) -> int:
    """Run the command line; returns the exit code (see :mod:`hbtp.cli.exit_codes`)."""
    args = list(sys.argv[1:] if argv is None else argv)
    original = sys.stdout
    output = cast(IO[str], _PipeSafeOutput(original))
    sys.stdout = output
    try:
        code = _run(args, "--debug" in args)
        output.flush()
    finally:
        if sys.stdout is output:
            sys.stdout = original
    return int(code)


__all__ = ["EXIT_INPUT", "EXIT_INTERNAL", "EXIT_NOT_SOLVED", "EXIT_OK", "ExitCode", "cli", "main"]
