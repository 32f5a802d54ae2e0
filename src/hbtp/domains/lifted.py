"""The lifted model of a PDDL domain and problem (the supported subset).

Supported: STRIPS with ``:typing``, ``:equality``, ``:action-costs``, ``:negative-preconditions``,
conditions with ``or``, ``not``, ``imply``, ``=``, ``exists`` and ``forall`` (over the finite objects),
and ``forall``/``when`` in effects where the ``when`` condition depends only on static facts. Static
parts, quantifiers and disjunctions are compiled away by :mod:`hbtp.domains.grounding`.

Nodes keep the ``line`` they were read from, for messages; it takes no part in equality, so a domain
read back from written text equals the original.
"""

from __future__ import annotations

from collections.abc import Iterable, Iterator
from dataclasses import dataclass, field

OBJECT_TYPE = "object"

#: The largest action cost accepted (an action's summed ``increase`` effects, a numeric fact used as a
#: cost). Costs stay exact as floats in the heuristics even when multiplied by HBTP-O's alpha (10^4)
#: and summed over long plans (2^53 is about 9 * 10^15).
MAX_ACTION_COST = 1_000_000


def is_variable(term: str) -> bool:
    return term.startswith("?")


@dataclass(frozen=True, slots=True)
class TypedName:
    """A parameter, object or constant with its type(s); ``types`` has several entries for ``either``."""

    name: str
    types: tuple[str, ...] = (OBJECT_TYPE,)


# ------------------------------------------------------------------ conditions
@dataclass(frozen=True, slots=True)
class AtomFormula:
    predicate: str
    terms: tuple[str, ...]
    line: int = field(default=0, compare=False)

    def __str__(self) -> str:
        return f"({' '.join((self.predicate, *self.terms))})"


@dataclass(frozen=True, slots=True)
class Equals:
    left: str
    right: str
    line: int = field(default=0, compare=False)


@dataclass(frozen=True, slots=True)
class Not:
    operand: Formula
    line: int = field(default=0, compare=False)


@dataclass(frozen=True, slots=True)
class And:
    parts: tuple[Formula, ...]
    line: int = field(default=0, compare=False)


@dataclass(frozen=True, slots=True)
class Or:
    parts: tuple[Formula, ...]
    line: int = field(default=0, compare=False)


@dataclass(frozen=True, slots=True)
class Imply:
    antecedent: Formula
    consequent: Formula
    line: int = field(default=0, compare=False)


@dataclass(frozen=True, slots=True)
class Exists:
    """``(exists (?v - type ...) body)``: the body holds for some objects of the variables' types."""

    variables: tuple[TypedName, ...]
    body: Formula
    line: int = field(default=0, compare=False)


@dataclass(frozen=True, slots=True)
class Forall:
    """``(forall (?v - type ...) body)``: the body holds for all objects of the variables' types."""

    variables: tuple[TypedName, ...]
    body: Formula
    line: int = field(default=0, compare=False)


Formula = AtomFormula | Equals | Not | And | Or | Imply | Exists | Forall
#: The quantified conditions.
Quantified = (Exists, Forall)


# --------------------------------------------------------------------- effects
@dataclass(frozen=True, slots=True)
class AddEffect:
    atom: AtomFormula


@dataclass(frozen=True, slots=True)
class DeleteEffect:
    atom: AtomFormula


@dataclass(frozen=True, slots=True)
class AndEffect:
    parts: tuple[Effect, ...]


@dataclass(frozen=True, slots=True)
class ForallEffect:
    variables: tuple[TypedName, ...]
    body: Effect
    line: int = field(default=0, compare=False)


@dataclass(frozen=True, slots=True)
class WhenEffect:
    condition: Formula
    body: Effect
    line: int = field(default=0, compare=False)
    column: int = field(default=0, compare=False)


@dataclass(frozen=True, slots=True)
class CostEffect:
    """``(increase (total-cost) N)`` or ``(increase (total-cost) (f ?x))`` with a static function f."""

    amount: int | AtomFormula
    line: int = field(default=0, compare=False)


Effect = AddEffect | DeleteEffect | AndEffect | ForallEffect | WhenEffect | CostEffect


# ------------------------------------------------------------ domain, problem
@dataclass(frozen=True)
class ActionSchema:
    name: str
    parameters: tuple[TypedName, ...]
    precondition: Formula
    effect: Effect
    line: int = field(default=0, compare=False)
    column: int = field(default=0, compare=False)  # of the action's opening parenthesis


@dataclass(frozen=True)
class Domain:
    name: str
    requirements: tuple[str, ...] = ()
    types: dict[str, str] = field(default_factory=dict)  # child -> parent
    constants: tuple[TypedName, ...] = ()
    predicates: dict[str, tuple[TypedName, ...]] = field(default_factory=dict)
    functions: dict[str, tuple[TypedName, ...]] = field(default_factory=dict)
    actions: tuple[ActionSchema, ...] = ()
    source: str = field(default="", compare=False)  # the file it was read from, for messages

    @property
    def uses_action_costs(self) -> bool:
        return ":action-costs" in self.requirements or "total-cost" in self.functions


@dataclass(frozen=True)
class Problem:
    name: str
    domain_name: str
    objects: tuple[TypedName, ...] = ()
    init: tuple[AtomFormula, ...] = ()
    numeric_init: dict[tuple[str, tuple[str, ...]], int] = field(default_factory=dict)
    goal: Formula = And(())
    minimize_cost: bool = False


def changed_predicates(actions: Iterable[ActionSchema]) -> set[str]:
    """The predicates some action adds or deletes (the fluents; the others are static)."""
    found: set[str] = set()
    for action in actions:
        for effect in _effects(action.effect):
            if isinstance(effect, AddEffect | DeleteEffect):
                found.add(effect.atom.predicate)
    return found


def _effects(effect: Effect) -> Iterator[Effect]:
    """``effect`` and every effect nested in it."""
    yield effect
    if isinstance(effect, AndEffect):
        for part in effect.parts:
            yield from _effects(part)
    elif isinstance(effect, ForallEffect | WhenEffect):
        yield from _effects(effect.body)
