"""With the planner as an optimality oracle, validating the shipped datasets reports exactly the
known defects of reference_results.md, including the valid-but-not-optimal plans (slow: a few
minutes; run with ``pytest -m slow``)."""

from __future__ import annotations

import pytest

from hbtp.datasets import DATASET_SCENARIO, dataset_names, load_dataset, validate_records
from hbtp.datasets.records import Record
from hbtp.domains import load_scenario
from hbtp.planning import Limits
from hbtp.planning.oracle import optimal_cost_function

_TABLE2_ROBOTHOW = "4 8 9 12 14 21 23 24 25 29 30 33 36 38 41 42 43 44 47"
NOT_OPTIMAL = {
    "table2_robothow_50": set(_TABLE2_ROBOTHOW.split()),
    # 92, 94 and 99 are not in reference_results.md: 162, 169 and 169 where the optima are 158, 165
    # and 165 (Fast Downward agrees on 92 and 94).
    "fewshot_robothow_100": {"5", "12", "21", "72", "92", "94", "99"},
    # Not in reference_results.md: LeftGrab forces opening the bin first; RightGrab saves a walk (63 < 78).
    "fewshot_robothow_small_100": {"92"},
}


@pytest.mark.slow
@pytest.mark.parametrize("name", dataset_names())
def test_only_the_known_plans_are_not_optimal(name: str) -> None:
    scenario_name = "robothow" if name == "fewshot_robothow_small_100" else DATASET_SCENARIO[name]
    scenario = load_scenario(scenario_name)
    optimal = optimal_cost_function(scenario, Limits(time_s=600))
    unknown: list[str] = []

    def checked(record: Record) -> int | None:
        cost = optimal(record)
        if cost is None:
            unknown.append(record.id)
        return cost

    records = load_dataset(name)
    report = validate_records(records, scenario.task, dataset=name, optimal_cost=checked)
    invalid = set(report.invalid_ids)
    # every valid record got its optimum (a time limit must not hide a defect)
    assert [i for i in unknown if i not in invalid] == []
    flagged = {issue.record_id for issue in report.issues if issue.code == "not-optimal"}
    assert flagged == NOT_OPTIMAL.get(name, set())
