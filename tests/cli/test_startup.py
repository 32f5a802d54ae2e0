"""A command imports only what it needs: ``hbtp --version`` none of the commands, ``hbtp plan`` not
the benchmarks (each command's module is loaded when it is asked for; see hbtp.cli.COMMANDS). The
times these give are measured by docs/benchmarks.md's startup table, not asserted here."""

from __future__ import annotations

import json
import subprocess
import sys

import pytest


def _modules_after(*argv: str) -> set[str]:
    code = (
        "import json, sys\n"
        "from hbtp.cli import main\n"
        f"code = main({list(argv)!r})\n"
        "sys.stderr.write(json.dumps(sorted(m for m in sys.modules if m.startswith('hbtp'))))\n"
    )
    done = subprocess.run([sys.executable, "-c", code], capture_output=True, text=True, timeout=120)
    return set(json.loads(done.stderr.strip().splitlines()[-1]))


def test_version_imports_no_command() -> None:
    loaded = _modules_after("--version")
    assert not {name for name in loaded if name.startswith(("hbtp.planning", "hbtp.bench", "hbtp.domains"))}
    assert not {name for name in loaded if name.startswith("hbtp.cli.") and name.endswith(("_command", "_commands"))}


@pytest.mark.parametrize("argv", [("plan", "-s", "robowaiter", "-g", "Exists_Coffee"), ("run", "--help")])
def test_plan_and_run_do_not_import_the_benchmarks(argv: tuple[str, ...]) -> None:
    loaded = _modules_after(*argv)
    assert "hbtp.cli.bench_commands" not in loaded
    assert not {name for name in loaded if name.startswith("hbtp.bench")}, sorted(loaded)
