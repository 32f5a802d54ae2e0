"""The few-shot example pool of a scenario: its shipped pool (or the user's file), valid records
only; for a domain without one (every ``--pddl`` domain), demonstrations generated from sampled
goals (:mod:`hbtp.llm.demonstrations`)."""

from __future__ import annotations

import logging
from pathlib import Path

from hbtp.datasets import load_dataset, read_dataset_file, validate_records
from hbtp.datasets.records import Record
from hbtp.domains.pruned import PrunedWorld
from hbtp.domains.scenarios import Scenario
from hbtp.errors import InputError
from hbtp.llm.demonstrations import generated_pool
from hbtp.logic.atoms import parse_atom

log = logging.getLogger(__name__)


def example_pool(world: Scenario | PrunedWorld, path: str | Path | None = None) -> list[Record]:
    """Records usable as demonstrations: every record whose plan is valid in the world; a world
    without a pool (and no ``path``) gets generated ones, with a warning. A world pruned before
    grounding checks them in the part its records' actions span."""
    fewshot = world.options.fewshot if isinstance(world, PrunedWorld) else world.fewshot
    if path is not None:
        records = read_dataset_file(path)
    elif fewshot is not None:
        records = load_dataset(fewshot)
    else:
        records = generated_pool(world)
    scenario = world if isinstance(world, Scenario) else _spanned(world, records)
    report = validate_records(records, scenario.task)
    invalid = set(report.invalid_ids)
    if invalid:
        log.info(
            "example pool: %d of %d records do not fit %s and are left out", len(invalid), len(records), scenario.name
        )
    return [r for r in records if r.id not in invalid and r.optimal_actions]


def _spanned(world: PrunedWorld, records: list[Record]) -> Scenario:
    """The part of ``world`` with every action predicate and object the records' plans name."""
    predicates: set[str] = set()
    objects: set[str] = set()
    for record in records:
        for name in record.optimal_actions:
            try:
                atom = parse_atom(name)
            except InputError:
                continue  # the validation reports it
            predicates.add(atom.predicate)
            objects.update(atom.args)
    return world.part(frozenset(predicates), frozenset(objects))
