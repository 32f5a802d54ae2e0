"""Limits of a planning run: time, expansions and memory end the search with the partial tree."""

from __future__ import annotations

import gc
import math
import random
import time
from collections.abc import Iterator
from contextlib import contextmanager

import pytest

from hbtp.bt import full_tree
from hbtp.collector import searches_frozen
from hbtp.deadline import Deadline, expired, seconds_left, within
from hbtp.domains import DomainBuilder, Scenario
from hbtp.errors import InputError
from hbtp.logic.task import GroundTask
from hbtp.planning import Limits, PlanResult, Status, plan
from hbtp.planning.limits import LimitWatch
from hbtp.planning.search import release_search_memory
from helpers import run_tree

HARD_GOAL = "IsIn_cutlets_box & IsCut_cutlets"  # OBTEA without a heuristic needs far more than a second
EASY_GOAL = "IsIn_milk_fridge"


@contextmanager
def cyclic_gc_paused() -> Iterator[None]:
    """Keep Python's cyclic garbage collector out of a timing.

    The search leaves the collector on; a full (generation 2) collection of the objects a robothow
    search creates takes 0.05-0.13 s here, and when it falls on the deadline plan() returns up to
    0.15 s late. What is measured here is the planner's own checking of the limit, as a command
    runs it (searches_frozen: freeing a finished search's objects is left to the next search).
    """
    gc.collect()
    enabled = gc.isenabled()
    gc.disable()
    try:
        with searches_frozen():
            yield
    finally:
        if enabled:
            gc.enable()


def check_partial_tree(scenario: Scenario, result: PlanResult, samples: int = 40) -> None:
    """The partial tree of a stopped search is still a sound tree from the conditions it explored."""
    task = scenario.task
    goal = result.goal.ids
    assert result.expansions[0].condition == goal
    assert result.expansions[0].action is None
    tree = full_tree(result.expansions)
    rng = random.Random(len(result.expansions))
    positions = rng.sample(range(len(result.expansions)), min(samples, len(result.expansions)))
    for position in positions:
        run = run_tree(tree, task, result.expansions[position].condition, len(result.expansions) + 1)
        assert run.reached, f"expanded condition #{position} does not lead to the goal"


def test_time_limit_stops_a_hard_search_promptly_with_the_partial_tree(robothow: Scenario) -> None:
    task = robothow.task
    time_s = 0.1
    with cyclic_gc_paused():
        started = time.perf_counter()
        result = plan(
            task, HARD_GOAL, "obtea", heuristic="none", mutexes=robothow.mutexes, limits=Limits(time_s=time_s)
        )
        elapsed = time.perf_counter() - started
    assert result.status is Status.TIMEOUT, result.message
    assert not result.solved
    assert result.cost is None
    assert result.executed == ()
    assert result.solution == ()
    assert elapsed <= time_s + 0.05, (
        f"plan() returned {elapsed - time_s:.3f} s after its {time_s} s limit "
        f"(the search itself stopped {result.stats.time_s - time_s:.3f} s after it)"
    )
    assert time_s <= result.stats.time_s <= time_s + 0.05
    assert "time limit" in result.message
    assert len(result.expansions) > 1
    assert result.stats.explored == len(result.expansions)
    assert result.stats.generated >= len(result.expansions) - 1
    assert result.stats.action_space == len(task.actions)
    check_partial_tree(robothow, result)


def test_time_limit_is_reported_without_mutexes_too(robothow: Scenario) -> None:
    with cyclic_gc_paused():
        started = time.perf_counter()
        result = plan(robothow.task, HARD_GOAL, "obtea", heuristic="none", limits=Limits(time_s=0.1))
        elapsed = time.perf_counter() - started
    assert result.status is Status.TIMEOUT
    assert elapsed <= 0.15
    assert result.expansions
    assert result.stats.explored == len(result.expansions)


@pytest.mark.parametrize("planner", ["bte", "obtea", "hbtp-o", "hbtp-s"])
@pytest.mark.parametrize("count", [1, 7, 300])
def test_expansion_limit_stops_after_exactly_that_many_expansions(robothow: Scenario, planner: str, count: int) -> None:
    result = plan(
        robothow.task,
        HARD_GOAL,
        planner,
        heuristic="none",
        mutexes=robothow.mutexes,
        limits=Limits(max_expansions=count),
    )
    assert result.status is Status.NODE_LIMIT
    assert len(result.expansions) == count
    assert result.stats.explored == count
    assert result.message == f"expansion limit of {count} reached"
    assert result.cost is None
    check_partial_tree(robothow, result)


def test_expansion_limit_equal_to_the_search_size_still_solves(robowaiter: Scenario) -> None:
    """A search that finds its plan at expansion k is solved with a limit of k, stopped with k - 1."""
    task = robowaiter.task
    goal = "On_Coffee_Table1"
    free = plan(task, goal, "obtea", mutexes=robowaiter.mutexes)
    assert free.solved
    needed = len(free.expansions)
    assert needed > 2
    exact = plan(task, goal, "obtea", mutexes=robowaiter.mutexes, limits=Limits(max_expansions=needed))
    assert exact.solved
    assert exact.cost == free.cost
    assert exact.expansions == free.expansions
    short = plan(task, goal, "obtea", mutexes=robowaiter.mutexes, limits=Limits(max_expansions=needed - 1))
    assert short.status is Status.NODE_LIMIT
    assert short.expansions == free.expansions[: needed - 1]


def test_tiny_memory_limit_stops_at_the_first_memory_check(robothow: Scenario) -> None:
    """Memory is read every 256 expansions; a 1 MB limit is below any Python process."""
    result = plan(
        robothow.task, HARD_GOAL, "obtea", heuristic="none", mutexes=robothow.mutexes, limits=Limits(memory_mb=1.0)
    )
    assert result.status is Status.MEMORY_LIMIT
    assert len(result.expansions) == 256
    assert result.stats.explored == 256
    assert "memory limit of 1.0 MB" in result.message
    check_partial_tree(robothow, result)


def test_generous_limits_do_not_change_a_solved_search(robothow: Scenario) -> None:
    hints_free = plan(robothow.task, EASY_GOAL, "obtea", mutexes=robothow.mutexes, heuristic="lm")
    limited = plan(
        robothow.task,
        EASY_GOAL,
        "obtea",
        mutexes=robothow.mutexes,
        heuristic="lm",
        limits=Limits(time_s=60.0, max_expansions=1_000_000, memory_mb=1e6),
    )
    assert hints_free.solved
    assert limited.solved
    assert limited.cost == hints_free.cost
    assert limited.expansions == hints_free.expansions


@pytest.mark.parametrize(
    "options",
    [
        {"time_s": 0},
        {"time_s": 0.0},
        {"time_s": -1},
        {"time_s": -0.001},
        {"time_s": math.nan},
        {"max_expansions": 0},
        {"max_expansions": -5},
        {"memory_mb": 0},
        {"memory_mb": -1.5},
        {"memory_mb": math.nan},
    ],
    ids=lambda options: "-".join(f"{k}={v}" for k, v in options.items()),
)
def test_limits_reject_values_that_are_not_positive(options: dict[str, float]) -> None:
    with pytest.raises(InputError, match="must be"):
        Limits(**options)


def test_limits_accept_positive_values_and_default_to_none() -> None:
    assert Limits() == Limits(time_s=None, max_expansions=None, memory_mb=None)
    limits = Limits(time_s=0.001, max_expansions=1, memory_mb=0.5)
    assert (limits.time_s, limits.max_expansions, limits.memory_mb) == (0.001, 1, 0.5)


# ================================================== one deadline for the whole command
def _chain_task(length: int) -> GroundTask:
    """s0 = {At(p0)}; Step_i moves from p_i to p_(i+1): the heuristic set-up visits every atom."""
    builder = DomainBuilder("chain").initial(["At(p0)"])
    for i in range(length):
        builder.action(f"Step(p{i})", pre=[f"At(p{i})"], add=[f"At(p{i + 1})"], delete=[f"At(p{i})"])
    return builder.build()


def test_a_shared_deadline_bounds_the_search_below_its_own_time_limit(robothow: Scenario) -> None:
    """The search stops within 0.05 s of a deadline it did not set. The deadline starts after
    cyclic_gc_paused's full collection, which takes 0.25 s after the rest of the suite has run."""
    with cyclic_gc_paused():
        deadline = Deadline(0.1)
        limits = Limits(time_s=60, deadline=deadline)
        result = plan(robothow.task, HARD_GOAL, "obtea", heuristic="none", mutexes=robothow.mutexes, limits=limits)
        late = -deadline.remaining()
    assert result.status is Status.TIMEOUT
    assert result.message == "time limit of 0.1 s reached"
    assert late <= 0.05
    assert result.expansions


def test_starting_now_gives_limits_a_deadline_of_their_time_limit() -> None:
    before = time.perf_counter()
    limits = Limits(time_s=5, max_expansions=3).starting_now()
    assert limits.deadline is not None
    assert limits.deadline.seconds == 5
    assert before <= limits.deadline.started <= time.perf_counter()
    assert (limits.time_s, limits.max_expansions) == (5, 3)
    assert Limits(max_expansions=3).starting_now() == Limits(max_expansions=3)


def test_a_sub_step_caps_the_command_deadline_and_never_extends_it() -> None:
    command = Deadline(10.0, memory_mb=500.0)
    round_cap = within(command, 0.5)
    assert round_cap is not None
    assert round_cap is not command
    assert round_cap.seconds == 0.5
    assert round_cap.memory_mb == 500.0
    assert round_cap.at <= command.at
    assert within(command, 60.0) is command  # a cap beyond the deadline leaves it as it is
    assert within(command, None) is command
    assert within(command, math.inf) is command
    assert within(None, None) is None
    alone = within(None, 2.0)
    assert alone is not None
    assert 1.9 < alone.remaining() <= 2.0
    assert seconds_left(None) == math.inf
    assert not expired(None)
    assert expired(Deadline(0.5, started=time.perf_counter() - 1.0))


def test_a_search_stops_at_the_earlier_of_its_own_limit_and_the_deadline() -> None:
    watch = LimitWatch(Limits(time_s=0.2, deadline=Deadline(30.0)), time.perf_counter())
    assert watch.deadline is not None
    assert watch.deadline.seconds == 0.2
    shared = Deadline(0.1)
    watch = LimitWatch(Limits(time_s=30.0, deadline=shared), time.perf_counter())
    assert watch.deadline is shared
    assert LimitWatch(Limits(), time.perf_counter()).deadline is None


def test_an_expired_deadline_stops_the_heuristic_set_up() -> None:
    task = _chain_task(3000)  # a fresh task: its heuristic tables are not cached yet
    expired = Deadline(0.5, started=time.perf_counter() - 1.0)
    started = time.perf_counter()
    result = plan(task, "At(p3000)", "obtea", heuristic="lm", limits=Limits(deadline=expired))
    assert time.perf_counter() - started < 0.5
    assert result.status is Status.TIMEOUT
    assert result.message == "time limit of 0.5 s reached while setting up the heuristic"
    assert result.expansions == ()
    # Nothing half-built was cached: with time, the same search solves.
    assert plan(task, "At(p3000)", "obtea", heuristic="lm").cost == 3000


def test_the_objects_of_a_search_are_frozen_until_the_next_one(robowaiter: Scenario) -> None:
    """A collection right after a long search would walk all its objects (a second after 10 s): in
    a command (searches_frozen, as the CLI and benchmark workers run) they are frozen until the next
    search; a library call leaves the collector as it found it."""
    assert gc.get_freeze_count() == 0
    plan(robowaiter.task, "On_Coffee_Table1", "obtea", mutexes=robowaiter.mutexes)
    assert gc.get_freeze_count() == 0  # the library alone: no process-wide state changed
    assert gc.isenabled()
    with searches_frozen():
        plan(robowaiter.task, "On_Coffee_Table1", "obtea", mutexes=robowaiter.mutexes)
        assert gc.get_freeze_count() > 0
        assert gc.isenabled()
        release_search_memory()
        assert gc.get_freeze_count() == 0
        plan(robowaiter.task, "On_Coffee_Table1", "obtea", mutexes=robowaiter.mutexes)
    assert gc.get_freeze_count() == 0  # freed on leaving
    gc.disable()
    try:
        plan(robowaiter.task, "On_Coffee_Table1", "obtea", mutexes=robowaiter.mutexes)
        assert not gc.isenabled()  # the caller's choice is kept
    finally:
        gc.enable()
