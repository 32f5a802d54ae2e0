"""Benchmark executors: inline, local worker processes and Ray give the same rows; runaway runs
are killed; crashed workers are recorded; runs resume."""

from __future__ import annotations

import json
import os
import time
from dataclasses import dataclass
from pathlib import Path
from typing import Any

import pytest

from hbtp.bench.results import ResultsFile, Row, optional
from hbtp.bench.runner import INLINE, Execution, Work, run_work
from hbtp.bench.table1 import Table1Config, run_table1
from hbtp.errors import InputError

#: Fields that measure time (they differ between any two runs).
TIMES = {"time_s", "planning_s", "llm_s", "b_time_s", "b_lm_time_s", "plan_time_s", "elapsed_s"}


def untimed(path: Path) -> list[dict[str, Any]]:
    rows = [json.loads(line) for line in path.read_text(encoding="utf-8").splitlines()]
    return sorted(
        ({k: v for k, v in row.items() if k not in TIMES} for row in rows), key=lambda r: json.dumps(r, sort_keys=True)
    )


@dataclass(frozen=True, kw_only=True)
class Square(Row):
    """A test row: ``n`` squared (``None`` for a killed or crashed run)."""

    KEY = ("n",)

    n: int
    status: str
    solved: bool
    square: int | None = optional()
    time_s: float | None = optional()


# Module-level run functions, so that worker processes can import them.
def square(spec: int) -> Square:
    return Square(n=spec, square=spec * spec, status="ok", solved=True)


def sleepy(spec: int) -> Square:
    if spec == 2:
        time.sleep(600)  # a planner that ignores its own time limit
    return square(spec)


def whose(spec: int) -> Square:
    """The run's worker process id, as the square (one worker runs all or each run has its own)."""
    return Square(n=spec, square=os.getpid(), status="ok", solved=True)


def crashing(spec: int) -> Square:
    if spec == 1:
        os._exit(3)  # a worker that dies (out of memory, a segfault in a native library)
    return square(spec)


def work_of(numbers: range) -> list[Work]:
    return [Work((n,), n, {"n": n}) for n in numbers]


def results_in(path: Path) -> ResultsFile[Square]:
    return ResultsFile(path / "results.jsonl", Square)


def test_local_workers_kill_a_runaway_run_and_keep_the_others(tmp_path: Path) -> None:
    results = results_in(tmp_path)
    started = time.monotonic()
    run_work(sleepy, work_of(range(5)), results, Execution(jobs=2, progress=False), kill_after=3.0, description="t")
    assert time.monotonic() - started < 60
    rows = {row.n: row for row in results.rows.values()}
    assert sorted(rows) == [0, 1, 2, 3, 4]
    assert rows[2].status == "killed"
    assert rows[2].solved is False
    assert rows[2].square is None
    assert (rows[2].time_s or 0.0) >= 3.0
    assert all(rows[n].square == n * n for n in (0, 1, 3, 4))
    # The killed run's line holds its known fields and the failure, nothing else.
    killed = [json.loads(line) for line in (tmp_path / "results.jsonl").read_text(encoding="utf-8").splitlines()]
    assert [set(line) for line in killed if line["n"] == 2] == [{"n", "status", "solved", "time_s"}]


def test_fresh_workers_give_every_run_a_process_of_its_own(tmp_path: Path) -> None:
    kept, fresh = results_in(tmp_path / "kept"), results_in(tmp_path / "fresh")
    for results, fresh_workers in ((kept, False), (fresh, True)):
        execution = Execution(progress=False, fresh_workers=fresh_workers)
        run_work(whose, work_of(range(4)), results, execution, kill_after=60, description="t")
    assert len({row.square for row in kept.rows.values()}) == 1
    assert len({row.square for row in fresh.rows.values()}) == 4
    assert os.getpid() not in {row.square for row in fresh.rows.values()}


def test_a_run_that_kills_its_worker_is_recorded_as_crashed(tmp_path: Path) -> None:
    results = results_in(tmp_path)
    run_work(crashing, work_of(range(6)), results, Execution(jobs=2, progress=False), kill_after=60, description="t")
    rows = {row.n: row for row in results.rows.values()}
    assert rows[1].status == "crashed"
    assert rows[1].solved is False
    assert sorted(rows) == [0, 1, 2, 3, 4, 5]
    # The runs that shared the pool with it are not charged with the crash.
    assert all(rows[n].square == n * n for n in (0, 2, 3, 4, 5))


def test_runs_resume_and_skip_what_results_hold(tmp_path: Path) -> None:
    path = tmp_path / "results.jsonl"
    run_work(square, work_of(range(3)), results_in(tmp_path), INLINE, kill_after=60, description="t")
    first = path.read_text(encoding="utf-8")
    resumed = results_in(tmp_path)
    assert [row.square for row in resumed.ordered([(n,) for n in range(5)])] == [0, 1, 4]
    run_work(square, work_of(range(5)), resumed, INLINE, kill_after=60, description="t")
    lines = path.read_text(encoding="utf-8").splitlines()
    assert path.read_text(encoding="utf-8").startswith(first)
    assert [json.loads(line)["n"] for line in lines] == [0, 1, 2, 3, 4]


def test_errors_in_a_run_reach_the_caller(tmp_path: Path) -> None:
    results = results_in(tmp_path)
    with pytest.raises(ZeroDivisionError):
        run_work(reciprocal, work_of(range(3)), results, Execution(progress=False), kill_after=60, description="t")


def reciprocal(spec: int) -> Square:
    return Square(n=spec, square=1 // spec, status="ok", solved=True)


@pytest.mark.parametrize(("executor", "jobs", "kill_after"), [("nope", 1, None), ("local", 0, None), ("local", 1, 0)])
def test_bad_execution_options_are_input_errors(executor: Any, jobs: int, kill_after: float | None) -> None:
    with pytest.raises(InputError):
        Execution(executor=executor, jobs=jobs, kill_after=kill_after)


def test_table1_rows_are_the_same_inline_and_on_two_workers(tmp_path: Path) -> None:
    config = Table1Config(limit=6, time_limit=5.0)
    inline = run_table1(config, tmp_path / "inline", INLINE)
    parallel = run_table1(config, tmp_path / "jobs2", Execution(jobs=2, progress=False))
    assert untimed(tmp_path / "inline" / "results.jsonl") == untimed(tmp_path / "jobs2" / "results.jsonl")
    for name, row in inline["planners"].items():
        other = parallel["planners"][name]
        assert (row["solved"], row["mean_cost"], row["mean_explored"]) == (
            other["solved"],
            other["mean_cost"],
            other["mean_explored"],
        )


@pytest.mark.slow
def test_table1_rows_are_the_same_on_a_local_ray(tmp_path: Path) -> None:
    pytest.importorskip("ray", reason="the ray extra is not installed")
    os.environ.pop("RAY_ADDRESS", None)
    config = Table1Config(limit=4, time_limit=5.0)
    run_table1(config, tmp_path / "inline", INLINE)
    run_table1(config, tmp_path / "ray", Execution(executor="ray", jobs=2, progress=False))
    assert untimed(tmp_path / "inline" / "results.jsonl") == untimed(tmp_path / "ray" / "results.jsonl")


@pytest.mark.slow
def test_ray_kills_a_runaway_run(tmp_path: Path) -> None:
    ray = pytest.importorskip("ray", reason="the ray extra is not installed")
    os.environ.pop("RAY_ADDRESS", None)
    # This test module's functions must be importable by Ray's workers; the runner uses a Ray
    # that is already initialised as it is.
    folders = os.pathsep.join(str(folder) for folder in (Path(__file__).parent, Path(__file__).parent.parent))
    ray.init(num_cpus=2, include_dashboard=False, runtime_env={"env_vars": {"PYTHONPATH": folders}})
    try:
        results = results_in(tmp_path)
        execution = Execution("ray", jobs=2, progress=False)
        run_work(sleepy, work_of(range(4)), results, execution, kill_after=5, description="t")
    finally:
        ray.shutdown()
    rows = {row.n: row for row in results.rows.values()}
    assert rows[2].status == "killed"
    assert all(rows[n].square == n * n for n in (0, 1, 3))


def test_a_pool_that_breaks_is_replaced_and_its_runs_run_again(tmp_path: Path, monkeypatch: pytest.MonkeyPatch) -> None:
    # pebble can raise BrokenProcessPool ("All workers expired") when a worker dies unseen: the
    # runs it held go to a new pool instead of ending the benchmark.
    from concurrent.futures.process import BrokenProcessPool

    from hbtp.bench import runner

    real = runner.ProcessPool
    pools: list[Any] = []

    class BreaksOnce(real):  # type: ignore[misc, valid-type]
        def schedule(self, *args: Any, **kwargs: Any) -> Any:
            if len(pools) == 1 and getattr(self, "scheduled", 0) == 2:
                raise BrokenProcessPool("All workers expired")
            self.scheduled = getattr(self, "scheduled", 0) + 1
            return super().schedule(*args, **kwargs)

    def make(*args: Any, **kwargs: Any) -> Any:
        pool = BreaksOnce(*args, **kwargs)
        pools.append(pool)
        return pool

    monkeypatch.setattr(runner, "ProcessPool", make)
    results = results_in(tmp_path)
    run_work(square, work_of(range(5)), results, Execution(jobs=2, progress=False), kill_after=60, description="t")
    assert len(pools) == 2
    assert {row.n: row.square for row in results.rows.values()} == {n: n * n for n in range(5)}
