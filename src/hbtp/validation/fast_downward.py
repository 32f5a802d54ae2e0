"""Fast Downward runs: the driver on PDDL files, or unified-planning's reader and planner, with the
plan replayed in hbtp's task (see :mod:`hbtp.validation` for when each is used)."""

from __future__ import annotations

import contextlib
import enum
import logging
import math
import os
import re
import signal
import subprocess
import sys
import tempfile
import time
import warnings
from collections.abc import Iterable, Iterator
from dataclasses import dataclass
from importlib import resources
from pathlib import Path
from typing import Any, NamedTuple

from hbtp.domains import write_grounded
from hbtp.domains.pddl_writer import GOAL_ACTION, keyword_safe_predicates
from hbtp.errors import BackendError, InputError
from hbtp.files import InputKind, read_text
from hbtp.logic.execution import apply_actions
from hbtp.logic.tables import TaskTable
from hbtp.logic.task import Goal, GroundAction, GroundTask
from hbtp.planning import Status

log = logging.getLogger(__name__)

INSTALL_HINT = "install the validate extra: pip install -e '.[validate]'"
ENGINE = "fast-downward-opt"
#: The search of unified-planning's ``fast-downward-opt``, used with the driver too.
SEARCH = "astar(lmcut())"
#: The search for files whose translation has axioms, which LM-cut and h_max do not support.
BLIND_SEARCH = "astar(blind())"
#: The search for files whose translation has conditional effects (LM-cut refuses them) and no axioms:
#: h_max supports them and stays admissible.
HMAX_SEARCH = "astar(hmax())"
#: The translator's output in the driver's working directory.
_TRANSLATION = "output.sas"
#: The translator's count of ground operators in the driver's output.
_OPERATORS_LINE = re.compile(r"^Translator operators: (\d+)$", re.MULTILINE)
#: ``auto`` runs the driver for tasks with more grounded actions than this.
AUTO_DRIVER_ACTIONS = 1000


class Engine(enum.StrEnum):
    """How Fast Downward is run (``hbtp validate --engine``)."""

    AUTO = "auto"  #: the driver for large tasks, unified-planning for the others
    UNIFIED_PLANNING = "unified-planning"  #: through unified-planning's Fast Downward engine
    DRIVER = "driver"  #: Fast Downward's own driver on exported PDDL files


ENGINES: tuple[str, ...] = tuple(e.value for e in Engine)
#: Seconds per planner run in a comparison: on RobotHow's record 40 both OBTEA without mutexes and
#: Fast Downward need close to a minute.
COMPARE_TIME_LIMIT = 300.0

_COST_LINE = re.compile(r";\s*cost\s*=\s*(\d+)")
_UNSOLVABLE_CODES = (10, 11)  # Fast Downward's exit codes: proved unsolvable by the translator, the search
_TIMEOUT_CODES = (21, 23, 24)
_REACHED_TIME_LIMIT = "Fast Downward reached the time limit"


class RunStatus(enum.Enum):
    """How a Fast Downward run ended."""

    OPTIMAL = "optimal"  # a plan, proved optimal
    UNSOLVABLE = "unsolvable"  # proved
    TIMEOUT = "timeout"
    ERROR = "error"

    @property
    def decided(self) -> bool:
        """Whether the run answered: an optimal cost or a proof that there is none."""
        return self in (RunStatus.OPTIMAL, RunStatus.UNSOLVABLE)


#: The OBTEA outcomes that answer: a cost (optimal: OBTEA with an admissible heuristic) or a proof.
OBTEA_DECIDED = (Status.SOLVED, Status.UNSOLVABLE)


@dataclass(frozen=True)
class FastDownwardRun:
    """One Fast Downward run.

    ``status`` is :attr:`~RunStatus.OPTIMAL` (``cost`` and ``plan`` set), ``UNSOLVABLE`` (proved),
    ``TIMEOUT`` or ``ERROR`` (``message`` says why). ``plan`` holds hbtp's action names (``Walk(apple)``);
    ``time_s`` is the whole call: export, parsing and the planner; ``engine`` the way it ran.
    """

    status: RunStatus
    cost: int | None = None
    plan: tuple[str, ...] = ()
    time_s: float = 0.0
    engine: str = ""
    message: str = ""


class _Outcome(NamedTuple):
    """What a planner said, before the plan is checked: status, action names, reported cost, message."""

    status: RunStatus
    names: tuple[str, ...] = ()
    reported_cost: int | None = None
    message: str = ""
    #: Fast Downward's translator's ground operators (the driver's output), when known.
    operators: int | None = None


@dataclass(frozen=True)
class ObteaRun:
    """OBTEA's outcome on one goal: ``cost`` is D(T) (``None`` unless solved)."""

    status: Status
    cost: int | None
    time_s: float


# ------------------------------------------------------------ Fast Downward
def require_extra() -> None:
    """Import unified-planning and its Fast Downward engine, or say how to install them."""
    try:
        import unified_planning.shortcuts  # noqa: F401
        import up_fast_downward  # noqa: F401
    except ImportError as error:
        raise BackendError(f"Fast Downward is not available ({error}); {INSTALL_HINT}") from None


def choose_engine(task: GroundTask, engine: Engine = Engine.AUTO) -> Engine:
    """The way ``auto`` runs Fast Downward on ``task`` (other choices are returned unchanged)."""
    if engine == Engine.AUTO:
        return Engine.DRIVER if len(task.actions) > AUTO_DRIVER_ACTIONS else Engine.UNIFIED_PLANNING
    if engine in ENGINES:
        return Engine(engine)
    raise InputError(f"unknown engine {engine!r}; choose one of: {', '.join(ENGINES)}")


def run_fast_downward(
    task: GroundTask, goal: Goal, *, time_limit: float = 60.0, engine: Engine = Engine.AUTO
) -> FastDownwardRun:
    """Solve ``goal`` optimally with Fast Downward; its plan is replayed in ``task`` to check it."""
    require_extra()
    chosen = choose_engine(task, engine)
    by_name = _actions_by_lowercase_name(task)
    started = time.perf_counter()
    domain_text, problem_text = write_grounded(task, goal, rename_keywords=True)
    with tempfile.TemporaryDirectory(prefix="hbtp-fd-") as folder, contextlib.chdir(folder):
        domain_file, problem_file = Path(folder, "domain.pddl"), Path(folder, "problem.pddl")
        domain_file.write_text(domain_text, encoding="utf-8")
        problem_file.write_text(problem_text, encoding="utf-8")
        if chosen is Engine.DRIVER:
            outcome = _solve_with_driver(domain_file, problem_file, time_limit)
        else:
            key = domain_text + problem_text.split("(:goal", 1)[0]
            outcome = _solve_with_unified_planning(task, goal, key, problem_file, time_limit)
    elapsed = time.perf_counter() - started
    if outcome.status is not RunStatus.OPTIMAL:
        return FastDownwardRun(outcome.status, time_s=elapsed, engine=chosen, message=outcome.message)
    return _replay(task, goal, by_name, outcome, elapsed, chosen)


def fast_downward_cost(
    task: GroundTask, goal: Goal, *, time_limit: float = 60.0, engine: Engine = Engine.AUTO
) -> int | None:
    """Fast Downward's optimal cost of ``goal`` in ``task``; ``None`` when it proves the goal unsolvable.

    Raises :class:`~hbtp.errors.BackendError` when the ``validate`` extra is missing, on a timeout
    and on any other failure.
    """
    run = run_fast_downward(task, goal, time_limit=time_limit, engine=engine)
    if run.status.decided:
        return run.cost
    raise BackendError(f"Fast Downward failed ({run.status.value}): {run.message}")


@dataclass(frozen=True)
class FilesRun:
    """Fast Downward on the original PDDL files, read and grounded by its own translator (an
    independent check of hbtp's reading and grounding): the status, the optimal cost it reports,
    its translator's ground operators, the seconds, the search used and why it failed."""

    status: RunStatus
    cost: int | None = None
    operators: int | None = None
    time_s: float = 0.0
    search: str = SEARCH
    message: str = ""


def run_fast_downward_files(domain_file: Path, problem_file: Path, *, time_limit: float = 60.0) -> FilesRun:
    """Solve the files optimally with Fast Downward's driver: A* with LM-cut; A* with h_max when the
    translation has conditional effects, which LM-cut does not support; blind A* when it has axioms
    (some negated quantifiers and disjunctive goals become axioms), which neither supports."""
    require_extra()
    started = time.perf_counter()
    texts = read_text(domain_file, InputKind.PDDL), read_text(problem_file, InputKind.PDDL)
    with tempfile.TemporaryDirectory(prefix="hbtp-fd-") as folder, contextlib.chdir(folder):
        copies = Path(folder, "domain.pddl"), Path(folder, "problem.pddl")
        for copy, text in zip(copies, texts, strict=True):
            copy.write_text(text, encoding="utf-8")
        search = SEARCH
        outcome = _solve_with_driver(*copies, time_limit, search)
        fallback = _fallback_search(outcome)
        if fallback:
            search = fallback
            left = time_limit - (time.perf_counter() - started)
            outcome = _solve_with_driver(*copies, max(left, 1.0), search)
    elapsed = time.perf_counter() - started
    message = outcome.message
    if outcome.status is RunStatus.OPTIMAL and outcome.reported_cost is None:
        return FilesRun(RunStatus.ERROR, None, outcome.operators, elapsed, search, "Fast Downward reported no cost")
    return FilesRun(outcome.status, outcome.reported_cost, outcome.operators, elapsed, search, message)


def _fallback_search(outcome: _Outcome) -> str:
    """The search to run again with when LM-cut refused the translation ("" when it did not), read
    in the driver's working directory."""
    if outcome.status is not RunStatus.ERROR:
        return ""
    if "support axioms" in outcome.message:
        return BLIND_SEARCH
    if "support conditional effects" in outcome.message:
        translation = Path(_TRANSLATION)
        has_axioms = not translation.is_file() or "begin_rule" in translation.read_text(encoding="utf-8")
        return BLIND_SEARCH if has_axioms else HMAX_SEARCH
    return ""


def lifted_fast_downward_cost(domain_file: Path, problem_file: Path, *, time_limit: float = 60.0) -> int | None:
    """:func:`run_fast_downward_files`'s optimal cost; ``None`` when it proves the goal unsolvable.
    Raises :class:`~hbtp.errors.BackendError` as :func:`fast_downward_cost` does."""
    run = run_fast_downward_files(domain_file, problem_file, time_limit=time_limit)
    if run.status.decided:
        return run.cost
    raise BackendError(f"Fast Downward failed ({run.status.value}): {run.message}")


def _replay(
    task: GroundTask,
    goal: Goal,
    by_name: dict[str, GroundAction],
    outcome: _Outcome,
    elapsed: float,
    engine: str,
) -> FastDownwardRun:
    """Map the planner's (lowercased) action names back to ``task`` and execute the plan from s0."""
    try:  # the free actions of a compiled disjunctive goal have no counterpart
        actions = [by_name[name.lower()] for name in outcome.names if not name.lower().startswith(GOAL_ACTION)]
    except KeyError as missing:
        message = f"Fast Downward's plan has an unknown action {missing}"
        return FastDownwardRun(RunStatus.ERROR, time_s=elapsed, engine=engine, message=message)
    readable = tuple(action.name for action in actions)
    state, applied = apply_actions(task, actions)
    cost = sum(action.cost for action in actions)
    problem = ""
    if applied < len(actions) or not goal.holds(state):
        problem = "Fast Downward's plan does not reach the goal in hbtp's task"
    elif outcome.reported_cost is not None and outcome.reported_cost != cost:
        problem = f"Fast Downward reports cost {outcome.reported_cost}, its plan costs {cost} in hbtp's task"
    if problem:
        return FastDownwardRun(RunStatus.ERROR, plan=readable, time_s=elapsed, engine=engine, message=problem)
    return FastDownwardRun(RunStatus.OPTIMAL, cost, readable, elapsed, engine)


def _actions_by_lowercase_name(task: GroundTask) -> dict[str, GroundAction]:
    """Actions by lowercased PDDL name; refuses names Fast Downward's lowercasing would merge."""
    _check_case(task.name, "action", (action.signature.underscored for action in task.actions))
    _check_case(task.name, "object", (*task.constants, *task.objects))
    _check_case(task.name, "predicate", {atom.predicate for atom in task.atoms})
    return {action.signature.underscored.lower(): action for action in task.actions}


def _check_case(task_name: str, kind: str, names: Iterable[str]) -> None:
    seen: dict[str, str] = {}
    for name in names:
        other = seen.setdefault(name.lower(), name)
        if other != name:
            raise InputError(
                f"{task_name}: {kind}s {other!r} and {name!r} differ only in case; Fast Downward merges them"
            )


# ----------------------------------------------------------------- driver
def _driver_script() -> Path:
    return Path(str(resources.files("up_fast_downward") / "downward" / "fast-downward.py"))


def _solve_with_driver(domain_file: Path, problem_file: Path, time_limit: float, search: str = SEARCH) -> _Outcome:
    """Run Fast Downward's driver (A* with LM-cut by default) on the files, in the current
    (temporary) directory."""
    plan_file = domain_file.with_name("plan.txt")
    command = [
        sys.executable,
        str(_driver_script()),
        "--plan-file",
        str(plan_file),
        "--overall-time-limit",
        f"{max(1, math.ceil(time_limit))}s",
        str(domain_file),
        str(problem_file),
        "--search",
        search,
    ]
    process = subprocess.Popen(
        command, stdout=subprocess.PIPE, stderr=subprocess.PIPE, text=True, start_new_session=True
    )
    try:
        output, errors = process.communicate(timeout=time_limit + 30)
    except subprocess.TimeoutExpired:
        os.killpg(process.pid, signal.SIGKILL)  # the driver's own process group: translator and search
        process.communicate()
        return _Outcome(RunStatus.TIMEOUT, message="Fast Downward did not stop at its time limit")
    return _driver_outcome(process.returncode, plan_file, output, errors)


def _driver_outcome(code: int, plan_file: Path, output: str, errors: str) -> _Outcome:
    found = _OPERATORS_LINE.search(output or "")
    operators = int(found.group(1)) if found else None
    if code == 0 and plan_file.is_file():
        return _read_plan_file(plan_file)._replace(operators=operators)
    if code in _UNSOLVABLE_CODES:
        return _Outcome(RunStatus.UNSOLVABLE, operators=operators)
    if code in _TIMEOUT_CODES:
        return _Outcome(RunStatus.TIMEOUT, message=_REACHED_TIME_LIMIT, operators=operators)
    tail = " ".join((errors or output).split())[-500:]
    return _Outcome(
        RunStatus.ERROR, message=f"Fast Downward's driver exited with code {code}: {tail}", operators=operators
    )


def _read_plan_file(plan_file: Path) -> _Outcome:
    """``(walk_apple)`` lines and a ``; cost = 12 (general cost)`` line."""
    names: list[str] = []
    cost: int | None = None
    for line in plan_file.read_text(encoding="utf-8").splitlines():
        line = line.strip()
        if line.startswith(";"):
            found = _COST_LINE.match(line)
            cost = int(found.group(1)) if found else cost
        elif line:
            names.append(line.strip("()").split()[0])
    return _Outcome(RunStatus.OPTIMAL, tuple(names), cost)


# ------------------------------------------------------- unified-planning
@contextlib.contextmanager
def _up_environment() -> Iterator[Any]:
    """unified-planning's global environment, quiet and lenient about shared names, for one call.

    RoboWaiter has objects ``On``/``Off`` and a predicate ``On``: PDDL keeps objects and predicates
    apart, but unified-planning refuses a shared name unless ``error_used_name`` is off (a private
    environment does not work: the Fast Downward engine builds expressions in the global one).
    """
    from unified_planning.shortcuts import get_environment

    environment = get_environment()
    saved = environment.credits_stream, environment.error_used_name
    environment.credits_stream, environment.error_used_name = None, False
    try:
        with warnings.catch_warnings():
            warnings.filterwarnings("ignore", message=r"Name .* already defined", category=UserWarning)
            yield environment
    finally:
        environment.credits_stream, environment.error_used_name = saved


def _solve_with_unified_planning(
    task: GroundTask, goal: Goal, key: str, problem_file: Path, time_limit: float
) -> _Outcome:
    """Read the files with unified-planning (once per ``key``: the text but the goal) and run ``fast-downward-opt``."""
    from unified_planning.engines import PlanGenerationResultStatus as UpStatus

    try:
        with _up_environment() as environment:
            problem = _problem_for_goal(task, goal, key, problem_file)
            with environment.factory.OneshotPlanner(name=ENGINE) as planner:
                result = planner.solve(problem, timeout=time_limit)
    except Exception as error:  # unified-planning raises many unrelated types
        return _Outcome(RunStatus.ERROR, message=f"unified-planning: {type(error).__name__}: {error}")
    if result.status == UpStatus.SOLVED_OPTIMALLY:
        return _Outcome(RunStatus.OPTIMAL, tuple(instance.action.name for instance in result.plan.actions))
    if result.status == UpStatus.UNSOLVABLE_PROVEN:
        return _Outcome(RunStatus.UNSOLVABLE)
    if result.status == UpStatus.TIMEOUT:
        return _Outcome(RunStatus.TIMEOUT, message=_REACHED_TIME_LIMIT)
    logs = " ".join(" ".join(m.message.split()) for m in result.log_messages or ())
    return _Outcome(RunStatus.ERROR, message=f"{result.status.name}: {logs[-500:]}")


#: Fast Downward's parsed problems of a task, by exported text (the goal set apart).
_PARSED_PROBLEMS: TaskTable[dict[str, Any]] = TaskTable("Fast Downward's parsed problems")


def _problem_for_goal(task: GroundTask, goal: Goal, key: str, problem_file: Path) -> Any:
    """The parsed problem with ``goal``: read from the files the first time, else a copy with a new goal.

    The parsed problem is kept with ``task`` (:meth:`~hbtp.logic.task.GroundTask.derived`), one per
    task: ``key``, the exported text but the goal, depends on the task alone.
    """
    from unified_planning.io import PDDLReader

    parsed = _PARSED_PROBLEMS.of(task, dict)
    cached = parsed.get(key)
    if not goal.conjunctive or task.negation_ids:  # kept simple: read the files, which hold the goal
        return PDDLReader().parse_problem(str(problem_file.with_name("domain.pddl")), str(problem_file))
    if cached is None:
        problem = PDDLReader().parse_problem(str(problem_file.with_name("domain.pddl")), str(problem_file))
        parsed.clear()
        parsed[key] = problem
        return problem.clone()
    problem = cached.clone()
    problem.clear_goals()
    fluents = {fluent.name.lower(): fluent for fluent in problem.fluents}
    objects = {obj.name.lower(): obj for obj in problem.all_objects}
    rename = keyword_safe_predicates({atom.predicate for atom in (*task.atoms, *goal.atoms)})
    for atom in goal.atoms:
        fluent = fluents[rename.get(atom.predicate, atom.predicate).lower()]
        problem.add_goal(fluent(*(objects[arg.lower()] for arg in atom.args)))
    return problem


__all__ = [
    "AUTO_DRIVER_ACTIONS",
    "COMPARE_TIME_LIMIT",
    "ENGINE",
    "ENGINES",
    "INSTALL_HINT",
    "OBTEA_DECIDED",
    "Engine",
    "FastDownwardRun",
    "FilesRun",
    "ObteaRun",
    "RunStatus",
    "choose_engine",
    "fast_downward_cost",
    "lifted_fast_downward_cost",
    "require_extra",
    "run_fast_downward",
    "run_fast_downward_files",
]
