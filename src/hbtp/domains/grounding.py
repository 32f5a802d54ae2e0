"""Compile a lifted PDDL domain and problem into a :class:`~hbtp.logic.GroundTask`.

Static predicates (no action changes them) are evaluated against the problem's initial facts and
disappear: guards such as ``(imply (hasplug ?y) (IsPlugged ?y))`` become plain STRIPS preconditions,
and ``(forall (?z) (when (not (= ?z ?x)) (not (IsNear self ?z))))`` becomes a list of delete effects.
A disjunction over fluents left in a precondition, or a ``when`` whose condition is over fluents,
gives a binding several ground actions (:mod:`hbtp.domains.alternatives`).

Bindings are enumerated by joining the static facts that an action's precondition requires (each
disjunct of its static part in turn), so an action over 126 objects never tries all pairs blindly.
Each join step looks its facts up in an index keyed by the arguments already bound; a ``forall``
effect's guard is joined once per distinct value of the outer variables it mentions.

With ``reachable_only``, only the actions reachable from s0 under the delete relaxation are kept
(:func:`~hbtp.domains.reachability.reachable_actions`), with the atoms s0 or they mention. With
``only``, only the ground actions it accepts are built (their effects computed), with the atoms s0
or they mention; :func:`action_bindings` lists the ground actions and their costs without effects.

Before enumerating, the number of ground actions of each schema is bounded from above (the join's
size: per static atom, at most its number of facts; per remaining parameter, the objects of its
type). When the bound exceeds ``max_ground_actions`` (by default ``$HBTP_MAX_GROUND_ACTIONS``, else
:data:`MAX_GROUND_ACTIONS`; a ground action takes about 1-2 KB of memory), only the actions reachable
from s0 are grounded (:func:`~hbtp.domains.ground_reach.reach`: the positive fluent atoms of each
precondition are joined with the fluent facts reached so far, round after round, as Fast Downward's
translator instantiates), and a task that still has more is refused with a one-line
:class:`~hbtp.errors.GroundingError` (with ``only``, the limit applies to the actions kept instead);
a ``deadline`` stops grounding with :class:`~hbtp.deadline.TimeLimitReached`.

This module is the entry point; the stages are modules of their own, as Fast Downward's translator's
are: :mod:`~hbtp.domains.ground_context` (the :class:`Scope` of a grounding, the prepared task, the
work meter), :mod:`~hbtp.domains.ground_estimate` (the static bound and the limit),
:mod:`~hbtp.domains.ground_join` (binding parameters), :mod:`~hbtp.domains.ground_compile` (schemas
into STRIPS), :mod:`~hbtp.domains.ground_instantiate` (the ground actions of each schema),
:mod:`~hbtp.domains.ground_reach` (relaxed reachability from s0, when used) and
:mod:`~hbtp.domains.ground_assemble` (the task of the ground actions).
"""

from __future__ import annotations

import dataclasses
import logging
from collections.abc import Iterable

from hbtp.deadline import Deadline, TimeLimitReached
from hbtp.domains.ground_assemble import assemble, objects_of_categories
from hbtp.domains.ground_compile import MAX_DNF_TERMS
from hbtp.domains.ground_context import (
    NEGATED,
    ActionFilter,
    Binding,
    Prepared,
    Scope,
    Selection,
    Work,
    fluent_predicates,
    objects_by_type,
    typed_objects,
)
from hbtp.domains.ground_estimate import LIMIT_VARIABLE, MAX_GROUND_ACTIONS, check_size, ground_actions_limit
from hbtp.domains.ground_instantiate import Grounder
from hbtp.domains.ground_reach import REACH_FLOOR, REACH_WORK, keep_reachable, reach, reaching_work
from hbtp.domains.lifted import Domain, Problem
from hbtp.errors import InputError
from hbtp.logic.task import GroundTask

__all__ = [
    "LIMIT_VARIABLE",
    "MAX_DNF_TERMS",
    "MAX_GROUND_ACTIONS",
    "NEGATED",
    "REACH_FLOOR",
    "REACH_WORK",
    "ActionBindings",
    "ActionFilter",
    "Binding",
    "Scope",
    "Selection",
    "action_bindings",
    "fluent_predicates",
    "ground",
    "ground_actions_limit",
    "objects_by_type",
    "objects_of_categories",
    "typed_objects",
]

#: The logger every stage of grounding logs to.
log = logging.getLogger(__name__)

#: Per action schema, the argument tuples of its ground actions with their costs (see :func:`action_bindings`).
ActionBindings = dict[str, tuple[tuple[tuple[str, ...], int], ...]]


def ground(
    domain: Domain,
    problem: Problem,
    *,
    keep_fluent: Iterable[str] = (),
    object_categories: Iterable[str] = (),
    name: str | None = None,
    max_ground_actions: int | None = None,
    deadline: Deadline | None = None,
    reachable_only: bool = False,
    only: ActionFilter | None = None,
) -> GroundTask:
    """Ground ``problem`` of ``domain``.

    ``keep_fluent`` names predicates that no action changes but that must stay part of the state
    (for example ``IsStanding``: a disturbance can make it false, so trees must test it).
    ``object_categories`` names the static categories whose members form the task's object set O
    (the objects an LLM reasons about); by default O is the problem's ``:objects``.
    A task whose estimated number of ground actions exceeds ``max_ground_actions`` (default:
    :func:`ground_actions_limit`) is refused (:class:`~hbtp.errors.GroundingError`); past ``deadline``,
    :class:`~hbtp.deadline.TimeLimitReached`. With ``reachable_only``, the actions that cannot be
    applied from s0 even when deletes are ignored are left out, with the atoms only they mention.
    With ``only``, only the ground actions whose schema name and arguments it accepts are built
    (exactly as in the full task, re-indexed), with the atoms s0 or they mention; the limit then
    applies to the number of actions kept, not to the estimate of all of them. A :class:`Selection`
    is also used to skip the schemas and objects it leaves out before joining.
    """
    if max_ground_actions is None:
        max_ground_actions = ground_actions_limit()
    if max_ground_actions < 1:
        raise InputError(f"max_ground_actions must be at least 1, not {max_ground_actions}")
    scope = Scope(frozenset(keep_fluent), reachable_only, only, max_ground_actions, deadline)
    stopped = ""
    try:
        task = _ground(domain, problem, scope, name or problem.name)
    except TimeLimitReached as stop:
        stopped = str(stop)
    if stopped:
        # Raised afresh, outside the handler: the first exception's traceback would keep the partial
        # grounding (hundreds of thousands of objects) alive while the caller reports the timeout.
        raise TimeLimitReached(stopped)
    categories = tuple(object_categories)
    if not categories:
        return task
    objects, constants = objects_of_categories(task.objects, task.constants, task.categories, categories)
    return dataclasses.replace(task, objects=objects, constants=constants)


def _ground(domain: Domain, problem: Problem, scope: Scope, task_name: str) -> GroundTask:
    """The stages in turn: prepare, estimate, reach (when the estimate is over the limit), then
    instantiate, keep what is reachable (with ``reachable_only``) and assemble."""
    prepared = Prepared(domain, problem, scope.keep_fluent)
    limit = scope.max_ground_actions
    refusal = None if scope.only is not None or limit is None else check_size(prepared, limit)
    if refusal is None:
        grounder = Grounder(prepared, scope, Work(scope.deadline))
    else:
        assert limit is not None
        grounder = Grounder(prepared, scope, reaching_work(limit, scope.deadline, refusal), reaching=True)
        reach(grounder, prepared.initial, refusal)
    grounded = grounder.ground_all()
    if scope.reachable_only:
        grounded = keep_reachable(grounded, prepared.initial, grounder.work, task_name)
    return assemble(prepared, task_name, grounded, grounder.work)


def action_bindings(
    domain: Domain,
    problem: Problem,
    *,
    keep_fluent: Iterable[str] = (),
    deadline: Deadline | None = None,
) -> ActionBindings:
    """Per action schema (in the domain's order), the sorted ``(arguments, cost)`` of its ground actions.

    These are exactly the actions :func:`ground` (without ``reachable_only``) builds: the static
    precondition holds, the fluent one is not false once statics are evaluated, the cost is defined.
    Add and delete effects are not computed, so this is much cheaper than grounding; no size limit
    applies. Past ``deadline``, :class:`~hbtp.deadline.TimeLimitReached`.
    """
    scope = Scope(frozenset(keep_fluent), deadline=deadline)
    grounder = Grounder(Prepared(domain, problem, scope.keep_fluent), scope, Work(deadline))
    found: ActionBindings = {}
    stopped = ""
    try:
        for schema in domain.actions:
            grounder.work.check_deadline()
            found[schema.name] = tuple(sorted(grounder.costs(schema)))
    except TimeLimitReached as stop:
        stopped = str(stop)
    if stopped:
        raise TimeLimitReached(stopped)
    return found
