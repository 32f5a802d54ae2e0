"""The ``hbtp`` command line.

Exit codes: 0 success; 1 the task was not solved (unsolvable, time or node limit) or a dataset has
invalid records; 2 bad input or usage, or an LLM backend that cannot run (a one-line message, no
traceback); 3 an internal error (a bug: run with ``--debug`` for the traceback and please report it).
"""

from __future__ import annotations

import logging
import sys
import traceback

import click

from hbtp import __version__
from hbtp.cli.bench_commands import bench
from hbtp.cli.dataset_commands import dataset
from hbtp.cli.domain_commands import export_pddl, ground, scenarios
from hbtp.cli.export_command import export_command
from hbtp.cli.plan_command import plan_command
from hbtp.cli.robustness_command import robustness
from hbtp.cli.run_command import run_command, verify_command
from hbtp.cli.validate_command import validate_optimal
from hbtp.errors import HbtpError, PlanningError

EXIT_OK, EXIT_NOT_SOLVED, EXIT_INPUT, EXIT_INTERNAL = 0, 1, 2, 3


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
bench.add_command(robustness)
cli.add_command(validate_optimal)


def main(argv: list[str] | None = None) -> int:
    """Run the command line; returns the exit code (see the module docstring)."""
    args = list(sys.argv[1:] if argv is None else argv)
    debug = "--debug" in args
    try:
        result = cli.main(args=args, prog_name="hbtp", standalone_mode=False)
    except click.exceptions.Exit as stop:
        return int(stop.exit_code)
    except click.ClickException as error:
        error.show()
        return EXIT_INPUT
    except click.Abort:
        click.echo("hbtp: aborted", err=True)
        return EXIT_INPUT
    except HbtpError as error:
        if debug:
            traceback.print_exc()
        click.echo(f"hbtp: error: {error}", err=True)
        return EXIT_NOT_SOLVED if isinstance(error, PlanningError) else EXIT_INPUT
    except KeyboardInterrupt:
        click.echo("hbtp: interrupted", err=True)
        return 130
    except Exception as error:  # a bug: say so in one line unless --debug
        if debug:
            traceback.print_exc()
        click.echo(f"hbtp: internal error: {type(error).__name__}: {error} (run with --debug for details)", err=True)
        return EXIT_INTERNAL
    return result if isinstance(result, int) else EXIT_OK


__all__ = ["EXIT_INPUT", "EXIT_INTERNAL", "EXIT_NOT_SOLVED", "EXIT_OK", "cli", "main"]
