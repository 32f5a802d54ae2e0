"""A world pruned before it is grounded: the names of its actions now, a part of it on request.

Grounding a large world (RobotHow grown to 110,592 actions: most of the time of a plan) is what LLM
guidance cannot save when the full space is grounded first. A :class:`PrunedWorld` reads the
lifted model and lists the names of its ground actions (their static preconditions joined, their
effects not built: :func:`hbtp.domains.grounding.action_bindings`), which is all the prompt, the
reply's grammar and the grammar check need. :meth:`PrunedWorld.part` grounds only the pruned space
A⁻ = (Q⁻ × O⁻) ∩ A that the hints name, and :meth:`PrunedWorld.whole` grounds everything, once,
when the full-space fallback needs it.

A part is a scenario of its own: its actions are exactly the full world's actions of A⁻ (the same
preconditions, effects and costs; a ``forall`` still ranges over every object), its atoms those
they and s0 mention. Its mutexes are inferred on the part: proved for the states its own actions
reach from s0, which are the only ones a search in A⁻ visits, so pruning with them is as sound as
the full world's.

The vocabulary of a world not grounded differs from a grounded one's in one respect: the values
a condition predicate's argument takes are read off the lifted conditions and effects (a
parameter's values are those of its action's bindings; a ``forall`` variable's, the objects of its
type in the categories its guard requires), a superset of the atoms a grounding would make. Its
prompts can therefore name a wider category in a condition predicate than the grounded world's.

The self-placements a world leaves out (``ScenarioOptions.irreflexive``, see
:mod:`hbtp.domains.irreflexive`) are left out of its names when an unconditional effect makes them
(the shipped scenarios' Put and PutIn); one made by a ``forall`` or ``when`` effect is still named,
and left out when its part is grounded.
"""

from __future__ import annotations

import dataclasses
import itertools
import logging
import time
from collections.abc import Callable, Sequence
from dataclasses import dataclass, field
from pathlib import Path

from hbtp.collector import collector_paused
from hbtp.deadline import Deadline, check_deadline
from hbtp.domains.grounding import (
    ActionBindings,
    ActionFilter,
    Selection,
    action_bindings,
    fluent_predicates,
    objects_by_type,
    objects_of_categories,
)
from hbtp.domains.irreflexive import checked_irreflexive, names_self_placement
from hbtp.domains.lifted import (
    AddEffect,
    And,
    AndEffect,
    AtomFormula,
    DeleteEffect,
    Effect,
    Exists,
    Forall,
    ForallEffect,
    Formula,
    Imply,
    Not,
    Or,
    TypedName,
    WhenEffect,
    is_variable,
)
from hbtp.domains.scenarios import Pddl, Scenario, ScenarioOptions, load_pddl_scenario, read_pddl
from hbtp.logic.atoms import Atom
from hbtp.logic.names import ActionNames, names_of

log = logging.getLogger(__name__)

Slots = dict[str, list[set[str]]]


@dataclass
class GroundedWorld:
    """A world grounded whole from the start: every part of it is the scenario itself."""

    scenario: Scenario

    @property
    def name(self) -> str:
        return self.scenario.name

    @property
    def names(self) -> ActionNames:
        return names_of(self.scenario.task)

    @property
    def grounded(self) -> bool:
        return True

    def part(self, predicates: frozenset[str], objects: frozenset[str], deadline: Deadline | None = None) -> Scenario:
        """The whole scenario (the search restricts itself to A⁻)."""
        return self.scenario

    def whole(self, deadline: Deadline | None = None) -> Scenario:
        return self.scenario


@dataclass
class PrunedWorld:
    """A PDDL world known by its action names; grounded in parts, or whole when asked."""

    pddl: Pddl
    options: ScenarioOptions
    domain_file: Path
    problem_file: Path
    names: ActionNames
    name: str
    load_seconds: float = 0.0
    _whole: Scenario | None = field(default=None, repr=False)
    _parts: dict[tuple[frozenset[str], frozenset[str]], Scenario] = field(default_factory=dict, repr=False)

    @classmethod
    def load(
        cls,
        domain_file: str | Path,
        problem_file: str | Path,
        options: ScenarioOptions | None = None,
        *,
        parsed: Pddl | None = None,
        deadline: Deadline | None = None,
    ) -> PrunedWorld:
        """Read the files (or take ``parsed``) and list the names of the world's actions."""
        started = time.perf_counter()
        options = options or ScenarioOptions()
        with collector_paused():
            pddl = parsed or read_pddl(domain_file, problem_file, deadline)
            check_deadline(deadline, "reading the PDDL files")
            names = lifted_names(pddl, options, deadline)
        elapsed = time.perf_counter() - started
        name = options.name or pddl.problem.name
        log.info("listed %s: %d action names in %.3f s (not grounded)", name, len(names.actions), elapsed)
        return cls(pddl, options, Path(domain_file), Path(problem_file), names, name, elapsed)

    @property
    def grounded(self) -> bool:
        """Whether the whole world has been grounded (the fallback asked for it)."""
        return self._whole is not None

    def part(self, predicates: frozenset[str], objects: frozenset[str], deadline: Deadline | None = None) -> Scenario:
        """The scenario of A⁻ = (``predicates`` × ``objects``) ∩ A alone (kept: asked again, it is not rebuilt)."""
        key = (predicates, objects)
        if key not in self._parts:
            with collector_paused():
                self._parts[key] = self._ground_part(predicates, objects, deadline)
        return self._parts[key]

    def _ground_part(self, predicates: frozenset[str], objects: frozenset[str], deadline: Deadline | None) -> Scenario:
        return self._load(deadline, Selection(predicates, objects))

    def whole(self, deadline: Deadline | None = None) -> Scenario:
        """The whole world grounded (once)."""
        if self._whole is None:
            self._whole = self._load(deadline)
        return self._whole

    def _load(self, deadline: Deadline | None, only: ActionFilter | None = None) -> Scenario:
        options = dataclasses.replace(self.options, name=self.name)
        return load_pddl_scenario(
            self.domain_file, self.problem_file, options, parsed=self.pddl, deadline=deadline, only=only
        )


# ====================================================================== names
def lifted_names(pddl: Pddl, options: ScenarioOptions | None = None, deadline: Deadline | None = None) -> ActionNames:
    """The names of the ground actions of ``pddl`` and the vocabulary of their conditions, not grounded."""
    options = options or ScenarioOptions()
    domain, problem = pddl.domain, pddl.problem
    bindings = action_bindings(domain, problem, keep_fluent=options.keep_fluent, deadline=deadline)
    named = _named(bindings, _self_placing(pddl, options), pddl)
    fluent = frozenset(p for p in fluent_predicates(domain, frozenset(options.keep_fluent)) if p in domain.predicates)
    static_unary: dict[str, list[str]] = {}
    for fact in problem.init:
        if fact.predicate not in fluent and len(fact.terms) == 1:
            static_unary.setdefault(fact.predicate, []).append(fact.terms[0])
    categories = {p: tuple(sorted(set(m))) for p, m in sorted(static_unary.items())}
    objects, constants = tuple(o.name for o in problem.objects), tuple(c.name for c in domain.constants)
    if options.objects:
        objects, constants = objects_of_categories(objects, constants, categories, options.objects)
    slots = _condition_slots(pddl, bindings, fluent, categories)
    return ActionNames(
        actions=tuple(atom for atom, _ in named),
        costs=tuple(cost for _, cost in named),
        objects=objects,
        constants=constants,
        condition_slots={p: tuple(frozenset(s) for s in slots.get(p, ())) for p in sorted(fluent)},
        categories=categories,
    )


def _named(
    bindings: ActionBindings, left_out: dict[str, Callable[[Sequence[str]], bool]], pddl: Pddl
) -> list[tuple[Atom, int]]:
    """The actions of ``bindings`` not ``left_out``, with their costs, in the order of their names
    (``Walk(apple)``), as a grounding orders them.

    Each schema's bindings are sorted by their arguments. When no name has a character that sorts
    before the comma (PDDL names are letters, digits, ``-`` and ``_``), taking the schemas by name
    already orders the actions as their names do, the separators ``(``, ``,`` and ``)`` sorting
    before any character of a name; otherwise they are sorted by their names."""
    named = [
        (Atom(schema, args), cost)
        for schema, found in sorted(bindings.items())
        for args, cost in found
        if not (schema in left_out and left_out[schema](args))
    ]
    symbols = itertools.chain(bindings, (o.name for o in pddl.problem.objects), (c.name for c in pddl.domain.constants))
    if any(min(name, default="~") <= "," for name in symbols):
        named.sort(key=lambda item: str(item[0]))
    return named


def _self_placing(pddl: Pddl, options: ScenarioOptions) -> dict[str, Callable[[Sequence[str]], bool]]:
    """Per action schema, whether a ground action's arguments make it a self-placement the scenario
    leaves out (:func:`hbtp.domains.irreflexive.names_self_placement`); empty when none is."""
    arities = {name: len(parameters) for name, parameters in pddl.domain.predicates.items()}
    declared = checked_irreflexive(arities, options.irreflexive)
    if options.keep_self_placements or not declared:
        return {}
    return {schema.name: names_self_placement(schema, declared) for schema in pddl.domain.actions}


def _condition_slots(
    pddl: Pddl,
    bindings: dict[str, tuple[tuple[tuple[str, ...], int], ...]],
    fluent: frozenset[str],
    categories: dict[str, tuple[str, ...]],
) -> Slots:
    """The values each fluent predicate's arguments take in s0 and in the actions' conditions and effects."""
    slots: Slots = {}
    for fact in pddl.problem.init:
        if fact.predicate in fluent:
            _note(slots, fact.predicate, [{t} for t in fact.terms])
    types = objects_by_type(pddl.domain, (*pddl.domain.constants, *pddl.problem.objects))
    for schema in pddl.domain.actions:
        found = bindings.get(schema.name, ())
        if not found:
            continue
        values: dict[str, set[str]] = {p.name: set() for p in schema.parameters}
        for args, _ in found:
            for param, value in zip(schema.parameters, args, strict=True):
                values[param.name].add(value)
        walker = _SlotWalker(slots, fluent, categories, types, values)
        walker.formula(schema.precondition)
        walker.effect(schema.effect)
    return slots


def _note(slots: Slots, predicate: str, values: list[set[str]]) -> None:
    known = slots.setdefault(predicate, [set() for _ in values])
    for slot, new in zip(known, values, strict=True):
        slot |= new


@dataclass
class _SlotWalker:
    slots: Slots
    fluent: frozenset[str]
    categories: dict[str, tuple[str, ...]]
    types: dict[str, tuple[str, ...]]
    values: dict[str, set[str]]

    def atom(self, atom: AtomFormula) -> None:
        if atom.predicate in self.fluent:
            _note(
                self.slots, atom.predicate, [self.values.get(t, set()) if is_variable(t) else {t} for t in atom.terms]
            )

    def formula(self, formula: Formula) -> None:
        if isinstance(formula, AtomFormula):
            self.atom(formula)
        elif isinstance(formula, Not):
            self.formula(formula.operand)
        elif isinstance(formula, And | Or):
            for part in formula.parts:
                self.formula(part)
        elif isinstance(formula, Imply):
            self.formula(formula.antecedent)
            self.formula(formula.consequent)
        elif isinstance(formula, Exists | Forall):
            inner = dict(self.values)
            for variable in formula.variables:
                inner[variable.name] = self._range(variable, formula.body)
            dataclasses.replace(self, values=inner).formula(formula.body)

    def effect(self, effect: Effect) -> None:
        if isinstance(effect, ForallEffect):
            guard = effect.body.condition if isinstance(effect.body, WhenEffect) else And(())
            inner = dict(self.values)
            for variable in effect.variables:
                inner[variable.name] = self._range(variable, guard)
            dataclasses.replace(self, values=inner).effect(effect.body)
        elif isinstance(effect, WhenEffect):
            self.formula(effect.condition)
            self.effect(effect.body)
        elif isinstance(effect, AndEffect):
            for part in effect.parts:
                self.effect(part)
        elif isinstance(effect, AddEffect | DeleteEffect):
            self.atom(effect.atom)

    def _range(self, variable: TypedName, guard: Formula) -> set[str]:
        """The objects of the variable's type, in every category the guard requires of it."""
        found = {o for t in variable.types for o in self.types.get(t, ())}
        parts = guard.parts if isinstance(guard, And) else (guard,)
        for part in parts:
            if isinstance(part, AtomFormula) and part.terms == (variable.name,) and part.predicate in self.categories:
                found &= set(self.categories[part.predicate])
        return found


#: Where the HBTP loop plans: a grounded scenario, or a world it prunes before grounding.
World = GroundedWorld | PrunedWorld

__all__ = ["GroundedWorld", "PrunedWorld", "World", "lifted_names"]
