"""Scenarios: a grounded task with its mutexes and metadata, from the shipped data or a user's PDDL.

The four published scenarios (``robowaiter``, ``virtualhome``, ``robothow-small``, ``robothow``) are
PDDL files inside the package, described by ``data/scenarios.toml``.
"""

from __future__ import annotations

import dataclasses
import functools
import logging
import time
import tomllib
from collections.abc import Iterable, Mapping, Sequence
from dataclasses import dataclass, field
from importlib import resources
from pathlib import Path
from typing import Any

from hbtp.collector import collector_paused
from hbtp.deadline import Deadline, check_deadline
from hbtp.domains import cache
from hbtp.domains.cache import cache_dir
from hbtp.domains.grounding import ActionFilter, ground, objects_by_type, typed_objects
from hbtp.domains.irreflexive import checked_irreflexive, without_self_placements
from hbtp.domains.lifted import (
    And,
    AtomFormula,
    Domain,
    Equals,
    Formula,
    Imply,
    Not,
    Or,
    Problem,
    is_variable,
)
from hbtp.domains.mutex import Mutexes, infer_mutexes, with_negation_groups
from hbtp.domains.pddl_reader import read_domain_file, read_problem_file
from hbtp.domains.quantifiers import expand_formula
from hbtp.errors import InputError
from hbtp.files import InputKind, read_text
from hbtp.logic.goals import GoalFormula
from hbtp.logic.negation import with_negations
from hbtp.logic.relevance import relevant_actions
from hbtp.logic.resolve import GoalSource, negations_needed
from hbtp.logic.tables import TaskTable
from hbtp.logic.task import Goal, GroundTask

log = logging.getLogger(__name__)

DATA = resources.files("hbtp.domains") / "data"


@dataclass(frozen=True)
class Pddl:
    """A parsed PDDL domain and problem."""

    domain: Domain
    problem: Problem


def _goal_text(formula: Formula, source: Path) -> str:
    """A PDDL goal formula without quantifiers, ``imply`` or ground equalities (see
    :func:`_equalities_evaluated`) as infix goal text (see :mod:`hbtp.logic.goals`)."""
    if isinstance(formula, AtomFormula):
        return f"{formula.predicate}({','.join(formula.terms)})"
    if isinstance(formula, Not):
        return f"~({_goal_text(formula.operand, source)})"
    if isinstance(formula, And | Or):
        joiner = " & " if isinstance(formula, And) else " | "
        text = joiner.join(_goal_text(part, source) for part in formula.parts)
        return text if len(formula.parts) == 1 else f"({text})"
    raise InputError(f"{source}:{formula.line or '?'}: the problem's :goal compares objects (=); give the goal with -g")


def _equalities_evaluated(formula: Formula) -> Formula | bool:
    """``formula`` with its equalities between objects evaluated and the constants folded away
    (``True``/``False`` when the whole formula is decided)."""
    if isinstance(formula, Equals):
        return (
            formula.left == formula.right if not (is_variable(formula.left) or is_variable(formula.right)) else formula
        )
    if isinstance(formula, Not):
        inner = _equalities_evaluated(formula.operand)
        return (not inner) if isinstance(inner, bool) else Not(inner, formula.line)
    if isinstance(formula, Imply):
        return _equalities_evaluated(Or((Not(formula.antecedent), formula.consequent), formula.line))
    if isinstance(formula, And | Or):
        absorbing = isinstance(formula, Or)  # True absorbs a disjunction, False a conjunction
        parts: list[Formula] = []
        for part in formula.parts:
            value = _equalities_evaluated(part)
            if value is absorbing:
                return absorbing
            if not isinstance(value, bool):
                parts.append(value)
        if not parts:
            return not absorbing
        return parts[0] if len(parts) == 1 else type(formula)(tuple(parts), formula.line)
    return formula


def read_pddl(domain_file: str | Path, problem_file: str | Path, deadline: Deadline | None = None) -> Pddl:
    """Parse a domain file and a problem file of that domain."""
    domain = read_domain_file(domain_file, deadline)
    return Pddl(domain, read_problem_file(problem_file, domain, deadline))


#: A scenario with negated twins, kept with the task it was made from (keyed by the new task).
_WITH_NEGATIONS: TaskTable[Scenario] = TaskTable("the scenario with negated twins")
#: A shipped scenario without its self-placements, kept with the paper's task it was made from.
_FOR_PLANS: TaskTable[Scenario] = TaskTable("the shipped scenario without its self-placements")


@dataclass(frozen=True)
class Scenario:
    """A planning scenario: the grounded task, its mutexes, and where it came from.

    ``parsed`` is the lifted domain and problem the task was grounded from; ``None`` for a scenario
    read from the disk cache, whose :attr:`pddl` reads its files again when first asked.
    ``left_out`` names the ground actions left out of ``task``: its self-placements
    (:meth:`without_self_placements`).
    """

    name: str
    title: str
    description: str
    task: GroundTask
    mutexes: Mutexes
    domain_file: Path
    problem_file: Path
    fewshot: str | None = None
    test_set: str | None = None
    load_seconds: float = 0.0
    parsed: Pddl | None = field(default=None, repr=False, compare=False)
    left_out: tuple[str, ...] = ()

    @functools.cached_property
    def pddl(self) -> Pddl:
        """The lifted domain and problem the task was grounded from."""
        return self.parsed if self.parsed is not None else read_pddl(self.domain_file, self.problem_file)

    def problem_goal(self) -> str:
        """The problem file's ``:goal`` as goal text (``P(a,b) & ~Q(c) | R(a)``): the default of
        ``hbtp plan``.

        Its ``exists``/``forall`` are expanded over the objects and its equalities evaluated. Raises
        :class:`InputError` when the problem has no goal (the shipped scenarios' problems hold a
        placeholder) or one that is then always or never true.
        """
        pddl = self.pddl  # read once: a scenario from the cache reads its files again for it
        goal = pddl.problem.goal
        if isinstance(goal, And) and not goal.parts:
            raise InputError(f"{self.problem_file}: the problem has no :goal to plan for; give one with -g")
        by_type = objects_by_type(pddl.domain, (*pddl.domain.constants, *pddl.problem.objects))
        objects_of = functools.partial(typed_objects, by_type)
        expanded = _equalities_evaluated(expand_formula(goal, objects_of, f"{self.problem_file}: the :goal"))
        if isinstance(expanded, bool):
            raise InputError(
                f"{self.problem_file}: the problem's :goal is {'always' if expanded else 'never'} true "
                "once its exists/forall and = are evaluated; give a goal with -g"
            )
        return _goal_text(expanded, self.problem_file)

    def resolve_goal(self, goal: GoalSource) -> tuple[Scenario, Goal]:
        """The goal resolved, with the scenario to plan it in: this one, or this one with the negated
        twins its negative literals need (:func:`hbtp.logic.negation.with_negations`). Goal text is
        read once (:class:`~hbtp.logic.goals.GoalFormula`)."""
        if isinstance(goal, Goal) and goal.resolved_in(self.task):
            return self, goal
        formula = GoalFormula.parse(goal) if isinstance(goal, str) else goal
        needed = negations_needed(self.task, formula)
        scenario = self.with_negations(needed) if needed else self
        return scenario, scenario.task.resolve_goal(formula)

    def with_negations(self, atom_ids: Iterable[int]) -> Scenario:
        """This scenario with negated twins for ``atom_ids`` (kept: asking again gives the same object)."""
        task = with_negations(self.task, atom_ids)
        if task is self.task:
            return self
        return _WITH_NEGATIONS.of(
            self.task,
            lambda: dataclasses.replace(self, task=task, mutexes=with_negation_groups(self.mutexes, task)),
            key=task,
        )

    def for_goal(self, goal: Goal) -> Scenario:
        """The scenario a search of ``goal`` needs: only the ground actions relevant to it (the
        achievers of its literals, then of their preconditions', and so on: the operators Fast
        Downward's translator keeps for a problem's goal), the same atoms, s0 and mutexes (proved for
        the states every action reaches, so they hold where fewer act). A backward search of ``goal``
        only ever regresses through these actions: its tree and cost are the same in both."""
        task = self.task.keeping(relevant_actions(self.task, goal))
        if task is self.task:
            return self
        return dataclasses.replace(self, task=task)

    def without_self_placements(self, irreflexive: Iterable[str]) -> Scenario:
        """This scenario without the ground actions that add ``P(x,x)`` for an ``irreflexive``
        predicate ``P`` (:mod:`hbtp.domains.irreflexive`; ``RightPut(chair,chair)``): the same atoms,
        s0 and mutexes (proved for the states every action reaches, so they hold where fewer act);
        this scenario itself when it has none."""
        task, left_out = without_self_placements(self.task, irreflexive)
        if task is self.task:
            return self
        log.info("%s: %d self-placement(s) left out, such as %s", self.name, len(left_out), left_out[0])
        return dataclasses.replace(self, task=task, left_out=(*self.left_out, *left_out))

    def summary(self) -> dict[str, Any]:
        """The figures ``hbtp scenarios`` prints."""
        return {
            "name": self.name,
            "title": self.title,
            "actions": len(self.task.actions),
            "action_predicates": len(self.task.action_predicates),
            "objects": len(self.task.objects),
            "s0": len(self.task.initial_state),
            "atoms": len(self.task.atoms),
            "mutex_groups": len(self.mutexes.groups),
            "declared_nogoods": len(self.mutexes.nogoods),
            "left_out": len(self.left_out),
        }


@functools.cache
def _manifest() -> dict[str, dict[str, Any]]:
    with (DATA / "scenarios.toml").open("rb") as handle:
        return tomllib.load(handle)


def manifest_entry(name: str) -> dict[str, Any]:
    """A shipped scenario's entry in ``scenarios.toml``."""
    if name not in _manifest():
        raise InputError(f"unknown scenario {name!r}; choose one of: {', '.join(scenario_names())}")
    return dict(_manifest()[name])


def scenario_names() -> tuple[str, ...]:
    """Names of the shipped scenarios, in the paper's order."""
    return tuple(_manifest())


def load_scenario(name: str, *, keep_self_placements: bool = False) -> Scenario:
    """Load (parse, ground, infer mutexes) a shipped scenario; cached per process and on disk
    (see :func:`cache_dir`; the cache is keyed by the data files' content and the hbtp version).

    Its self-placements (actions that add ``P(x,x)`` for a predicate its ``scenarios.toml`` entry
    declares ``irreflexive``, see :mod:`hbtp.domains.irreflexive`) are left out, unless
    ``keep_self_placements``: the paper's action space, which the benchmarks reproduce.
    """
    if name not in _manifest():
        raise InputError(f"unknown scenario {name!r}; choose one of: {', '.join(scenario_names())}")
    paper = _load_shipped(name)
    if keep_self_placements:
        return paper
    declared = ScenarioOptions.shipped(name).irreflexive
    return _FOR_PLANS.of(paper.task, lambda: paper.without_self_placements(declared))


def forget_shipped() -> None:
    """Free the shipped scenarios this process keeps loaded (a later :func:`load_scenario` reads
    them from the disk cache again)."""
    _load_shipped.cache_clear()


@dataclass(frozen=True)
class ScenarioOptions:
    """How PDDL files become a scenario: its name (default: the problem's), title and description,
    the grounding options (``keep_fluent``, the static categories ``objects`` that form O,
    ``max_ground_actions``: see :func:`hbtp.domains.grounding.ground`), declared mutexes, and the
    shipped few-shot and test datasets.

    ``irreflexive`` names predicates that never hold between an object and itself (``IsOn``,
    ``IsIn``): the ground actions that add such an atom ``P(x,x)`` are left out of the scenario
    (:meth:`Scenario.without_self_placements`) unless ``keep_self_placements``, which the paper's
    benchmarks set to keep the paper's action lists."""

    name: str | None = None
    title: str | None = None
    description: str = ""
    keep_fluent: Sequence[str] = ()
    objects: Sequence[str] = ()
    mutex_groups: Sequence[Sequence[str]] = ()
    mutex_nogoods: Sequence[Sequence[str]] = ()
    fewshot: str | None = None
    test_set: str | None = None
    max_ground_actions: int | None = None
    #: Keep only the actions reachable from s0 under the delete relaxation (as Fast Downward's
    #: translator does). Off for the shipped scenarios: the paper's action lists (RobotHow's 7,329)
    #: include a few unreachable actions (``PlugOut(keyboard)``, ``PlugOut(mouse)``).
    reachable_only: bool = True
    irreflexive: Sequence[str] = ()
    keep_self_placements: bool = False

    @classmethod
    def shipped(cls, name: str, *, keep_self_placements: bool = False) -> ScenarioOptions:
        """The options of the shipped scenario ``name``, from ``scenarios.toml``."""
        entry = manifest_entry(name)
        mutex = entry.get("mutex", {})
        return cls(
            name=name,
            title=entry.get("title", name),
            description=entry.get("description", ""),
            keep_fluent=entry.get("keep_fluent", ()),
            objects=entry.get("objects", ()),
            mutex_groups=mutex.get("groups", ()),
            mutex_nogoods=mutex.get("nogoods", ()),
            fewshot=entry.get("fewshot"),
            test_set=entry.get("test"),
            reachable_only=False,
            irreflexive=entry.get("irreflexive", ()),
            keep_self_placements=keep_self_placements,
        )


#: Shipped scenarios kept loaded in this process (all four: each is loaded once per process, and a
#: command or a benchmark worker asks for the same ones again and again). :func:`forget_shipped`
#: frees them.
SHIPPED_KEPT = 4


@functools.lru_cache(maxsize=SHIPPED_KEPT)
def _load_shipped(name: str) -> Scenario:
    entry = _manifest()[name]
    with resources.as_file(DATA) as folder:
        domain_file, problem_file = folder / entry["domain"], folder / entry["problem"]
        location = _cache_entry(name, folder, entry)
        if location is not None:
            started = time.perf_counter()
            cached = cache.read_cached(location)
            if cached is not None:
                return Scenario(
                    name=name,
                    title=cached.title,
                    description=cached.description,
                    task=cached.task,
                    mutexes=cached.mutexes,
                    domain_file=domain_file,
                    problem_file=problem_file,
                    fewshot=cached.fewshot,
                    test_set=cached.test_set,
                    load_seconds=time.perf_counter() - started,
                )
        scenario = load_pddl_scenario(
            domain_file, problem_file, ScenarioOptions.shipped(name, keep_self_placements=True)
        )
        if location is not None:
            cache.write_cached(
                location,
                cache.CachedScenario(
                    scenario.task,
                    scenario.mutexes,
                    scenario.title,
                    scenario.description,
                    scenario.fewshot,
                    scenario.test_set,
                ),
            )
        return scenario


# ----------------------------------------------------------------- disk cache (see hbtp.domains.cache)
def _cache_entry(name: str, folder: Path, entry: dict[str, Any]) -> cache.CacheEntry | None:
    """Where the shipped scenario ``name`` is cached, keyed by everything it is built from."""
    if cache_dir() is None:
        return None
    files = [folder / entry["domain"], folder / entry["problem"], folder / "scenarios.toml"]
    return cache.cache_entry(name, cache.scenario_key(name, entry, files))


def load_pddl_scenario(
    domain_file: str | Path,
    problem_file: str | Path,
    options: ScenarioOptions = ScenarioOptions(),
    *,
    parsed: Pddl | None = None,
    deadline: Deadline | None = None,
    only: ActionFilter | None = None,
) -> Scenario:
    """Load a scenario from a user's PDDL domain and problem files (``parsed``, when given, is their
    content already read, or changed: e.g. a generated larger problem). With ``only``, the scenario
    has only the ground actions it accepts (see :func:`hbtp.domains.grounding.ground`).

    Grounding is bounded by ``options.max_ground_actions`` (default ``$HBTP_MAX_GROUND_ACTIONS`` or
    1,000,000); past ``deadline``, :class:`~hbtp.deadline.TimeLimitReached` names the phase that was running.
    """
    started = time.perf_counter()
    domain_path, problem_path = Path(domain_file), Path(problem_file)
    # Reading and grounding build hundreds of thousands of small acyclic objects; the cyclic
    # collector's repeated full passes over them would take more than half of the time.
    with collector_paused():
        parsed = parsed or read_pddl(domain_path, problem_path, deadline)
        check_deadline(deadline, "reading the PDDL files")
        task = ground(
            parsed.domain,
            parsed.problem,
            keep_fluent=options.keep_fluent,
            object_categories=options.objects,
            name=options.name or parsed.problem.name,
            max_ground_actions=options.max_ground_actions,
            deadline=deadline,
            reachable_only=options.reachable_only,
            only=only,
        )
        check_deadline(deadline, "grounding")
        mutexes = infer_mutexes(task, options.mutex_groups, options.mutex_nogoods, deadline)
    elapsed = time.perf_counter() - started
    log.info("loaded %s: %d actions in %.3f s", task.name, len(task.actions), elapsed)
    scenario = Scenario(
        name=task.name,
        title=options.title or task.name,
        description=options.description,
        task=task,
        mutexes=mutexes,
        domain_file=domain_path,
        problem_file=problem_path,
        fewshot=options.fewshot,
        test_set=options.test_set,
        load_seconds=elapsed,
        parsed=parsed,
    )
    if options.keep_self_placements:
        checked_irreflexive({**task.static_arities, **task.predicates}, options.irreflexive)
        return scenario
    return scenario.without_self_placements(options.irreflexive)


def read_mutex_file(path: str | Path) -> Mapping[str, Sequence[Sequence[str]]]:
    """Read declared mutexes (``groups = [[...]]``, ``nogoods = [[...]]``) from a TOML file."""
    path = Path(path)
    try:
        data = tomllib.loads(read_text(path, InputKind.SETTINGS))
    except tomllib.TOMLDecodeError as error:
        raise InputError(f"{path}: not valid TOML: {error}") from None
    unknown = set(data) - {"groups", "nogoods"}
    if unknown:
        raise InputError(f"{path}: unknown key(s) {', '.join(sorted(unknown))} (expected groups, nogoods)")
    declared: dict[str, Sequence[Sequence[str]]] = {}
    for key in ("groups", "nogoods"):
        value = data.get(key, [])
        if not isinstance(value, list) or not all(
            isinstance(spec, list) and all(isinstance(atom, str) for atom in spec) for spec in value
        ):
            example = '[["IsOpen(?x)", "IsClose(?x)"]]'
            raise InputError(f"{path}: {key} must be a list of lists of atoms such as {example}, not {value!r:.60}")
        declared[key] = value
    return declared
