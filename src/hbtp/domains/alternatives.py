"""The alternatives of a ground action, so that every ground action is plain STRIPS.

Once static facts are evaluated, what is left of a binding's precondition is a conjunction of fluent
literals, or a :class:`Choice` of such conjunctions when a disjunction over fluents remains. What is
left of its effects is an :class:`Effects`: adds, deletes and costs that always happen, and the
:class:`Case`\\ s of the conditional effects whose ``when`` condition is over fluents.

hbtp's planners regress STRIPS actions, so these are compiled away as Fast Downward's translator
compiles disjunctions away (it keeps conditional effects; its LM-cut then refuses them):
:func:`variants` gives one ground action per combination of the cases' conditions holding or
failing, whose precondition is the action's conjoined with those conditions (or their negations)
and whose effects are the action's with the bodies of the cases that hold. Every condition is
evaluated in the state before the action, as PDDL's semantics say, so in any state exactly one
variant of an applicable action is applicable, and it changes the state as the action does.
Combinations whose precondition asks for an atom and its negation are left out, so a case whose
condition the precondition already decides gives one variant, not two; so is a case that only does
what the action does anyway. ``(when (p) (not (p)))`` (delete ``p`` if it holds, as airport's
takeoff and schedule's machines do for every segment or surface) is the plain delete of ``p``, and
``(when (not (p)) (p))`` the plain add of ``p`` when no other effect may delete it: these need no
variant at all.
"""

from __future__ import annotations

from collections.abc import Iterable, Sequence
from dataclasses import dataclass, field

from hbtp.errors import GroundingError
from hbtp.logic.atoms import NEGATION

#: An atom inside the grounder: (predicate, arguments); ``("~on", args)`` asks for ``(on ...)`` to be false.
Key = tuple[str, tuple[str, ...]]
#: The most alternatives one binding of an action may have (disjuncts, or combinations of cases).
MAX_ALTERNATIVES = 10_000


class Choice(tuple[tuple[Key, ...], ...]):
    """Two or more alternative conjunctions of fluent literals (a disjunctive precondition)."""


#: A condition once static facts are evaluated: decided, a conjunction, or a choice of conjunctions.
Value = bool | list[Key] | Choice


@dataclass(slots=True)
class Effects:
    """What a binding of an action does: always (``add``, ``delete``, ``costs``) and in ``cases``."""

    add: set[Key] = field(default_factory=set)
    delete: set[Key] = field(default_factory=set)
    costs: list[int] = field(default_factory=list)
    cases: list[Case] = field(default_factory=list)

    def absorb(self, other: Effects) -> None:
        """Do what ``other`` does too (its adds, deletes and costs; not its cases)."""
        self.add |= other.add
        self.delete |= other.delete
        self.costs += other.costs


@dataclass(frozen=True, slots=True)
class Case:
    """A conditional effect over fluents: its condition, the condition's negation and its body."""

    holds: list[Key] | Choice
    fails: list[Key] | Choice
    body: Effects


def alternatives(value: list[Key] | Choice) -> tuple[tuple[Key, ...], ...]:
    return value if isinstance(value, Choice) else (tuple(value),)


def choice(options: Iterable[tuple[Key, ...]], action: str) -> Value:
    """The ``options`` that can hold (no ``p`` with ``~p``), each once, without those that ask for
    more than another one does (their actions would be redundant)."""
    return _minimal([literals for literals in map(frozenset, options) if not _contradictory(literals)], action)


def _minimal(options: Sequence[frozenset[Key]], action: str) -> Value:
    """``options`` (each consistent) each once, without those that ask for more than another one does."""
    kept: list[frozenset[Key]] = []
    for literals in options:
        if literals not in kept:
            kept.append(literals)
    if not kept:
        return False
    minimal = [a for a in kept if not any(b < a for b in kept)]
    if len(minimal) > MAX_ALTERNATIVES:
        raise _too_many(action)
    if len(minimal) == 1:
        return sorted(minimal[0])
    return Choice(tuple(sorted(a)) for a in minimal)


def conjoined(values: Sequence[list[Key] | Choice], action: str) -> Value:
    """The conjunction of ``values``: a list when none is a choice, else the product of the choices."""
    if not any(isinstance(v, Choice) for v in values):
        return [key for value in values if isinstance(value, list) for key in value]
    combined: list[tuple[Key, ...]] = [()]
    for value in values:
        options = alternatives(value)
        if len(combined) * len(options) > MAX_ALTERNATIVES:
            raise _too_many(action)
        combined = [left + right for left in combined for right in options]
    return choice(combined, action)


def disjoined(values: Sequence[list[Key] | Choice], action: str) -> Value:
    """The disjunction of ``values`` (each a conjunction or a choice)."""
    if len(values) == 1:
        return values[0]
    return choice((a for value in values for a in alternatives(value)), action)


def add_case(effects: Effects, holds: Value, fails: Value, body: Effects, action: str) -> None:
    """Record ``(when condition body)`` in ``effects``, given the condition (``holds``) and its
    negation (``fails``) under the binding; the cases nested in ``body`` become cases of
    ``effects`` whose condition is conjoined with this one."""
    holds, fails = _consistent(holds, action), _consistent(fails, action)
    if holds is False or fails is True:
        return  # it never fires
    nested, body.cases = body.cases, []
    if holds is True or fails is False:  # it always fires
        effects.absorb(body)
        for case in nested:
            add_case(effects, case.holds, case.fails, case.body, action)
        return
    if body.add or body.delete or body.costs:
        effects.cases.append(Case(holds, fails, body))
    for case in nested:
        both = conjoined([holds, case.holds], action)
        add_case(effects, both, disjoined([fails, case.fails], action), case.body, action)


def variants(
    precondition: list[Key] | Choice, effects: Effects, action: str
) -> list[tuple[list[Key] | Choice, Effects]]:
    """Per combination of ``effects``' cases that can occur together with ``precondition``, the
    precondition conjoined with each case's condition or its negation, and the effects then (the
    cases that fail first, so with no case, or none that can hold, the action's own effects)."""
    start = _consistent(precondition, action)
    if isinstance(start, bool):
        return []  # the precondition asks for an atom and its negation
    found: list[tuple[list[Key] | Choice, tuple[Effects, ...]]] = [(start, ())]
    for case in _unconditional(effects):
        body = case.body
        if not body.costs and body.add <= effects.add and body.delete <= effects.delete:
            continue  # it does what the action does anyway
        extended: list[tuple[list[Key] | Choice, tuple[Effects, ...]]] = []
        for value, bodies in found:
            for condition, fired in ((case.fails, bodies), (case.holds, (*bodies, case.body))):
                both = _conjoined_consistent(value, condition, action)
                if not isinstance(both, bool):
                    extended.append((both, fired))
        if len(extended) > MAX_ALTERNATIVES:
            raise _too_many(action)
        found = extended
    return [(value, _merged(effects, bodies)) for value, bodies in found]


def _unconditional(effects: Effects) -> list[Case]:
    """``effects``' cases once the effects that need no condition are moved to ``effects`` itself:
    ``(when (p) (not (p)))`` deletes ``p`` whatever holds, and ``(when (not (p)) (p))`` adds it
    whatever holds unless another effect may delete it (then the add, which wins, would change what
    happens when ``p`` holds). Cases left with no effect are dropped."""
    deleted = effects.delete.union(*(case.body.delete for case in effects.cases))
    kept: list[Case] = []
    for case in effects.cases:
        body = case.body
        if isinstance(case.holds, list) and len(case.holds) == 1:
            ((predicate, args),) = case.holds
            if not predicate.startswith(NEGATION) and (predicate, args) in body.delete:
                effects.delete.add((predicate, args))
                body = Effects(body.add, body.delete - {(predicate, args)}, body.costs)
            elif predicate.startswith(NEGATION):
                plain = (predicate[len(NEGATION) :], args)
                if plain in body.add and plain not in deleted:
                    effects.add.add(plain)
                    body = Effects(body.add - {plain}, body.delete, body.costs)
            if not (body.add or body.delete or body.costs):
                continue
            case = Case(case.holds, case.fails, body)
        kept.append(case)
    return kept


def _merged(effects: Effects, bodies: tuple[Effects, ...]) -> Effects:
    if not bodies:
        return effects
    merged = Effects(set(effects.add), set(effects.delete), list(effects.costs))
    for body in bodies:
        merged.absorb(body)
    return merged


def _conjoined_consistent(value: list[Key] | Choice, condition: list[Key] | Choice, action: str) -> Value:
    """``value`` and ``condition`` (each consistent) conjoined, ``False`` when they contradict. When
    ``value`` is a conjunction (the usual case), only ``condition``'s literals can contradict it, so
    only they are looked up in it."""
    if not isinstance(value, list):
        return _consistent(conjoined([value, condition], action), action)
    present = set(value)
    if isinstance(condition, list):
        if any(_opposite(key) in present for key in condition):
            return False
        return value + [key for key in condition if key not in present]
    options = [
        frozenset((*value, *option)) for option in condition if not any(_opposite(key) in present for key in option)
    ]
    return _minimal(options, action)


def _contradictory(literals: frozenset[Key] | set[Key]) -> bool:
    """Whether ``literals`` ask for an atom and its negation (only a negative literal is looked up)."""
    for predicate, args in literals:
        if predicate.startswith(NEGATION) and (predicate[len(NEGATION) :], args) in literals:
            return True
    return False


def _opposite(key: Key) -> Key:
    predicate, args = key
    if predicate.startswith(NEGATION):
        return predicate[len(NEGATION) :], args
    return NEGATION + predicate, args


def _consistent(value: Value, action: str) -> Value:
    """``value`` without the conjunctions that ask for an atom and its negation (``False`` if none is left)."""
    if isinstance(value, list):
        return choice((tuple(value),), action)
    return value


class TooManyAlternatives(GroundingError):
    """One binding of an action has more than :data:`MAX_ALTERNATIVES` alternatives."""


def _too_many(action: str) -> GroundingError:
    return TooManyAlternatives(
        f"action {action!r}: its disjunctive precondition or conditional effects over fluents give more than "
        f"{MAX_ALTERNATIVES:,} alternatives for one binding"
    )
