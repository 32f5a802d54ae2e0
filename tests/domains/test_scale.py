"""Larger scenarios by cloning objects (Figure 3's generator), and hbtp bench fig3."""

from __future__ import annotations

import json
from pathlib import Path

import pytest

from hbtp.cli import main
from hbtp.domains import load_scenario
from hbtp.domains.pddl_reader import read_domain_file, read_problem_file
from hbtp.domains.scale import clone_objects, scaled_scenario
from hbtp.errors import InputError
from hbtp.planning import plan


def test_clones_copy_every_fact_and_keep_the_originals() -> None:
    base = load_scenario("robothow-small")
    domain = read_domain_file(base.domain_file)
    problem = read_problem_file(base.problem_file, domain)
    bigger = clone_objects(problem, 2.0)
    names = [o.name for o in bigger.objects]
    assert len(names) == 2 * len(problem.objects)
    assert len(set(names)) == len(names)
    assert "apple2" in names
    assert "fridge2" in names
    facts = {(f.predicate, f.terms) for f in bigger.init}
    assert {(f.predicate, f.terms) for f in problem.init} <= facts
    assert ("grabbable", ("apple2",)) in facts
    assert ("IsClose", ("fridge2",)) in facts
    with pytest.raises(InputError):
        clone_objects(problem, 0.5)


def test_scaled_scenarios_keep_the_original_optima() -> None:
    base = load_scenario("robothow-small")
    bigger = scaled_scenario("robothow-small", 2.0)
    assert len(bigger.task.actions) > 3 * len(base.task.actions)
    for goal in ("IsIn_apple_fridge & IsClose_fridge", "IsClean_tv & IsCut_cutlets", "IsSwitchedOn_candle"):
        small = plan(base.task, goal, "obtea", mutexes=base.mutexes, heuristic="lm")
        large = plan(bigger.task, goal, "obtea", mutexes=bigger.mutexes, heuristic="lm")
        assert small.solved
        assert large.solved
        assert large.cost == small.cost, goal


def test_fig3_command(tmp_path: Path) -> None:
    out = tmp_path / "fig3"
    code = main(
        ["bench", "fig3", "--scales", "1,1.2", "--limit", "2", "--heuristic", "lm", "--no-progress", "-o", str(out)]
    )
    assert code == 0
    summary = json.loads((out / "summary.json").read_text(encoding="utf-8"))
    sizes = {cell["scale"]: cell["actions"] for cell in summary["by_action_space"]}
    assert sizes[1.2] > sizes[1.0] == 7329
    assert all(cell["solved"] == cell["tasks"] == 2 for cell in summary["by_action_space"] if cell["planner"] != "bte")
    assert main(["bench", "fig3", "--scales", "0.5", "-o", str(out)]) == 2
