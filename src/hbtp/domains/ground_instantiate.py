"""Grounding's instantiate stage: the ground actions of each schema, within the grounding's scope.

Gets the :class:`~hbtp.domains.ground_context.Prepared` task and the grounding's
:class:`~hbtp.domains.ground_context.Scope`; compiles each schema (:mod:`hbtp.domains.ground_compile`),
joins its candidates (:mod:`hbtp.domains.ground_join`) and applies its effects to each. Gives, per
binding, its variants (:func:`~hbtp.domains.alternatives.variants`), and the ground actions ready to
assemble: a signature, a precondition, what it really adds and deletes, a cost. With ``only``, or
when only what is reachable from s0 is grounded, the actions kept are counted against the limit.
"""

from __future__ import annotations

import contextlib
import logging
from collections.abc import Container, Iterator

from hbtp.domains.alternatives import Effects, TooManyAlternatives, alternatives, variants
from hbtp.domains.ground_compile import Compiler, FixedCost, Op, UndefinedCost
from hbtp.domains.ground_context import LOGGER, Binding, Key, Prepared, Scope, Selection, Work
from hbtp.domains.ground_estimate import LIMIT_VARIABLE
from hbtp.domains.ground_join import Joiner
from hbtp.domains.lifted import MAX_ACTION_COST, ActionSchema
from hbtp.errors import GroundingError
from hbtp.logic.atoms import Atom, alternative_name
from hbtp.logic.task import listing

log = logging.getLogger(LOGGER)

#: A binding of an action as built: its arguments and its variants, each with its precondition's
#: alternatives (one unless the precondition has a disjunction over fluents), add, delete and cost.
Built = tuple[tuple[str, ...], list[tuple[tuple[tuple[Key, ...], ...], set[Key], set[Key], int]]]
#: A ground action ready to assemble: its signature, precondition, adds, deletes and cost.
Grounded = tuple[Atom, frozenset[Key], frozenset[Key], frozenset[Key], int]


class Grounder:
    """Builds the ground actions of one grounding, whose ``scope`` is fixed from the start.

    With ``reaching``, the positive fluent atoms of each precondition are joined with the fluent facts
    reached from s0 (which :func:`hbtp.domains.ground_reach.reach` gives the :attr:`joiner`), and the
    actions kept are counted against the limit, as they are with ``scope.only``.
    """

    def __init__(self, prepared: Prepared, scope: Scope, work: Work, reaching: bool = False) -> None:
        self.domain = prepared.domain
        self.uses_costs = prepared.uses_costs
        self.scope = scope
        self.work = work
        self.joiner = Joiner(prepared, work, scope.only, reaching)
        self.compiler = Compiler(prepared, self.joiner)
        self.counting = scope.only is not None or reaching
        self.kept = 0

    def ground_all(self) -> list[Grounded]:
        """The ground actions of every schema, sorted by signature."""
        grounded: list[Grounded] = []
        for schema in self.domain.actions:
            self.work.check_deadline()
            grounded.extend(self._ground_schema(schema))
        self.work.check_deadline()
        grounded.sort(key=lambda g: str(g[0]))
        return grounded

    def _ground_schema(self, schema: ActionSchema) -> Iterator[Grounded]:
        only = self.scope.only
        if isinstance(only, Selection) and schema.name not in only.predicates:
            return
        counting = self.counting
        names = self._alternative_names(schema)
        for key, found in self.build(schema):
            number = 0
            for options, add, delete, cost in found:
                for pre in options:
                    needs = frozenset(pre)
                    adds, deletes = changes(needs, add, delete)
                    if not adds and not deletes:
                        continue  # an action that changes nothing (Fast Downward drops it too)
                    if counting:
                        self.count_kept(schema, key)
                    name = names[number] if number < len(names) else alternative_name(schema.name, number)
                    number += 1
                    yield Atom(name, key), needs, adds, deletes, cost

    def _alternative_names(self, schema: ActionSchema) -> tuple[str, ...]:
        """The names of the schema's first ground actions per binding, checked against the declared
        action names (an alternative's name must not be one of them)."""
        declared = {a.name.lower() for a in self.domain.actions}
        names = tuple(alternative_name(schema.name, n) for n in range(8))
        for name in names[1:]:
            if name.lower() in declared:
                raise GroundingError(
                    f"action {schema.name!r}: its disjunctive precondition's alternatives are named "
                    f"{names[1]}, {names[2]}, ..., and the domain declares an action {name!r}"
                )
        return names

    def count_kept(self, schema: ActionSchema, key: tuple[str, ...]) -> None:
        """Count the ground action of ``schema`` over ``key`` as kept, refusing one past the limit."""
        self.kept += 1
        limit = self.scope.max_ground_actions
        if limit is not None and self.kept > limit:
            which = "selected actions" if self.joiner.reached is None else "actions reachable from s0"
            raise GroundingError(
                f"grounding the {which} would create more than the limit of {limit:,} "
                f"(max_ground_actions, or {LIMIT_VARIABLE} for the command line): "
                f"{Atom(schema.name, key)} is action {self.kept:,}"
            )

    def build(self, schema: ActionSchema, warn: bool = True, skip: Container[tuple[str, ...]] = ()) -> Iterator[Built]:
        """The ground actions of ``schema``, per binding: its arguments and its variants
        (:func:`~hbtp.domains.alternatives.variants`), each with its precondition's alternatives, add,
        delete and cost; those whose cost is undefined are left out with a warning. Bindings in
        ``skip`` are passed over."""
        with self._located(schema):
            compiled = self.compiler.compile(schema)
            dropped: list[str] = []
            for key, binding, pre in self.joiner.candidates(schema, compiled.static, compiled.fluent, skip):
                effects = self._effects(compiled.ops, binding, dropped)
                if effects is None:
                    continue
                found = [(pre, effects)] if not effects.cases else variants(pre, effects, schema.name)
                yield (
                    key,
                    [
                        (alternatives(v), done.add, done.delete, self._cost(schema, key, done.costs))
                        for v, done in found
                    ],
                )
            if warn:
                _warn_dropped(schema, dropped)

    def costs(self, schema: ActionSchema) -> Iterator[tuple[tuple[str, ...], int]]:
        """The bindings :meth:`build` gives, each with its cost when no conditional effect over fluents
        fires, without building effects (nor, when no fluent part of the precondition can rule a
        binding out, the fluent precondition): what listing the actions' names needs."""
        with self._located(schema):
            compiled = self.compiler.compile(schema)
            fluent = () if compiled.fluent_atoms_only else compiled.fluent
            amounts = [op.amount for op in compiled.cost_ops if isinstance(op, FixedCost)]
            fixed = self._cost(schema, (), amounts) if len(amounts) == len(compiled.cost_ops) else None  # all numbers
            dropped: list[str] = []
            for key, binding, _ in self.joiner.candidates(schema, compiled.static, fluent, ()):
                if fixed is not None:
                    yield key, fixed
                    continue
                effects = self._effects(compiled.cost_ops, binding, dropped)
                if effects is not None:
                    yield key, self._cost(schema, key, effects.costs)
            _warn_dropped(schema, dropped)

    @contextlib.contextmanager
    def _located(self, schema: ActionSchema) -> Iterator[None]:
        """Too many alternatives in ``schema``: a :class:`GroundingError` saying where it is."""
        try:
            yield
        except TooManyAlternatives as error:
            source = self.domain.source
            where = f"{source}:{schema.line}:{schema.column}" if schema.column else f"{source}:{schema.line}"
            raise GroundingError(f"{where}: {error}" if source and schema.line else str(error)) from None

    @staticmethod
    def _effects(ops: tuple[Op, ...], binding: Binding, dropped: list[str]) -> Effects | None:
        """What ``ops`` do under ``binding``; ``None`` (the cost noted in ``dropped``) when the cost is undefined."""
        effects = Effects()
        try:
            for op in ops:
                op(binding, effects)
        except UndefinedCost as undefined:
            dropped.append(undefined.args[0])
            return None
        return effects

    def _cost(self, schema: ActionSchema, key: tuple[str, ...], costs: list[int]) -> int:
        cost = sum(costs) if self.uses_costs else 1
        if cost > MAX_ACTION_COST:
            raise GroundingError(
                f"action {Atom(schema.name, key)} costs {cost}, more than the maximum {MAX_ACTION_COST}"
            )
        return cost


def _warn_dropped(schema: ActionSchema, dropped: list[str]) -> None:
    if dropped:
        # Fast Downward's translator only instantiates reachable actions, and fails on one whose cost
        # is undefined; hbtp grounds from static facts alone, so it drops them (elevators' slow lifts).
        log.warning(
            "action %r (line %d): %d ground action(s) dropped, their cost is not defined in :init (%s)",
            schema.name,
            schema.line,
            len(dropped),
            listing(dropped, 3),
        )


def changes(needs: frozenset[Key], add: set[Key], delete: set[Key]) -> tuple[frozenset[Key], frozenset[Key]]:
    """What a ground action really adds and deletes: adding what the precondition requires changes
    nothing, and what is both deleted and added stays (delete, then add)."""
    return frozenset(add) - needs, frozenset(delete - add)
