"""Grounding's assemble stage: the :class:`~hbtp.logic.GroundTask` of the ground actions.

Gets the :class:`~hbtp.domains.ground_context.Prepared` task and its ground actions (as
:mod:`hbtp.domains.ground_instantiate` gives them, over atoms as plain tuples); gives the task over
interned atoms: the atoms the actions or s0 mention, sorted, then the negated twins the negative
preconditions need, and the actions over them. :func:`objects_of_categories` then chooses the
task's object set O.
"""

from __future__ import annotations

import logging
from collections.abc import Mapping, Sequence

from hbtp.domains.ground_context import LOGGER, NEGATED, Key, Prepared, Work
from hbtp.domains.ground_instantiate import Grounded
from hbtp.errors import InputError
from hbtp.logic.atoms import Atom
from hbtp.logic.negation import with_twin_effects
from hbtp.logic.task import GroundAction, GroundTask

log = logging.getLogger(LOGGER)


def assemble(prepared: Prepared, task_name: str, grounded: list[Grounded], work: Work) -> GroundTask:
    """The task of the ``grounded`` actions: their atoms and s0's, sorted, and the actions over
    them; a negative precondition ``(not (p ...))`` becomes the twin ``~p`` of
    :mod:`hbtp.logic.negation`, appended after the atoms and kept exact by the actions."""
    work.check_deadline()
    all_atoms: set[Key] = set(prepared.initial)
    negated: set[Key] = set()
    for _, pre, add, delete, _ in grounded:
        for key in pre:
            if key[0].startswith(NEGATED):
                negated.add((key[0][len(NEGATED) :], key[1]))
            else:
                all_atoms.add(key)
        all_atoms.update(add, delete)
    all_atoms |= negated
    keys = sorted(all_atoms)  # the order of Atom (predicate, then arguments)
    ids = {key: i for i, key in enumerate(keys)}
    twins = {(NEGATED + p, args): len(keys) + n for n, (p, args) in enumerate(sorted(negated))}
    twin_of = {ids[(p[len(NEGATED) :], args)]: twin for (p, args), twin in twins.items()}
    get = {**ids, **twins}.__getitem__
    actions: list[GroundAction] = []
    for index, (signature, pre, add, delete, cost) in enumerate(grounded):
        work.tick()
        action = GroundAction(
            index, signature, frozenset(map(get, pre)), frozenset(map(ids.__getitem__, add)),
            frozenset(map(ids.__getitem__, delete)), cost,
        )  # fmt: skip
        actions.append(with_twin_effects(action, twin_of) if twin_of else action)
    log.debug("grounded %s: %d actions, %d atoms", task_name, len(actions), len(keys) + len(twins))
    initial = {ids[a] for a in prepared.initial}
    initial |= {twin for atom, twin in twin_of.items() if atom not in initial}
    domain, fluent = prepared.domain, prepared.fluent
    return GroundTask(
        name=task_name,
        atoms=(
            *(Atom(predicate, args) for predicate, args in keys),
            *(Atom(p, args, True) for p, args in sorted(negated)),
        ),
        actions=tuple(actions),
        initial_state=frozenset(initial),
        objects=tuple(o.name for o in prepared.problem.objects),
        constants=tuple(c.name for c in domain.constants),
        predicates={p: len(args) for p, args in domain.predicates.items() if p in fluent},
        static_facts=frozenset(Atom(p, args) for p, args in prepared.static_facts),
        static_predicates={p: len(args) for p, args in domain.predicates.items() if p not in fluent},
    )


def objects_of_categories(
    objects: Sequence[str], constants: Sequence[str], members: Mapping[str, Sequence[str]], chosen: Sequence[str]
) -> tuple[tuple[str, ...], tuple[str, ...]]:
    """O = the members of the ``chosen`` static categories (``members``: category -> objects); every
    other object or constant becomes a constant. Both sorted."""
    unknown = [c for c in chosen if c not in members]
    if unknown:
        raise InputError(f"object category {unknown[0]!r} is not a unary static predicate with members")
    kept = tuple(sorted({o for c in chosen for o in members[c]}))
    everything = dict.fromkeys((*constants, *objects))
    return kept, tuple(sorted(s for s in everything if s not in set(kept)))
