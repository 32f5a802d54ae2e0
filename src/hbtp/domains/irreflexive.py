"""Self-placements: ground actions that put an object on or in itself, derived from declared data.

A domain's data may declare predicates *irreflexive*: relations that never hold between an object
and itself. The shipped scenarios declare their placement relations in ``data/scenarios.toml``
(``IsOn`` and ``IsIn`` in VirtualHome and RobotHow, ``On`` in RoboWaiter); ``--irreflexive PRED``
(:class:`~hbtp.domains.scenarios.ScenarioOptions` ``irreflexive``) declares one for a user's PDDL.
A ground action whose add effects include ``P(x,x)`` for an irreflexive ``P`` is a
*self-placement*: RobotHow's ``LeftPut(chair,chair)``, where a chair is both grabbable and a surface.

The paper's action lists hold such actions, so the benchmarks keep them; a scenario loaded for a
user's plans leaves them out (:meth:`hbtp.domains.scenarios.Scenario.without_self_placements`). No
predicate or action is named here: which relations are irreflexive is the domain's data.
"""

from __future__ import annotations

from collections.abc import Callable, Iterable, Iterator, Mapping, Sequence

from hbtp.domains.lifted import ActionSchema, AddEffect, AndEffect, Effect
from hbtp.errors import InputError
from hbtp.logic.atoms import Atom
from hbtp.logic.suggest import did_you_mean
from hbtp.logic.task import GroundAction, GroundTask

__all__ = [
    "checked_irreflexive",
    "names_self_placement",
    "self_placements",
    "without_self_placements",
]


def checked_irreflexive(arities: Mapping[str, int], predicates: Iterable[str]) -> frozenset[str]:
    """``predicates``, each checked to be a predicate of ``arities`` (name -> arity) that relates two
    objects (:class:`InputError` otherwise)."""
    declared = frozenset(predicates)
    for name in sorted(declared):
        if name not in arities:
            hint = did_you_mean(name, arities)
            raise InputError(f"irreflexive names an unknown predicate {name!r}{hint}")
        if arities[name] != 2:
            raise InputError(
                f"irreflexive predicate {name!r} has {arities[name]} argument(s): only a relation between "
                "two objects can be irreflexive"
            )
    return declared


def _relates_itself(atom: Atom, irreflexive: frozenset[str]) -> bool:
    return not atom.negated and atom.predicate in irreflexive and len(atom.args) == 2 and atom.args[0] == atom.args[1]


def self_placements(task: GroundTask, irreflexive: Iterable[str]) -> tuple[GroundAction, ...]:
    """The actions of ``task`` (in task order) whose add effects include ``P(x,x)`` for a predicate
    ``P`` of ``irreflexive`` (checked against the task's predicates)."""
    declared = checked_irreflexive({**task.static_arities, **task.predicates}, irreflexive)
    if not declared:
        return ()
    impossible = frozenset(i for i, atom in enumerate(task.atoms) if _relates_itself(atom, declared))
    return tuple(action for action in task.actions if action.add & impossible)


def without_self_placements(task: GroundTask, irreflexive: Iterable[str]) -> tuple[GroundTask, tuple[str, ...]]:
    """``task`` without its self-placements (:meth:`GroundTask.keeping`: the same atoms and s0, the
    other actions unchanged), and the names of the actions left out; ``task`` itself when none is."""
    found = self_placements(task, irreflexive)
    if not found:
        return task, ()
    dropped = frozenset(action.index for action in found)
    kept = (i for i in range(len(task.actions)) if i not in dropped)
    return task.keeping(kept), tuple(action.name for action in found)


def _unconditional_adds(effect: Effect) -> Iterator[AddEffect]:
    """The add effects of ``effect`` outside any ``forall`` or ``when``."""
    if isinstance(effect, AndEffect):
        for part in effect.parts:
            yield from _unconditional_adds(part)
    elif isinstance(effect, AddEffect):
        yield effect


def names_self_placement(schema: ActionSchema, irreflexive: frozenset[str]) -> Callable[[Sequence[str]], bool]:
    """Whether the ground action of ``schema`` with the given arguments adds ``P(x,x)`` for an
    irreflexive ``P`` through an unconditional effect, told from the lifted model without grounding.

    Exact for unconditional effects. An add inside a ``forall`` or ``when`` is decided only when the
    action is grounded, so such a name is not flagged here (a listing of names may then hold a
    self-placement that the grounded task leaves out).
    """
    pairs = tuple(
        effect.atom.terms
        for effect in _unconditional_adds(schema.effect)
        if effect.atom.predicate in irreflexive and len(effect.atom.terms) == 2
    )
    parameters = tuple(parameter.name for parameter in schema.parameters)

    def flagged(args: Sequence[str]) -> bool:
        if not pairs:
            return False
        values = dict(zip(parameters, args, strict=True))
        return any(values.get(first, first) == values.get(second, second) for first, second in pairs)

    return flagged
