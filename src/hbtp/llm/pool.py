"""The few-shot example pool of a scenario: its shipped pool (or the user's file), valid records
only; for a domain without one (every ``--pddl`` domain), demonstrations generated from sampled
goals (:mod:`hbtp.llm.demonstrations`)."""

from __future__ import annotations

import logging
from pathlib import Path

from hbtp.datasets import load_dataset, read_dataset_file, validate_records
from hbtp.datasets.records import Record
from hbtp.domains.scenarios import Scenario
from hbtp.llm.demonstrations import generated_pool

log = logging.getLogger(__name__)


def example_pool(scenario: Scenario, path: str | Path | None = None) -> list[Record]:
    """Records usable as demonstrations: every record whose plan is valid in ``scenario``; a scenario
    without a pool (and no ``path``) gets generated ones, with a warning."""
    if path is not None:
        records = read_dataset_file(path)
    elif scenario.fewshot is not None:
        records = load_dataset(scenario.fewshot)
    else:
        records = generated_pool(scenario)
    report = validate_records(records, scenario.task)
    invalid = set(report.invalid_ids)
    if invalid:
        log.info(
            "example pool: %d of %d records do not fit %s and are left out", len(invalid), len(records), scenario.name
        )
    return [r for r in records if r.id not in invalid and r.optimal_actions]
