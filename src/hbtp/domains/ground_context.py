"""What every stage of grounding (:mod:`hbtp.domains.grounding`) shares: the scope, the prepared task, the work.

Gets a lifted domain and problem and the :class:`Scope` of one grounding; gives the :class:`Prepared`
task (quantifiers expanded over the objects by :mod:`hbtp.domains.quantifiers`, the initial facts
split into static and fluent ones, the objects by type), the :class:`Work` meter that checks the
deadline (and spends the work budget when only what is reachable is grounded), and the types the
stages pass each other.
"""

from __future__ import annotations

from collections.abc import Callable, Iterable, Mapping
from dataclasses import dataclass

from hbtp.deadline import Deadline
from hbtp.domains.lifted import OBJECT_TYPE, Domain, Problem, TypedName, changed_predicates
from hbtp.domains.quantifiers import expand_domain
from hbtp.errors import GroundingError, InputError
from hbtp.logic.atoms import NEGATION

#: The logger of every stage: they log as the grounding they are part of (one logger to configure).
LOGGER = "hbtp.domains.grounding"

Binding = dict[str, str]
#: Which ground actions to build: called with the schema's name and the argument tuple.
ActionFilter = Callable[[str, tuple[str, ...]], bool]
# Inside the grounder an atom is the plain tuple (predicate, arguments): it hashes and sorts as Atom
# does, much faster; Atoms are made once per distinct atom when the task is assembled.
Key = tuple[str, tuple[str, ...]]
#: The mark of a negative fluent precondition's key: ``("~on", args)`` asks for ``(on ...)`` to be false.
NEGATED = NEGATION
Check = Callable[[Binding], bool]

PHASE = "grounding"
TICKS = 4096  # units of work between two deadline checks


@dataclass(frozen=True)
class Selection:
    """The ground actions of some schemas whose every argument is one of some objects: the pruned
    space (Q⁻ × O⁻) ∩ A as an :data:`ActionFilter` that the grounder also uses to skip the other
    schemas and to join only over the objects (so a small part of a large world grounds quickly)."""

    predicates: frozenset[str]
    objects: frozenset[str]

    def __call__(self, schema: str, args: tuple[str, ...]) -> bool:
        return schema in self.predicates and all(a in self.objects for a in args)


@dataclass(frozen=True)
class Scope:
    """What one grounding covers, fixed when it starts.

    ``keep_fluent`` names predicates that no action changes but that stay part of the state;
    ``reachable_only`` leaves out the actions that cannot be applied from s0 even when deletes are
    ignored; ``only``, when given, chooses the ground actions built (a :class:`Selection` also
    narrows the join); ``max_ground_actions`` bounds the actions kept when they are counted (with
    ``only``, or when only what is reachable from s0 is grounded; ``None``: no bound); past
    ``deadline``, grounding stops.
    """

    keep_fluent: frozenset[str] = frozenset()
    reachable_only: bool = False
    only: ActionFilter | None = None
    max_ground_actions: int | None = None
    deadline: Deadline | None = None


class Work:
    """The units of work a grounding does, counted: every :data:`TICKS` of them the deadline is
    checked and, when there is a ``budget`` (grounding only what is reachable from s0), spent;
    past the budget, a :class:`~hbtp.errors.GroundingError` saying ``over_budget``."""

    __slots__ = ("budget", "deadline", "over_budget", "ticks")

    def __init__(self, deadline: Deadline | None, budget: int | None = None, over_budget: str = "") -> None:
        self.deadline = deadline
        self.budget = budget
        self.over_budget = over_budget
        self.ticks = 0

    def tick(self, count: int = 1) -> None:
        """Count ``count`` units of work; every :data:`TICKS` units, check the deadline."""
        self.ticks += count
        if self.ticks >= TICKS:
            self.ticks = 0
            self.check_deadline()
            if self.budget is not None:
                self.budget -= TICKS
                if self.budget < 0:
                    raise GroundingError(self.over_budget)

    def check_deadline(self) -> None:
        if self.deadline is not None:
            self.deadline.check(PHASE)


class Prepared:
    """A domain and problem made ready to ground: the fluent predicates (those some action changes,
    with ``keep_fluent``), the objects by type, the domain with its quantifiers expanded, and the
    problem's initial facts split into the static ones (by predicate, in :init order) and s0."""

    def __init__(self, domain: Domain, problem: Problem, keep_fluent: frozenset[str]) -> None:
        self.problem = problem
        self.uses_costs = domain.uses_action_costs
        self.fluent = fluent_predicates(domain, keep_fluent)
        self.objects: tuple[TypedName, ...] = (*domain.constants, *problem.objects)
        self.by_type = objects_by_type(domain, self.objects)
        self.domain = expand_domain(domain, self.domain_of)  # exists/forall become or/and over the objects
        self.static_facts: set[Key] = set()
        self.static_index: dict[str, list[tuple[str, ...]]] = {}
        self.initial: set[Key] = set()
        for fact in problem.init:
            if fact.predicate in self.fluent:
                self.initial.add((fact.predicate, fact.terms))
            elif (fact.predicate, fact.terms) not in self.static_facts:
                self.static_facts.add((fact.predicate, fact.terms))
                self.static_index.setdefault(fact.predicate, []).append(fact.terms)

    def domain_of(self, typed: TypedName) -> tuple[str, ...]:
        """The objects a parameter or variable ranges over."""
        return typed_objects(self.by_type, typed)


def fluent_predicates(domain: Domain, keep_fluent: frozenset[str]) -> set[str]:
    """The predicates some action changes, with ``keep_fluent`` (checked to be predicates of ``domain``)."""
    unknown = sorted(keep_fluent - set(domain.predicates))
    if unknown:
        raise InputError(f"keep_fluent names unknown predicate(s): {', '.join(unknown)}")
    return changed_predicates(domain.actions) | keep_fluent


def objects_by_type(domain: Domain, objects: Iterable[TypedName]) -> dict[str, tuple[str, ...]]:
    """The names of ``objects`` of each type, subtypes included (every object is an ``object``)."""
    parents = domain.types
    table: dict[str, list[str]] = {OBJECT_TYPE: []}
    for obj in objects:
        for declared in obj.types:
            current: str | None = declared
            seen: set[str] = set()
            while current is not None and current not in seen:
                seen.add(current)
                table.setdefault(current, []).append(obj.name)
                current = parents.get(current, OBJECT_TYPE if current != OBJECT_TYPE else None)
    return {t: tuple(dict.fromkeys(names)) for t, names in table.items()}


def typed_objects(by_type: Mapping[str, tuple[str, ...]], typed: TypedName) -> tuple[str, ...]:
    """The objects a parameter or variable of ``typed``'s type(s) ranges over (``by_type`` as
    :func:`objects_by_type` gives it)."""
    if len(typed.types) == 1:
        return by_type.get(typed.types[0], ())
    return tuple(dict.fromkeys(o for t in typed.types for o in by_type.get(t, ())))
