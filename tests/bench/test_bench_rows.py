"""Benchmark rows as typed values: every row type reads a stored ``results.jsonl`` line and writes
it back byte for byte, a killed run's line is the one the benchmarks have always written, a line
from an older file without a later field still loads with the default the summaries assume, and a
line without a key field is a one-line error."""

from __future__ import annotations

import json
from pathlib import Path
from types import ModuleType
from typing import Any

import pytest

from hbtp.bench import fig3, fig4, payoff, robustness, table1, table2
from hbtp.bench.fig3 import Fig3Config, Fig3Row
from hbtp.bench.fig4 import Fig4Config, Fig4Row
from hbtp.bench.instructions import InstructionRow
from hbtp.bench.payoff import BEST_FREE, PayoffConfig, PayoffRow, World, _known
from hbtp.bench.pddl_suite import Instance, PddlRow, PddlRun, ground_ratios, known
from hbtp.bench.results import JsonObject, ResultsFile, Row
from hbtp.bench.robustness import RobustnessConfig, RobustnessRow
from hbtp.bench.runner import INLINE, RunFailure, Work, failed_rows
from hbtp.bench.table1 import Table1Config, Table1Row
from hbtp.bench.table2 import BackendRecipe, Table2Config, Table2Row
from hbtp.datasets import load_dataset
from hbtp.errors import InputError
from hbtp.llm.backends.registry import LlmSpec
from hbtp.planning.planners import Space

#: Lines of results files (as JSON objects) written before the rows were typed: a finished run's,
#: other shapes a benchmark writes, and a killed run's (the last of each list, with 1.5 s).
STORED: dict[type[Row], list[JsonObject]] = {
    Table1Row: [
        {
            "action_space": 4,
            "cost": 41,
            "explored": 5,
            "generated": 4,
            "goal": "IsOn_chips_desk",
            "heuristic": "none",
            "hints": "oracle",
            "p_star": 4,
            "planner": "bte",
            "solved": True,
            "space": "pruned",
            "status": "solved",
            "task": "1",
            "time_s": 0.004718,
        },
        {
            "cost": None,
            "explored": None,
            "heuristic": "none",
            "hints": "oracle",
            "p_star": 4,
            "planner": "bte",
            "solved": False,
            "space": "pruned",
            "status": "killed",
            "task": "1",
            "time_s": 1.5,
        },
    ],
    Fig3Row: [
        {
            "action_space": 4,
            "actions": 7329,
            "explored": 5,
            "heuristic": "none",
            "p_star": 4,
            "planner": "obtea",
            "scale": 1.0,
            "solved": True,
            "space": "pruned",
            "status": "solved",
            "task": "1",
            "time_s": 0.004394,
        },
        {
            "explored": None,
            "heuristic": "none",
            "p_star": 4,
            "planner": "obtea",
            "scale": 1.0,
            "solved": False,
            "space": "pruned",
            "status": "killed",
            "task": "1",
            "time_s": 1.5,
        },
    ],
    Fig4Row: [
        {
            "action_space": 4,
            "correct": 0.5,
            "cost": 41,
            "error": 0.0,
            "explored": 5,
            "p_hat": 3,
            "p_star": 4,
            "planner": "hbtp-o",
            "seed": 0,
            "solved": True,
            "status": "solved",
            "task": "1",
            "time_s": 0.004478,
        },
        {
            "correct": 0.5,
            "cost": None,
            "error": 0.0,
            "explored": None,
            "planner": "hbtp-o",
            "seed": 0,
            "solved": False,
            "status": "killed",
            "task": "1",
            "time_s": 1.5,
        },
    ],
    Table2Row: [
        {
            "A_star": 1,
            "action_space": 1,
            "b_lm_solved": True,
            "b_lm_time_s": 8.9e-05,
            "b_solved": True,
            "b_time_s": 5.7e-05,
            "backend": "oracle",
            "cost": 5,
            "errors": [],
            "explored": 2,
            "goal": "Exists_Coffee",
            "llm_s": 0.000851,
            "outcome": "NF",
            "p_hat": 1,
            "p_star": 1,
            "planning_s": 0.000349,
            "repairs": 0,
            "rounds": 1,
            "run": 0,
            "scenario": "robowaiter",
            "solved": True,
            "task": "1",
        },
        {
            "A_star": 7,
            "action_space": 14,
            "backend": "noisy-oracle",
            "cost": 59,
            "errors": [],
            "explored": 13,
            "goal": "IsIn_cutlets_fridge & IsClose_fridge",
            "llm_s": 0.000707,
            "outcome": "1F",
            "p_hat": 8,
            "p_star": 7,
            "planning_s": 0.000516,
            "repairs": 0,
            "rounds": 2,
            "run": 1,
            "scenario": "robothow-small",
            "solved": True,
            "task": "1",
        },
        {
            "A_star": 9,
            "action_space": None,
            "backend": "noisy-oracle",
            "cost": 61,
            "errors": ["round 1: no plan in the pruned space", "round 2: no plan in the pruned space"],
            "explored": 40,
            "goal": "IsIn_milk_fridge & IsClose_fridge",
            "llm_s": 0.0011,
            "outcome": "fallback",
            "p_hat": None,
            "p_star": 7,
            "planning_s": 0.2,
            "repairs": 1,
            "rounds": 4,
            "run": 0,
            "scenario": "robothow-small",
            "solved": True,
            "task": "9",
        },
        {
            "backend": "oracle",
            "errors": ["killed"],
            "goal": "Exists_Coffee",
            "outcome": "failed",
            "rounds": 0,
            "run": 0,
            "scenario": "robowaiter",
            "solved": False,
            "status": "killed",
            "task": "1",
            "time_s": 1.5,
        },
    ],
    RobustnessRow: [
        {
            "base_cost": 5,
            "base_reached": True,
            "base_ticks": 2,
            "condition_checks": 3,
            "dataset": "table2_robowaiter_50",
            "explored": 2,
            "goal": "Exists_Coffee",
            "heuristic": "lm",
            "limit_hits": 0,
            "max_ticks": 500,
            "mean_cost": 5.0,
            "mean_events": 0.333333,
            "mean_extra_cost": 0.0,
            "mean_extra_ticks": 0.0,
            "mean_ticks": 2.0,
            "nodes": 5,
            "p": 0.2,
            "plan_cost": 5,
            "plan_time_s": 0.001013,
            "planned_with": "hbtp-s/pruned",
            "planner": "hbtp-s",
            "robust": 0,
            "runs": 3,
            "scenario": "robowaiter",
            "seed": 0,
            "solved": True,
            "success_rate": 1.0,
            "successes": 3,
            "task": "1",
            "tree": "full",
        },
        {
            "base_cost": 5,
            "base_reached": True,
            "base_ticks": 2,
            "budget_runs": 0,
            "condition_checks": 3,
            "dataset": "table2_robowaiter_50",
            "explored": 2,
            "goal": "Exists_Coffee",
            "heuristic": "lm",
            "limit_hits": 0,
            "max_replan_ms": None,
            "max_ticks": 500,
            "mean_cost": 5.0,
            "mean_events": 0.333333,
            "mean_extra_cost": 0.0,
            "mean_extra_ticks": 0.0,
            "mean_replans": 0.0,
            "mean_ticks": 2.0,
            "median_replan_ms": None,
            "nodes": 5,
            "p": 0.2,
            "plan_cost": 5,
            "plan_time_s": 0.001013,
            "planned_with": "hbtp-s/pruned",
            "planner": "hbtp-s",
            "replans": 0,
            "robust": 0,
            "runs": 3,
            "scenario": "robowaiter",
            "seed": 0,
            "solved": True,
            "success_rate": 1.0,
            "success_rate_reachable": 1.0,
            "successes": 3,
            "task": "1",
            "tree": "path+replan",
            "unsolvable_runs": 0,
        },
        {
            "condition_checks": None,
            "dataset": "table2_robowaiter_50",
            "explored": 6,
            "goal": "On_Water_Table1",
            "heuristic": "lm",
            "max_ticks": 500,
            "mean_extra_cost": None,
            "mean_extra_ticks": None,
            "nodes": None,
            "p": 0.2,
            "plan_cost": None,
            "plan_time_s": 0.000631,
            "planned_with": "obtea/full",
            "planner": "hbtp-s",
            "robust": 0,
            "runs": 3,
            "scenario": "robowaiter",
            "seed": 0,
            "solved": False,
            "success_rate": 0.0,
            "successes": 0,
            "task": "2",
            "tree": "full+replan",
        },
        {
            "dataset": "table2_robowaiter_50",
            "explored": None,
            "goal": "Exists_Coffee",
            "heuristic": "lm",
            "max_ticks": 500,
            "mean_extra_cost": None,
            "mean_extra_ticks": None,
            "nodes": None,
            "p": 0.2,
            "planned_with": "killed",
            "planner": "hbtp-s",
            "robust": 0,
            "runs": 3,
            "scenario": "robowaiter",
            "seed": 0,
            "solved": False,
            "status": "killed",
            "success_rate": 0.0,
            "successes": 0,
            "task": "1",
            "time_s": 1.5,
            "tree": "full",
        },
    ],
    PayoffRow: [
        {
            "actions": 174,
            "axis": "set",
            "cell": "robowaiter",
            "config": "obtea+lm",
            "cost": 5,
            "explored": 2,
            "load_kind": "shipped (disk cache)",
            "load_s": 0.001831,
            "model_s": 0.0,
            "p_star": 1,
            "planning_s": 0.000736,
            "resident_mb": 56,
            "scale": 1.0,
            "scenario": "robowaiter",
            "solve_s": 0.000858,
            "solved": True,
            "status": "solved",
            "task": "1",
            "total_s": 0.002688,
            "verified": True,
            "verify_s": 0.000122,
        },
        {
            "actions": 174,
            "axis": "set",
            "backend_s": 0.000203,
            "backend_setup_s": 3.1e-05,
            "cell": "robowaiter",
            "config": "hbtp:noisy-oracle",
            "cost": 5,
            "explored": 2,
            "load_kind": "shipped (disk cache)",
            "load_s": 0.001831,
            "model_s": 0.0,
            "outcome": "1F",
            "p_star": 1,
            "planning_s": 0.001623,
            "resident_mb": 56,
            "rounds": 2,
            "scale": 1.0,
            "scenario": "robowaiter",
            "solve_s": 0.001686,
            "solved": True,
            "status": "solved",
            "task": "1",
            "total_s": 0.003516,
            "verified": True,
            "verify_s": 6.2e-05,
        },
        {
            "actions": 174,
            "axis": "set",
            "backend_s": 0.000182,
            "backend_setup_s": 2.8e-05,
            "cell": "robowaiter",
            "config": "hbtp-pruned:oracle",
            "cost": 5,
            "explored": 2,
            "grounded_whole": False,
            "load_kind": "names listed, pruned before grounding",
            "load_s": 0.007218,
            "model_s": 0.0,
            "outcome": "NF",
            "p_star": 1,
            "planning_s": 0.003113,
            "resident_mb": 56,
            "rounds": 1,
            "scale": 1.0,
            "scenario": "robowaiter",
            "solve_s": 0.003175,
            "solved": True,
            "status": "solved",
            "task": "1",
            "total_s": 0.010393,
            "verified": True,
            "verify_s": 6.2e-05,
        },
        {
            "axis": "set",
            "cell": "robowaiter",
            "config": "obtea+lm",
            "p_star": 1,
            "scale": 1.0,
            "scenario": "robowaiter",
            "solved": False,
            "status": "killed",
            "task": "1",
            "time_s": 1.5,
        },
    ],
    PddlRow: [
        {
            "actions": 1,
            "cost": 1.0,
            "domain": "move",
            "explored": 2,
            "heuristic": "lm",
            "instance": "m1",
            "load_s": 0.000659,
            "mismatch": False,
            "planner": "hbtp-s",
            "planning_s": 0.000181,
            "pruned_symmetric": 0,
            "reachable_actions": 1,
            "reference_cost": 1.0,
            "reference_source": "fd_optimal_costs.json",
            "solved": True,
            "status": "solved",
            "symmetry": True,
            "time_s": 0.00084,
            "verified": True,
        },
        {
            "cost": None,
            "domain": "broken",
            "explored": None,
            "heuristic": "lm",
            "instance": "b1",
            "load_s": 0.000395,
            "message": "broken/domain.pddl:1:83: unknown predicate 'q'",
            "mismatch": False,
            "planner": "obtea",
            "reference_cost": None,
            "solved": False,
            "status": "load-error",
            "symmetry": True,
            "time_s": 0.000395,
            "verified": False,
        },
        {
            "actions": None,
            "cost": 2.0,
            "domain": "move",
            "explored": None,
            "heuristic": "lm",
            "instance": "m2",
            "load_s": 0.0,
            "mismatch": False,
            "planner": "fast-downward",
            "planning_s": 0.125,
            "reference_cost": 3.0,
            "reference_source": "fd_optimal_costs.json",
            "search": "astar(lmcut())",
            "solved": True,
            "status": "solved",
            "symmetry": False,
            "time_s": 0.125,
            "verified": True,
        },
        {
            "cost": None,
            "domain": "switch",
            "explored": None,
            "heuristic": "lm",
            "instance": "s2",
            "message": "no Fast Downward here",
            "mismatch": False,
            "planner": "fast-downward",
            "reference_cost": 2.0,
            "reference_source": "fd_optimal_costs.json",
            "solved": False,
            "status": "error",
            "symmetry": False,
            "time_s": 0.0,
            "verified": False,
        },
        {
            "cost": None,
            "domain": "move",
            "explored": None,
            "heuristic": "lm",
            "instance": "m1",
            "mismatch": False,
            "planner": "obtea",
            "reference_cost": 1.0,
            "reference_source": "fd_optimal_costs.json",
            "solved": False,
            "status": "killed",
            "symmetry": True,
            "time_s": 1.5,
            "verified": False,
        },
    ],
    InstructionRow: [
        {
            "equivalent": True,
            "exact": True,
            "id": "robowaiter-001",
            "instruction": "Make a coffee.",
            "intended": "Exists_Coffee",
            "kind": "test-set",
            "llm_s": 0.0,
            "message": "",
            "phrasing": 0,
            "produced": "Exists_Coffee",
            "reached": True,
            "rejected": False,
            "rounds": 1,
            "scenario": "robowaiter",
            "seconds": 0.002804,
            "well_formed": True,
        },
        {
            "equivalent": False,
            "exact": False,
            "id": "robowaiter-002",
            "instruction": "Put the water on table one.",
            "intended": "On_Water_Table1",
            "kind": "test-set",
            "llm_s": 0.0,
            "message": "server down",
            "phrasing": 1,
            "produced": None,
            "reached": False,
            "rejected": True,
            "rounds": 0,
            "scenario": "robowaiter",
            "seconds": 0.000412,
            "well_formed": False,
        },
    ],
}


def _line(data: JsonObject) -> str:
    """A results file's line: how :class:`ResultsFile` writes a row."""
    return json.dumps(data, sort_keys=True)


CASES = [(row_type, data) for row_type, objects in STORED.items() for data in objects]


@pytest.mark.parametrize(("row_type", "data"), CASES, ids=[f"{t.__name__}-{i}" for i, (t, _) in enumerate(CASES)])
def test_a_stored_line_reads_as_a_row_and_writes_back_byte_for_byte(row_type: type[Row], data: JsonObject) -> None:
    line = _line(data)
    row = row_type.from_json(json.loads(line))
    assert isinstance(row, row_type)
    assert row.key == row_type.key_of(data)
    assert _line(row.to_json()) == line


@pytest.mark.parametrize("row_type", list(STORED), ids=lambda t: t.__name__)
def test_a_results_file_yields_typed_rows_and_appends_the_same_lines(row_type: type[Row], tmp_path: Path) -> None:
    distinct = {row_type.key_of(data): data for data in STORED[row_type]}
    stored = tmp_path / "stored.jsonl"
    stored.write_text("".join(_line(data) + "\n" for data in distinct.values()), encoding="utf-8")
    rows = list(ResultsFile(stored, row_type).ordered(distinct))
    assert [type(row) for row in rows] == [row_type] * len(distinct)
    copy = ResultsFile(tmp_path / "copy.jsonl", row_type)
    for row in rows:
        copy.append(row)
    assert copy.path.read_bytes() == stored.read_bytes()


def test_rows_are_read_by_attribute() -> None:
    done, killed = (Table2Row.from_json(data) for data in (STORED[Table2Row][2], STORED[Table2Row][-1]))
    assert (done.outcome, done.action_space, done.A_star) == ("fallback", None, 9)
    assert done.errors == ("round 1: no plan in the pruned space", "round 2: no plan in the pruned space")
    assert done.loop_outcome.feedback_rounds is None
    assert (killed.status, killed.solved, killed.time_s) == ("killed", False, 1.5)
    assert (killed.action_space, killed.planning_s, killed.errors) == (None, None, ("killed",))
    # A field written as null stays null; a field the line lacks stays out of it.
    assert "action_space" in done.to_json()
    assert "action_space" not in killed.to_json()


def _kill_every_run(monkeypatch: pytest.MonkeyPatch, module: ModuleType) -> None:
    """Every run of ``module``'s benchmark is killed after 1.5 s (its rows: the known fields)."""

    def kill(function: Any, work: Any, results: ResultsFile[Any], execution: Any, **options: Any) -> None:
        for item in work:
            for row in failed_rows(item, RunFailure.KILLED, 1.5, results.row_type):
                results.append(row)

    monkeypatch.setattr(module, "run_work", kill)


def _first_line(path: Path) -> JsonObject:
    line = path.read_text(encoding="utf-8").splitlines()[0]
    data: JsonObject = json.loads(line)
    return data


@pytest.mark.filterwarnings("ignore:Data has no positive values")  # the plots of runs that all failed
def test_a_killed_run_writes_the_line_it_always_wrote(monkeypatch: pytest.MonkeyPatch, tmp_path: Path) -> None:
    for module in (table1, table2, fig3, fig4, robustness):
        _kill_every_run(monkeypatch, module)
    summary = table1.run_table1(Table1Config(planners=("bte",), limit=1), tmp_path / "table1", INLINE)
    assert _line(_first_line(tmp_path / "table1" / "results.jsonl")) == _line(STORED[Table1Row][-1])
    bte = summary["planners"]["bte"]
    assert (bte["tasks"], bte["solved"], bte["timeouts"], bte["killed"], bte["mean_time_s"]) == (1, 0, 1, 1, 1.5)
    assert bte["mean_explored"] is None
    table2.run_table2(
        Table2Config("robowaiter", "oracle", limit=1), BackendRecipe(LlmSpec.parse("oracle")), tmp_path / "t2", INLINE
    )
    assert _line(_first_line(tmp_path / "t2" / "results.jsonl")) == _line(STORED[Table2Row][-1])
    config3 = Fig3Config(scales=(1.0,), planners=("obtea",), space=Space.PRUNED, limit=1)
    fig3.run_fig3(config3, tmp_path / "fig3", INLINE)
    assert _line(_first_line(tmp_path / "fig3" / "results.jsonl")) == _line(STORED[Fig3Row][-1])
    config4 = Fig4Config(correct_rates=(0.5,), error_rates=(0.0,), seeds=1, planners=("hbtp-o",), limit=1)
    fig4.run_fig4(config4, tmp_path / "fig4", INLINE)
    assert _line(_first_line(tmp_path / "fig4" / "results.jsonl")) == _line(STORED[Fig4Row][-1])
    config = RobustnessConfig(scenarios=("robowaiter",), limit=1, runs=3, p_values=(0.2,))
    summary = robustness.run_robustness(config, tmp_path / "robustness", INLINE)
    assert _line(_first_line(tmp_path / "robustness" / "results.jsonl")) == _line(STORED[RobustnessRow][-1])
    assert summary["scenarios"]["robowaiter"]["planned_with"] == {"killed": 1}


def test_killed_payoff_and_pddl_runs_keep_their_lines() -> None:
    record = load_dataset("table2_robowaiter_50")[0]
    work = Work(
        ("set", "robowaiter", record.id, "obtea+lm"),
        None,
        _known(World("set", "robowaiter", "robowaiter"), record, "obtea+lm"),
    )
    (row,) = failed_rows(work, RunFailure.KILLED, 1.5, PayoffRow)
    assert _line(row.to_json()) == _line(STORED[PayoffRow][-1])
    instance = Instance("move", "m1", Path("domain.pddl"), Path("m1.pddl"))
    run = PddlRun(instance, "obtea", "lm", 60.0, 1.0, False)
    (row,) = failed_rows(Work(("move", "m1"), run, known(run)), RunFailure.KILLED, 1.5, PddlRow)
    assert _line(row.to_json()) == _line(STORED[PddlRow][-1])


def _without(data: JsonObject, *names: str) -> JsonObject:
    return {k: v for k, v in data.items() if k not in names}


def test_an_older_robustness_line_without_later_figures_loads_and_summarises(tmp_path: Path) -> None:
    older = _without(STORED[RobustnessRow][0], "condition_checks", "mean_events", "base_ticks")
    path = tmp_path / "results.jsonl"
    path.write_text(_line(older) + "\n", encoding="utf-8")
    (row,) = ResultsFile(path, RobustnessRow).rows.values()
    assert (row.condition_checks, row.mean_events, row.base_ticks, row.nodes) == (None, None, None, 5)
    assert _line(row.to_json()) == _line(older)
    figures = robustness.summarise([row], ["robowaiter"], [0.2], ["full"])["scenarios"]["robowaiter"]["p"]["0.2"][
        "full"
    ]
    assert figures["mean_condition_checks"] is None
    assert figures["mean_events"] is None
    assert figures["mean_base_ticks"] is None
    assert (figures["tasks"], figures["success_rate"], figures["mean_nodes"]) == (1, 1.0, 5)


def test_a_payoff_line_without_verified_counts_as_unverified() -> None:
    done = PayoffRow.from_json(STORED[PayoffRow][0])
    killed = PayoffRow.from_json({**STORED[PayoffRow][-1], "config": "hbtp-s+lm"})
    assert killed.verified is None
    config = PayoffConfig(backends=("oracle",), sets=("robowaiter",), levels=(), scales=())
    summary = payoff.summarise([done, killed], config)
    (cell,) = summary["cells"]
    assert summary["unverified"] == 1
    assert (cell["configs"]["obtea+lm"]["verified"], cell["configs"]["hbtp-s+lm"]["verified"]) == (1, 0)
    assert cell["configs"][BEST_FREE]["median_total_s"] == done.total_s


def test_an_older_pddl_line_gets_the_defaults_the_summary_assumes() -> None:
    older = _without(STORED[PddlRow][0], "verified", "mismatch", "reachable_actions", "pruned_symmetric")
    row = PddlRow.from_json(older)
    assert (row.verified, row.mismatch, row.reachable_actions, row.solved) == (False, False, None, True)
    assert _line(row.to_json()) == _line(older)
    fd = PddlRow.from_json({**STORED[PddlRow][2], "instance": "m1", "actions": 4})
    # Without reachable_actions the whole grounding's ratio is the goal's.
    assert ground_ratios([row, fd]) == {("move", "m1"): (0.25, 0.25)}


def test_an_older_table2_line_without_the_oracle_columns_loads() -> None:
    older = _without(STORED[Table2Row][1], "A_star", "p_star", "repairs")
    row = Table2Row.from_json(older)
    assert (row.A_star, row.p_star, row.repairs, row.outcome) == (None, None, None, "1F")
    assert _line(row.to_json()) == _line(older)


def test_a_line_without_a_key_field_is_a_one_line_error(tmp_path: Path) -> None:
    path = tmp_path / "results.jsonl"
    path.write_text(_line(_without(STORED[Table1Row][0], "heuristic")) + "\n", encoding="utf-8")
    with pytest.raises(InputError, match=r"results\.jsonl: a row lacks the key field 'heuristic'$") as error:
        ResultsFile(path, Table1Row)
    assert "\n" not in str(error.value)
    path.write_text(_line(_without(STORED[Table1Row][0], "status")) + "\n", encoding="utf-8")
    with pytest.raises(InputError, match=r"results\.jsonl: a row lacks the field 'status'$"):
        ResultsFile(path, Table1Row)
    path.write_text("[1, 2]\n", encoding="utf-8")
    with pytest.raises(InputError, match="not a JSON object"):
        ResultsFile(path, Table1Row)
