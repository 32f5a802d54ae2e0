"""Grounding's reach stage: relaxed reachability from s0, when it is used.

When the static bound on ground actions exceeds the limit (:mod:`hbtp.domains.ground_estimate`),
:func:`reach` gets the :class:`~hbtp.domains.ground_instantiate.Grounder` made for reaching and
gives it the fluent facts reachable from s0, as Fast Downward's translator instantiates: the positive
fluent atoms of each precondition are joined with the fluent facts reached so far, round after
round; the grounder then builds only the actions so joined, within a work budget
(:func:`reaching_work`). With ``reachable_only``, :func:`keep_reachable` gets the ground actions and
gives those that can be applied from s0 when deletes are ignored
(:func:`~hbtp.domains.reachability.reachable_actions`).
"""

from __future__ import annotations

import logging
from collections.abc import Set

from hbtp.deadline import Deadline
from hbtp.domains.ground_compile import reaching_atoms, split_precondition
from hbtp.domains.ground_context import LOGGER, NEGATED, Key, Work
from hbtp.domains.ground_instantiate import Grounded, Grounder, changes
from hbtp.domains.lifted import ActionSchema
from hbtp.domains.reachability import reachable_actions

log = logging.getLogger(LOGGER)

#: With the fallback to relaxed reachability, the units of join work allowed per allowed action.
REACH_WORK = 100
#: ... counted for no fewer allowed actions than this.
REACH_FLOOR = 100_000


def reaching_work(limit: int, deadline: Deadline | None, estimate: str) -> Work:
    """The work meter of a grounding that falls back to what is reachable from s0: :data:`REACH_WORK`
    units of join work per allowed action, for at least :data:`REACH_FLOOR` of them (``estimate``,
    the static bound that was too large, is named in the error past them)."""
    return Work(
        deadline,
        REACH_WORK * max(limit, REACH_FLOOR),
        f"grounding would create {estimate}; grounding only what is reachable "
        f"from s0 took more than {REACH_WORK} units of work per allowed action",
    )


def reach(grounder: Grounder, initial: Set[Key], estimate: str) -> None:
    """Give ``grounder`` (made for reaching) the fluent facts that relaxed reachability from s0
    (``initial``) reaches, as Fast Downward's translator does: the positive fluent atoms of a
    precondition are joined with the facts reached so far, and their actions' adds are reached in
    turn, until nothing new is. Then :meth:`~hbtp.domains.ground_instantiate.Grounder.ground_all`
    builds the actions so joined, at most the limit of them."""
    log.info("static facts allow %s; grounding only the actions reachable from s0", estimate)
    joiner, actions = grounder.joiner, grounder.domain.actions
    joiner.reach(sorted(initial))
    known = set(initial)
    # A schema's bindings change only when a predicate it joins gained facts in the last round.
    joined = {schema.name: _joined_predicates(schema, grounder.compiler.fluent) for schema in actions}
    # A binding joined in an earlier round added its atoms then: its effects are not built again.
    taken: dict[str, set[tuple[str, ...]]] = {schema.name: set() for schema in actions}
    changed: set[str] | None = None  # None in the first round: every schema is joined
    rounds = 0
    while True:
        rounds += 1
        new: set[Key] = set()
        for schema in actions:
            if changed is None or joined[schema.name] & changed:
                _reach_schema(grounder, schema, known, new, taken[schema.name])
        if not new:
            break
        reached = sorted(new)
        known.update(reached)
        joiner.reach(reached)
        changed = {key[0] for key in new}
    grounder.kept = 0  # the actions are counted again as they are built
    log.debug(
        "relaxed reachability: %d fluent atoms in %d rounds, %d units of work left",
        len(known),
        rounds,
        grounder.work.budget,
    )


def _joined_predicates(schema: ActionSchema, fluent: set[str]) -> set[str]:
    """The fluent predicates whose facts a reaching join of ``schema`` ranges over."""
    _, fluent_parts = split_precondition(schema.precondition, fluent)
    return {part.predicate for part in reaching_atoms(fluent_parts)}


def _reach_schema(
    grounder: Grounder, schema: ActionSchema, known: set[Key], new: set[Key], taken: set[tuple[str, ...]]
) -> None:
    """Add to ``new`` what the ground actions of ``schema`` joined so far, but not ``taken`` in an
    earlier round, add beyond ``known``, counting them against the limit (those that change
    nothing are not counted); they join ``taken``."""
    for key, found in grounder.build(schema, warn=False, skip=taken):
        taken.add(key)
        changing = False
        for options, add, delete, _cost in found:
            changing = changing or any(any(changes(frozenset(pre), add, delete)) for pre in options)
            new.update(atom for atom in add if atom not in known)
        if changing:
            grounder.count_kept(schema, key)


def keep_reachable(grounded: list[Grounded], initial: Set[Key], work: Work, task_name: str) -> list[Grounded]:
    """The actions of ``grounded`` reachable from ``initial`` under the delete relaxation, in order."""
    found = len(grounded)
    # relaxed: a negative precondition is taken as reachable (deleting is never needed)
    relaxed = [(frozenset(k for k in pre if not k[0].startswith(NEGATED)), add) for _, pre, add, _, _ in grounded]

    def tick_atom() -> None:
        """A unit of the reachability fixpoint: a reached atom, which may wake many actions."""
        work.tick(64)

    kept = reachable_actions(initial, relaxed, tick_atom)
    grounded = [grounded[index] for index in kept]
    log.debug("%s: %d of %d ground actions are unreachable from s0", task_name, found - len(grounded), found)
    return grounded
