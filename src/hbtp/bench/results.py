"""Benchmark results on disk: one JSON line per run, resumable, and summaries.

Each benchmark's rows are a frozen dataclass, a :class:`Row`: its fields are the keys of its JSON
object, and :data:`Row.KEY` names the fields that identify a run (a results file holds one row per
key). Not every run writes every key, so a field is one of:

- *required* (no default): in every row;
- *optional* (declared with :func:`optional`): left out of the JSON object when it is ``None``; a
  key some runs write, never as ``null``;
- *defaulted* (any other default): written, ``null`` included, unless the row's ``absent`` set
  names it. :meth:`Row.from_json` puts there the defaulted fields the object lacks: a killed run's
  row holds only the fields known before it ran (:func:`hbtp.bench.runner.failed_rows`), and an
  older results file may lack a field added since.

So :meth:`Row.from_json` then :meth:`Row.to_json` gives back the object read (JSON arrays are tuples
in a row), and ``json.dumps(row.to_json(), sort_keys=True)`` is the line a results file holds.
"""

from __future__ import annotations

import dataclasses
import json
import logging
import statistics
from collections.abc import Iterable, Iterator, Mapping
from dataclasses import dataclass, field
from pathlib import Path
from typing import Any, ClassVar, Generic, Self, TypeVar

from hbtp.errors import InputError
from hbtp.files import InputKind, open_output, read_text, write_atomically

log = logging.getLogger(__name__)

#: A row's JSON object, as a line of ``results.jsonl`` holds it.
JsonObject = dict[str, Any]

_OPTIONAL = "hbtp.bench.results.optional"
_ABSENT = "absent"


def optional() -> Any:
    """A field some runs do not write: ``None`` by default, and left out of the JSON object when ``None``."""
    return field(default=None, metadata={_OPTIONAL: True})


@dataclass(frozen=True, kw_only=True)
class Row:
    """The base of the benchmarks' rows (see the module's documentation)."""

    #: The fields that identify a run.
    KEY: ClassVar[tuple[str, ...]] = ()

    #: The defaulted fields this row's JSON object does not have.
    absent: frozenset[str] = field(default=frozenset(), repr=False)

    @property
    def key(self) -> tuple[Any, ...]:
        """The values of the :data:`KEY` fields."""
        return tuple(getattr(self, name) for name in self.KEY)

    @classmethod
    def key_of(cls, data: Mapping[str, Any]) -> tuple[Any, ...]:
        """The key of a row's JSON object; one that lacks a key field is an :class:`InputError`."""
        try:
            return tuple(data[name] for name in cls.KEY)
        except KeyError as error:
            raise InputError(f"a row lacks the key field {error.args[0]!r}") from None

    def to_json(self) -> JsonObject:
        """The row's JSON object."""
        data: JsonObject = {}
        for item in dataclasses.fields(self):
            value = getattr(self, item.name)
            if item.name == _ABSENT or item.name in self.absent or (value is None and item.metadata.get(_OPTIONAL)):
                continue
            data[item.name] = list(value) if isinstance(value, tuple) else value
        return data

    @classmethod
    def from_json(cls, data: Mapping[str, Any]) -> Self:
        """The row of a JSON object. A missing key or required field is an :class:`InputError`; a
        missing optional or defaulted field gets its default; keys that are not fields are dropped."""
        cls.key_of(data)
        values: JsonObject = {}
        absent: set[str] = set()
        for item in dataclasses.fields(cls):
            if item.name == _ABSENT:
                continue
            if item.name in data:
                value = data[item.name]
                values[item.name] = tuple(value) if isinstance(value, list) else value
            elif item.default is dataclasses.MISSING and item.default_factory is dataclasses.MISSING:
                raise InputError(f"a row lacks the field {item.name!r}")
            elif not item.metadata.get(_OPTIONAL):
                absent.add(item.name)
        return cls(**values, absent=frozenset(absent))

    def updated(self, data: Mapping[str, Any]) -> Self:
        """This row with the fields of ``data`` (figures another module returns as a JSON object):
        those fields are no longer absent."""
        return dataclasses.replace(self, absent=self.absent - data.keys(), **data)


R = TypeVar("R", bound=Row)


class ResultsFile(Generic[R]):
    """``results.jsonl``: rows of ``row_type``, one per key; rows already present are not run again."""

    def __init__(self, path: Path, row_type: type[R]) -> None:
        self.path = path
        self.row_type = row_type
        self.rows: dict[tuple[Any, ...], R] = {}
        if path.exists():
            for number, line in enumerate(read_text(path, InputKind.RESULTS).splitlines(), 1):
                if not line.strip():
                    continue
                try:
                    data = json.loads(line)
                except json.JSONDecodeError:
                    log.warning("%s:%d: unreadable line skipped (it will be run again)", path, number)
                    continue
                row = self._row(data)
                self.rows[row.key] = row

    def _row(self, data: Any) -> R:
        if not isinstance(data, dict):
            raise InputError(f"{self.path}: a row is not a JSON object")
        try:
            return self.row_type.from_json(data)
        except InputError as error:
            raise InputError(f"{self.path}: {error}") from None

    def key(self, data: Mapping[str, Any]) -> tuple[Any, ...]:
        """The key of a row's JSON object (such as a run's known fields)."""
        try:
            return self.row_type.key_of(data)
        except InputError as error:
            raise InputError(f"{self.path}: {error}") from None

    def __contains__(self, key: tuple[Any, ...]) -> bool:
        return key in self.rows

    def append(self, row: R) -> None:
        with open_output(self.path, append=True, create_folders=True) as handle:
            handle.write(json.dumps(row.to_json(), sort_keys=True) + "\n")
        self.rows[row.key] = row

    def ordered(self, keys: Iterable[tuple[Any, ...]]) -> Iterator[R]:
        for key in keys:
            if key in self.rows:
                yield self.rows[key]


def _known(values: Iterable[float | None]) -> list[float]:
    return [value for value in values if value is not None]


def mean(values: Iterable[float | None]) -> float | None:
    """The mean of the values that are not ``None``, to 6 places; ``None`` if there is none."""
    known = _known(values)
    return round(statistics.fmean(known), 6) if known else None


def median(values: Iterable[float | None]) -> float | None:
    """The median of the values that are not ``None``, to 6 places; ``None`` if there is none."""
    known = _known(values)
    return round(statistics.median(known), 6) if known else None


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
