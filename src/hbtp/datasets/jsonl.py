"""hbtp's own dataset format: JSON Lines, one :meth:`Record.to_dict` object per line.

Blank lines are skipped. :func:`read_dataset_file` picks the format from the file name, so the
command line can take either kind of file.
"""

from __future__ import annotations

import json
from collections.abc import Iterable
from pathlib import Path

from hbtp.datasets.records import Record
from hbtp.datasets.textformat import read_source, read_text
from hbtp.errors import DatasetError, InputError

#: File suffixes read as JSON Lines; anything else is read in the reference text format.
JSONL_SUFFIXES = frozenset({".jsonl", ".json", ".ndjson"})


def read_jsonl(text: str, source: str = "<string>") -> list[Record]:
    """Read records from JSON Lines text.

    Raises :class:`DatasetError` with the line for invalid JSON, a bad record or a repeated id.
    """
    records: list[Record] = []
    first_line: dict[str, int] = {}
    for number, line in enumerate(text.removeprefix("\ufeff").split("\n"), start=1):
        if not line.strip():
            continue
        try:
            data = json.loads(line)
        except json.JSONDecodeError as error:
            raise DatasetError(f"invalid JSON: {error.msg} (column {error.colno})", source, number) from None
        except ValueError:  # an integer of more than 4300 digits (int()'s limit)
            raise DatasetError("invalid JSON: a number with too many digits", source, number) from None
        except RecursionError:
            raise DatasetError("invalid JSON: nested too deeply", source, number) from None
        try:
            record = Record.from_dict(data, line=number)
        except InputError as error:
            raise DatasetError(str(error), source, number) from None
        if record.id in first_line:
            raise DatasetError(
                f"duplicate record id {record.id!r} (first at line {first_line[record.id]})", source, number
            )
        first_line[record.id] = number
        records.append(record)
    return records


def read_jsonl_file(path: str | Path) -> list[Record]:
    """Read a JSON Lines dataset file; unreadable files raise :class:`DatasetError`."""
    return read_jsonl(read_source(path), str(path))


def write_jsonl(records: Iterable[Record]) -> str:
    """Write records as JSON Lines (non-ASCII kept as is), one per line, ending with a newline."""
    return "".join(json.dumps(record.to_dict(), ensure_ascii=False) + "\n" for record in records)


def read_dataset_file(path: str | Path) -> list[Record]:
    """Read a dataset file: JSON Lines for ``.jsonl``/``.json``/``.ndjson``, the text format otherwise.

    Raises :class:`DatasetError` for a missing, unreadable or malformed file.
    """
    path = Path(path)
    text = read_source(path)
    if path.suffix.lower() in JSONL_SUFFIXES:
        return read_jsonl(text, str(path))
    return read_text(text, str(path))
