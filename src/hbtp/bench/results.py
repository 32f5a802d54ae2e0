"""Benchmark results on disk: one JSON line per run, resumable, and summaries."""

from __future__ import annotations

import json
import logging
import statistics
from collections.abc import Iterable, Iterator, Sequence
from pathlib import Path
from typing import Any

from hbtp.errors import InputError
from hbtp.files import InputKind, open_output, read_text, write_atomically

log = logging.getLogger(__name__)


class ResultsFile:
    """``results.jsonl``: rows keyed by ``key_fields``; rows already present are not run again."""

    def __init__(self, path: Path, key_fields: Sequence[str]) -> None:
        self.path = path
        self.key_fields = tuple(key_fields)
        self.rows: dict[tuple[Any, ...], dict[str, Any]] = {}
        if path.exists():
            for number, line in enumerate(read_text(path, InputKind.RESULTS).splitlines(), 1):
                if not line.strip():
                    continue
                try:
                    row = json.loads(line)
                except json.JSONDecodeError:
                    log.warning("%s:%d: unreadable line skipped (it will be run again)", path, number)
                    continue
                self.rows[self.key(row)] = row

    def key(self, row: dict[str, Any]) -> tuple[Any, ...]:
        try:
            return tuple(row[field] for field in self.key_fields)
        except KeyError as error:
            raise InputError(f"{self.path}: a row lacks the key field {error.args[0]!r}") from None

    def __contains__(self, key: tuple[Any, ...]) -> bool:
        return key in self.rows

    def append(self, row: dict[str, Any]) -> None:
        with open_output(self.path, append=True, create_folders=True) as handle:
            handle.write(json.dumps(row, sort_keys=True) + "\n")
        self.rows[self.key(row)] = row

    def ordered(self, keys: Iterable[tuple[Any, ...]]) -> Iterator[dict[str, Any]]:
        for key in keys:
            if key in self.rows:
                yield self.rows[key]


def mean(values: Sequence[float]) -> float | None:
    return round(statistics.fmean(values), 6) if values else None


def median(values: Sequence[float]) -> float | None:
    return round(statistics.median(values), 6) if values else None


def read_json(path: Path) -> Any:
    """The JSON in ``path``; a file that cannot be read or parsed is an :class:`InputError`."""
    try:
        return json.loads(read_text(path, InputKind.RESULTS))
    except ValueError as error:  # invalid JSON
        raise InputError(f"{path}: not valid JSON: {error}") from None
    except RecursionError:
        raise InputError(f"{path}: not valid JSON: nested too deeply") from None


def write_json(path: Path, data: Any) -> None:
    """``data`` as JSON in ``path`` (its folder created: a benchmark's ``-o DIR``)."""
    write_atomically(path, json.dumps(data, indent=1, sort_keys=True) + "\n", create_folders=True)
