"""Demonstrations for a domain that has none: goals sampled and labelled by the optimal planner.

Every ``--pddl`` domain lacks a few-shot example pool. :func:`generated_pool` makes one with
:func:`hbtp.planning.generate.generate_records` (level ``any``: 1-3 literals, solved optimally by
OBTEA with the landmark heuristic) and caches it in the hbtp cache folder
(:func:`hbtp.domains.cache.cache_dir`, with its safety rules) as a small JSON file holding the
records in the dataset text format. The key hashes the domain and problem files' contents, the
parsed model (a generated problem has no file), the task's objects, constants and fluent predicates
(so ``--objects`` or ``--keep-fluent`` make another pool), the generator's parameters and source,
and the hbtp version: all known before grounding, so a world pruned before grounding
(:class:`~hbtp.domains.pruned.PrunedWorld`) finds its pool without grounding; only generating one
grounds it whole.
"""

from __future__ import annotations

import hashlib
import json
import logging
import re
from dataclasses import dataclass, field
from pathlib import Path

from hbtp import __version__
from hbtp.datasets import read_text, write_text
from hbtp.datasets.records import Record
from hbtp.domains import cache
from hbtp.domains.pruned import PrunedWorld
from hbtp.domains.scenarios import Scenario
from hbtp.errors import InputError
from hbtp.files import InputKind, read_bytes
from hbtp.logic.names import names_of
from hbtp.planning import generate
from hbtp.planning.generate import Sampling

log = logging.getLogger(__name__)

FORMAT = "hbtp-demonstrations"
VERSION = 1
WHAT = "demonstration cache"


@dataclass(frozen=True, slots=True)
class PoolSettings:
    """How many demonstrations a generated pool holds, and how they are sampled."""

    count: int = 30
    sampling: Sampling = field(default_factory=Sampling)
    level: str = "any"


def pool_key(world: Scenario | PrunedWorld, settings: PoolSettings) -> str:
    """The hash of everything a generated pool depends on (the same for a world grounded or not)."""
    digest = hashlib.sha256(f"{FORMAT}|{__version__}|{settings!r}|{settings.sampling.key()}".encode())
    for path in (world.domain_file, world.problem_file):
        try:
            digest.update(read_bytes(path, InputKind.PDDL))
        except InputError:
            digest.update(b"\0")  # a generated problem: the parsed model below still tells it apart
    digest.update(repr(world.pddl).encode())
    names = world.names if isinstance(world, PrunedWorld) else names_of(world.task)
    digest.update("\n".join((" ".join(names.objects), " ".join(names.constants), *names.condition_slots)).encode())
    for module in (generate.__file__, __file__):
        digest.update(Path(module).read_bytes())
    return digest.hexdigest()


def _entry_name(name: str) -> str:
    return "demonstrations-" + (re.sub(r"[^A-Za-z0-9.-]+", "_", name)[:40] or "domain")


def generated_pool(world: Scenario | PrunedWorld, settings: PoolSettings = PoolSettings()) -> list[Record]:
    """The generated demonstrations of ``scenario``: read from the cache, or sampled and cached.

    Logs the warning ``no demonstrations for this domain: generated N from sampled goals (cached at
    ...)``. A domain too small to sample from gives an empty pool (the prompt then has no examples)
    with a warning saying so.
    """
    key = pool_key(world, settings)
    entry = cache.cache_entry(_entry_name(world.name), key)
    records = _read(entry) if entry is not None else None
    if records is None:
        if isinstance(world, PrunedWorld):
            log.warning("generating demonstrations grounds the whole world once (then they are cached)")
        scenario = world.whole() if isinstance(world, PrunedWorld) else world
        try:
            records = generate.generate_records(
                scenario.task, settings.level, settings.count, settings.sampling, scenario.mutexes
            )
        except InputError as error:
            log.warning("no demonstrations for this domain, and none can be generated (%s): prompts have none", error)
            return []
        if entry is not None:
            cache.write_entry_bytes(entry, _encode(records, entry), WHAT)
    where = f"cached at {entry.path}" if entry is not None else "not cached: the cache is off"
    log.warning(
        "no demonstrations for this domain: generated %d from sampled goals (%s)", len(records), where
    )  # fmt: skip
    return records


def _encode(records: list[Record], entry: cache.CacheEntry) -> bytes:
    document = {"format": FORMAT, "version": VERSION, "key": entry.key, "records": write_text(records)}
    return json.dumps(document, ensure_ascii=False, indent=0).encode()


def _read(entry: cache.CacheEntry) -> list[Record] | None:
    """The records cached at ``entry``; ``None`` when absent or invalid (warned: regenerated)."""
    data = cache.read_entry_bytes(entry, WHAT)
    if data is None:
        return None
    try:
        document = json.loads(data)
        if not isinstance(document, dict) or document.get("format") != FORMAT or document.get("version") != VERSION:
            raise ValueError(f"not an hbtp demonstration cache of format version {VERSION}")
        if document.get("key") != entry.key:
            raise ValueError("it was built from other data (cache key differs)")
        text = document.get("records")
        if not isinstance(text, str):
            raise ValueError("'records' is not text")
        return read_text(text, str(entry.path))
    except (ValueError, InputError, RecursionError) as error:
        log.warning("ignoring the %s %s: %s; generating it again", WHAT, entry.path, error)
        return None
