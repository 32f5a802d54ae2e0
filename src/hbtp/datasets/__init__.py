"""Datasets: records of goals with their solution paths, their two file formats, the shipped files,
and validation against a scenario.

>>> from hbtp.datasets import load_dataset, validate_dataset
>>> records = load_dataset("table2_robowaiter_50")
>>> validate_dataset("table1_robothow_100").invalid_ids
('29', '99')
"""

from hbtp.datasets.jsonl import read_dataset_file, read_jsonl, read_jsonl_file, write_jsonl
from hbtp.datasets.records import Record
from hbtp.datasets.shipped import DATASET_SCENARIO, dataset_names, dataset_path, load_dataset
from hbtp.datasets.textformat import read_text, read_text_file, write_text
from hbtp.datasets.validate import (
    Issue,
    OptimalCost,
    Severity,
    ValidationReport,
    validate_dataset,
    validate_records,
)

__all__ = [
    "DATASET_SCENARIO",
    "Issue",
    "OptimalCost",
    "Record",
    "Severity",
    "ValidationReport",
    "dataset_names",
    "dataset_path",
    "load_dataset",
    "read_dataset_file",
    "read_jsonl",
    "read_jsonl_file",
    "read_text",
    "read_text_file",
    "validate_dataset",
    "validate_records",
    "write_jsonl",
    "write_text",
]
