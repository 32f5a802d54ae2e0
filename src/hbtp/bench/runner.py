"""Run benchmark work items inline, in local worker processes, or on Ray, with a hard time limit.

Every benchmark describes its runs as :class:`Work` items (a key, a picklable ``spec`` and the row
fields known before running) and a module-level function ``spec -> row`` (a
:class:`~hbtp.bench.results.Row`, or a list of them). :func:`run_work` runs the items that
``results.jsonl`` does not hold yet and appends each row as it arrives, so an interrupted
benchmark resumes where it stopped. Rows depend only on their spec (every run is seeded from its own
key), so the executor and the number of jobs change the order of the lines in ``results.jsonl`` and
the measured times, nothing else; summaries are computed in key order.

Executors:

- ``inline``: in this process, one run after the other (no isolation; for debugging and tests);
- ``local``: ``jobs`` worker processes (:class:`pebble.ProcessPool`, which stops a run at its time
  limit and names the run whose worker died);
- ``ray``: Ray tasks, on the cluster at ``RAY_ADDRESS`` or on a local Ray started for the run.

With ``local`` and ``ray`` a run that exceeds ``kill_after`` seconds (a planner that ignores its own
time limit, a hung LLM request) is killed with its worker and recorded as ``status: "killed"``; a
run whose worker dies (out of memory, a crash in a native library) is recorded as ``"crashed"``.
At most ``jobs`` runs are in flight, so a run's clock starts when a worker is free for it.
"""

from __future__ import annotations

import enum
import logging
import multiprocessing
import os
import time
from collections.abc import Callable, Sequence
from concurrent.futures import FIRST_COMPLETED, Future, wait
from concurrent.futures.process import BrokenProcessPool
from dataclasses import dataclass, field
from typing import Any, TypeVar

from pebble import ProcessExpired, ProcessPool
from tqdm import tqdm

from hbtp.bench.results import JsonObject, ResultsFile, Row
from hbtp.collector import searches_frozen
from hbtp.errors import BackendError, InputError

log = logging.getLogger(__name__)


class Executor(enum.StrEnum):
    """Where the runs of a benchmark run (``--executor``)."""

    LOCAL = "local"  #: worker processes on this machine (pebble), each run killable
    INLINE = "inline"  #: in this process, one after the other (tests, debugging)
    RAY = "ray"  #: Ray tasks (the ray extra)


EXECUTORS: tuple[str, ...] = tuple(e.value for e in Executor)
#: New worker pools a local run may start after pebble lost track of a dead worker (see _run_local).
MAX_POOL_RESTARTS = 3

R = TypeVar("R", bound=Row)

#: A module-level function (picklable) from a spec to its row, or rows.
RunFunction = Callable[[Any], R | list[R]]


@dataclass(frozen=True)
class Work:
    """One run: ``key`` (names it in logs), ``spec`` (the run function's argument) and ``known``: the
    JSON fields of each row it produces that are known without running it, including the
    results.jsonl key fields (a run is pending while one of its rows is missing; a killed or crashed
    run gets these rows, unsolved: :func:`failed_rows`). ``stage`` names the sub-part it belongs to
    (a planner, a scale, a scenario): the progress bar shows it after the benchmark's description
    while the run starts."""

    key: tuple[Any, ...]
    spec: Any
    known: JsonObject | tuple[JsonObject, ...] = field(default_factory=dict)
    stage: str = ""

    @property
    def rows(self) -> tuple[JsonObject, ...]:
        return self.known if isinstance(self.known, tuple) else (self.known,)


@dataclass(frozen=True)
class Execution:
    """How to run: ``executor``, ``jobs`` in parallel, ``kill_after`` seconds per run (``None``: the
    benchmark's default), whether to show a progress bar, and (``local``) whether every run gets a
    new worker process (``fresh_workers``: a run's peak memory is then its own; nothing a worker
    loaded is kept for the next run)."""

    executor: Executor = Executor.LOCAL
    jobs: int = 1
    kill_after: float | None = None
    progress: bool = True
    fresh_workers: bool = False

    def __post_init__(self) -> None:
        try:  # text from an untyped caller becomes the value
            object.__setattr__(self, "executor", Executor(self.executor))
        except ValueError:
            raise InputError(f"unknown executor {self.executor!r}; choose one of: {', '.join(EXECUTORS)}") from None
        if self.jobs < 1:
            raise InputError(f"jobs must be at least 1, not {self.jobs}")
        if self.kill_after is not None and not self.kill_after > 0:
            raise InputError(f"kill_after must be a positive number of seconds, not {self.kill_after}")


#: The default: one local worker process, with a progress bar.
DEFAULT_EXECUTION = Execution()
#: In this process, quietly (tests, debugging).
INLINE = Execution(executor=Executor.INLINE, progress=False)


def hard_limit(time_limit: float, slack: float = 60.0) -> float:
    """The default ``kill_after`` of a run limited to ``time_limit`` seconds: twice that, plus
    ``slack`` for loading what the run needs."""
    return 2 * time_limit + slack


class RunFailure(enum.Enum):
    """How a run that did not return ended (its rows' ``status``)."""

    KILLED = "killed"  # past its hard limit: the worker was killed
    CRASHED = "crashed"  # its worker died (out of memory, a crash in a native library)


def failed_rows(work: Work, failure: RunFailure, seconds: float, row_type: type[R]) -> list[R]:
    """The rows of a run that did not return: their known fields, unsolved, with the time it took
    (only those keys: a field the run would have written is absent)."""
    failed = {"status": failure.value, "solved": False, "time_s": round(seconds, 6)}
    return [row_type.from_json({**known, **failed}) for known in work.rows]


def _pending(work: Work, results: ResultsFile[R]) -> bool:
    return any(results.key(row) not in results for row in work.rows)


def _store(results: ResultsFile[R], rows: R | list[R]) -> None:
    for row in rows if isinstance(rows, list) else [rows]:
        if row.key not in results:
            results.append(row)


def run_work(
    function: RunFunction[R],
    work: Sequence[Work],
    results: ResultsFile[R],
    execution: Execution,
    *,
    kill_after: float,
    description: str,
) -> None:
    """Run every item of ``work`` not in ``results`` with ``function`` and append the rows."""
    pending = [item for item in work if _pending(item, results)]
    limit = execution.kill_after or kill_after
    bar = _Progress(
        description,
        total=len(work),
        initial=len(work) - len(pending),
        disable=not execution.progress,
        unit="run",
    )
    try:
        if not pending:
            return
        if execution.executor is Executor.INLINE:
            for item in pending:
                bar.starting(item)
                _store(results, function(item.spec))
                bar.update(1)
        elif execution.executor is Executor.LOCAL:
            _run_local(function, pending, results, execution, limit, bar)
        else:
            _run_ray(function, pending, results, execution.jobs, limit, bar)
    finally:
        bar.close()


class _Progress:
    """A progress bar whose description names the stage of the run started last
    (``table1 pruned hbtp-s``), not just the benchmark (``table1``)."""

    def __init__(self, description: str, **options: Any) -> None:
        self.bar = tqdm(desc=description, **options)
        self.description = description
        self.stage = ""

    def starting(self, item: Work) -> None:
        if item.stage and item.stage != self.stage:
            self.stage = item.stage
            self.bar.set_description(f"{self.description} {item.stage}")

    def update(self, count: int) -> None:
        self.bar.update(count)

    def close(self) -> None:
        self.bar.close()


def _context() -> Any:
    # forkserver: workers start from a clean, single-threaded server process (no inherited threads
    # or model handles); each worker loads what its runs need once and caches it.
    method = "forkserver" if "forkserver" in multiprocessing.get_all_start_methods() else "spawn"
    return multiprocessing.get_context(method)


def in_worker(function: RunFunction[R], spec: Any) -> R | list[R]:
    """One run in a worker process: a short-lived process whose searches keep their objects frozen
    until the next one (:func:`hbtp.collector.searches_frozen`)."""
    with searches_frozen():
        return function(spec)


def _run_local(
    function: RunFunction[R],
    pending: Sequence[Work],
    results: ResultsFile[R],
    execution: Execution,
    limit: float,
    bar: _Progress,
) -> None:
    """``execution.jobs`` worker processes (a :class:`pebble.ProcessPool`; with ``fresh_workers`` a
    new one for every run): a run past ``limit`` seconds is stopped with its worker, and a worker
    that dies is charged to the one run it was running; the pool replaces either worker and the
    other runs go on undisturbed."""
    queue = list(reversed(pending))
    running: dict[Future[Any], tuple[Work, float]] = {}
    jobs = execution.jobs
    for restart in range(MAX_POOL_RESTARTS + 1):
        pool = ProcessPool(max_workers=jobs, max_tasks=1 if execution.fresh_workers else 0, context=_context())
        try:
            _drain(function, pool, queue, running, results, jobs, limit, bar)
            return
        except BrokenProcessPool:
            # pebble can lose track of a worker that died (it then finds no run to charge): the
            # runs it held are run again in a new pool, a bounded number of times.
            if restart == MAX_POOL_RESTARTS:
                raise
            log.warning("the worker pool broke; running its %d unfinished run(s) again in a new pool", len(running))
            queue.extend(item for item, _ in running.values())
            running.clear()
        finally:
            # pebble leaves stop() and close() unannotated
            if running:
                pool.stop()  # type: ignore[no-untyped-call]
            else:
                pool.close()  # type: ignore[no-untyped-call]
            pool.join()


def _drain(
    function: RunFunction[R],
    pool: ProcessPool,
    queue: list[Work],
    running: dict[Future[Any], tuple[Work, float]],
    results: ResultsFile[R],
    jobs: int,
    limit: float,
    bar: _Progress,
) -> None:
    """Run the ``queue`` in ``pool``, ``jobs`` at a time (``running``: what the pool holds now)."""
    while queue or running:
        while queue and len(running) < jobs:  # so a run's clock starts when a worker is free for it
            item = queue[-1]
            bar.starting(item)
            running[pool.schedule(in_worker, (function, item.spec), timeout=limit)] = (item, time.monotonic())
            queue.pop()  # (only once scheduled: a broken pool leaves it queued)
        done, _ = wait(running, return_when=FIRST_COMPLETED)
        for future in done:
            item, started = running[future]
            rows = _local_rows(future, item, time.monotonic() - started, limit, results.row_type)
            del running[future]
            _store(results, rows)
            bar.update(1)


def _local_rows(future: Future[Any], item: Work, seconds: float, limit: float, row_type: type[R]) -> R | list[R]:
    """The run's rows; a killed or crashed run's known rows. Any other error reaches the caller."""
    try:
        rows: R | list[R] = future.result()
    except TimeoutError:  # concurrent.futures.TimeoutError is TimeoutError since Python 3.11
        log.warning("run %s exceeded %.0f s; its worker was killed", item.key, limit)
        return failed_rows(item, RunFailure.KILLED, seconds, row_type)
    except ProcessExpired as error:
        log.warning("run %s killed its worker process (exit code %s); recorded as crashed", item.key, error.exitcode)
        return failed_rows(item, RunFailure.CRASHED, seconds, row_type)
    return rows


def _run_ray(
    function: RunFunction[R], pending: Sequence[Work], results: ResultsFile[R], jobs: int, limit: float, bar: _Progress
) -> None:
    try:
        import ray
    except ImportError:
        raise BackendError("the ray executor needs Ray: pip install 'hbtp[ray]'") from None
    started_here = not ray.is_initialized()
    if started_here:
        address = os.environ.get("RAY_ADDRESS") or None
        log.info("connecting to Ray at %s", address or "a new local Ray")
        try:
            if address:
                ray.init(address=address, log_to_driver=False)
            else:
                ray.init(num_cpus=jobs, include_dashboard=False, log_to_driver=False)
        except Exception as error:  # Ray raises many types (ConnectionError, RuntimeError, ...)
            raise BackendError(f"cannot start or reach Ray ({address or 'local'}): {error}") from error
    remote: Any = ray.remote(max_retries=0)(in_worker)  # Ray 2.60's stubs reject the generic in_worker
    queue = list(reversed(pending))
    running: dict[Any, tuple[Work, float]] = {}
    try:
        while queue or running:
            while queue and len(running) < jobs:
                item = queue.pop()
                bar.starting(item)
                running[remote.remote(function, item.spec)] = (item, time.monotonic())
            nearest = min(started for _, started in running.values()) + limit
            done, _ = ray.wait(list(running), num_returns=1, timeout=max(0.0, nearest - time.monotonic()))
            for ref in done:
                item, _ = running.pop(ref)
                _store(results, ray.get(ref))
                bar.update(1)
            now = time.monotonic()
            for ref in [r for r, (_, started) in running.items() if now - started >= limit]:
                item, started = running.pop(ref)
                log.warning("run %s exceeded %.0f s; its Ray task was killed", item.key, limit)
                ray.cancel(ref, force=True)
                _store(results, failed_rows(item, RunFailure.KILLED, now - started, results.row_type))
                bar.update(1)
    finally:
        for ref in running:
            ray.cancel(ref, force=True)
        if started_here:
            ray.shutdown()


__all__ = [
    "DEFAULT_EXECUTION",
    "EXECUTORS",
    "INLINE",
    "Execution",
    "Executor",
    "Work",
    "failed_rows",
    "hard_limit",
    "run_work",
]
