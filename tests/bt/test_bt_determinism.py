"""Determinism across processes: ``hbtp plan -o ... --export ...`` under two hash seeds, diffed byte for byte.

Set iteration order depends on ``PYTHONHASHSEED`` (strings hash differently in every process), so
planning and exporting twice in one process cannot show that the output depends on nothing but
the input. Here two processes with different seeds plan the same tasks (several scenarios and
planners, full, path and compacted trees) and write the JSON tree and its BT.CPP XML, py_trees
and DOT exports; every file must be the same in both.
"""

from __future__ import annotations

import json
import os
import subprocess
import sys
from pathlib import Path

from hbtp.datasets import load_dataset
from hbtp.domains import load_scenario

#: (scenario, planner, extra ``hbtp plan`` options); the goal is the scenario's first test task.
CASES = (
    ("robowaiter", "hbtp-s", ()),
    ("virtualhome", "obtea", ("--tree", "path")),
    ("robothow-small", "bte", ("--heuristic", "none", "--compact")),
    ("robothow", "hbtp-o", ("--hints", "oracle")),
)
EXPORTS = ("xml", "py", "dot")

#: Runs ``hbtp plan`` in-process for every case and export, into the folder given.
DRIVER = """
import json, sys
from hbtp.cli import main
out, cases = sys.argv[1], json.loads(sys.argv[2])
for name, argv in cases:
    code = main(["plan", *argv, "-o", f"{out}/{name}.json", "--export", f"{out}/{name}"])
    if code != 0:
        sys.exit(f"{name}: exit code {code}")
"""


def _commands() -> list[tuple[str, list[str]]]:
    commands = []
    for index, (scenario, planner, options) in enumerate(CASES):
        test_set = load_scenario(scenario).test_set
        assert test_set is not None
        goal = load_dataset(test_set)[0].goal
        argv = ["-s", scenario, "-g", goal, "-p", planner, *options]
        commands += [(f"case{index}-{planner}.{ext}", argv) for ext in EXPORTS]
    return commands


def test_plan_and_exports_are_byte_identical_under_two_hash_seeds(tmp_path: Path) -> None:
    commands = json.dumps(_commands())
    processes = {}
    for seed in ("1", "4242"):
        out = tmp_path / f"seed{seed}"
        out.mkdir()
        env = {**os.environ, "PYTHONHASHSEED": seed}
        processes[out] = subprocess.Popen(
            [sys.executable, "-c", DRIVER, str(out), commands],
            env=env,
            stdout=subprocess.DEVNULL,
            stderr=subprocess.PIPE,
            text=True,
        )
    for process in processes.values():
        _, errors = process.communicate(timeout=300)
        assert process.returncode == 0, errors
    first, second = processes
    names = sorted(path.name for path in first.iterdir())
    assert names == sorted(path.name for path in second.iterdir())
    assert len(names) == 2 * len(CASES) * len(EXPORTS)  # a JSON tree and an export per command
    for name in names:
        assert (first / name).read_bytes() == (second / name).read_bytes(), name
    # the three plans of a case agree too (planning twice in one process gives the same tree)
    for index, (_, planner, _) in enumerate(CASES):
        trees = {(first / f"case{index}-{planner}.{ext}.json").read_bytes() for ext in EXPORTS}
        assert len(trees) == 1, index
