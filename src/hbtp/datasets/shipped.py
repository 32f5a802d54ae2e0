"""The datasets shipped with hbtp (package data in ``hbtp/datasets/data``).

Nine files in the reference text format: the paper's Table I tasks, the four Table II test sets
and the four few-shot pools. :data:`DATASET_SCENARIO` says which scenario each one is validated
against; see ``reference_results.md`` ("Known defects") for the records that do not fit it.
"""

from __future__ import annotations

import functools
from importlib import resources
from pathlib import Path

from hbtp.datasets.records import Record
from hbtp.datasets.textformat import read_text
from hbtp.errors import InputError

DATA = resources.files("hbtp.datasets") / "data"
SUFFIX = ".txt"

#: Each shipped dataset and the scenario (``hbtp.domains.load_scenario`` name) it belongs to, in the
#: paper's order. ``fewshot_robothow_small_100`` is paired with RobotHow-Small as published, although
#: 52 of its records only fit RobotHow.
DATASET_SCENARIO: dict[str, str] = {
    "table1_robothow_100": "robothow",
    "table2_robowaiter_50": "robowaiter",
    "table2_virtualhome_50": "virtualhome",
    "table2_robothow_small_50": "robothow-small",
    "table2_robothow_50": "robothow",
    "fewshot_robowaiter_100": "robowaiter",
    "fewshot_virtualhome_100": "virtualhome",
    "fewshot_robothow_small_100": "robothow-small",
    "fewshot_robothow_100": "robothow",
}


@functools.cache
def dataset_names() -> tuple[str, ...]:
    """Names (file stems) of the shipped datasets: the known ones in the paper's order, then others."""
    stems = {entry.name.removesuffix(SUFFIX) for entry in DATA.iterdir() if entry.name.endswith(SUFFIX)}
    order = list(DATASET_SCENARIO)
    return tuple(sorted(stems, key=lambda stem: (order.index(stem) if stem in order else len(order), stem)))


def _check_name(name: str) -> None:
    if name not in dataset_names():
        raise InputError(f"unknown dataset {name!r}; choose one of: {', '.join(dataset_names())}")


def dataset_path(name: str) -> Path:
    """The file of a shipped dataset (package data, so do not write to it)."""
    _check_name(name)
    return Path(str(DATA / f"{name}{SUFFIX}"))


def load_dataset(name: str) -> list[Record]:
    """The records of a shipped dataset; :class:`InputError` naming the choices for an unknown name."""
    _check_name(name)
    return list(_load(name))


@functools.cache
def _load(name: str) -> tuple[Record, ...]:
    text = (DATA / f"{name}{SUFFIX}").read_text(encoding="utf-8")
    return tuple(read_text(text, f"{name}{SUFFIX}"))
