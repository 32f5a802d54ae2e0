"""The scenario's vocabulary as the prompt shows it, derived from the grounded task.

Condition predicates with argument categories (``IsOn_<GRABBABLE>_<SURFACE>``), action predicates
with categories and costs (``Walk_<ALL_OBJECTS> (15)``), and the categories' members. A category is
the smallest static unary predicate that covers every value an argument takes; a single value
(``self``) is written as is.
"""

from __future__ import annotations

from dataclasses import dataclass

from hbtp.logic.task import GroundTask

ANY = "ANY"


@dataclass(frozen=True)
class Vocabulary:
    condition_predicates: tuple[str, ...]  # "IsOn_<GRABBABLE>_<SURFACE>"
    action_predicates: tuple[str, ...]  # "Walk_<ALL_OBJECTS> (15)"
    categories: tuple[tuple[str, tuple[str, ...]], ...]  # ("GRABBABLE", ("apple", ...))
    action_names: frozenset[str]  # "Walk_apple"
    predicate_names: frozenset[str]  # action predicates: "Walk"
    object_names: frozenset[str]  # objects and constants


def _describe(values: set[str], categories: dict[str, tuple[str, ...]], used: dict[str, tuple[str, ...]]) -> str:
    if len(values) == 1:
        return next(iter(values))
    best: tuple[int, str] | None = None
    for name, members in categories.items():
        if values <= set(members) and (best is None or (len(members), name) < best):
            best = (len(members), name)
    if best is None:
        return f"<{ANY}>"
    label = best[1].upper()
    used[label] = categories[best[1]]
    return f"<{label}>"


def vocabulary_of(task: GroundTask) -> Vocabulary:
    """The prompt vocabulary of ``task`` (built once, kept with the task)."""
    return task.derived(vocabulary_of, lambda: _vocabulary(task))


def _vocabulary(task: GroundTask) -> Vocabulary:
    categories = task.categories
    used: dict[str, tuple[str, ...]] = {}
    positions: dict[str, list[set[str]]] = {}
    for atom in task.atoms:
        slots = positions.setdefault(atom.predicate, [set() for _ in atom.args])
        for slot, value in zip(slots, atom.args, strict=True):
            slot.add(value)
    conditions = []
    for predicate in sorted(task.predicates):
        slots = positions.get(predicate, [])
        parts = [_describe(values, categories, used) for values in slots if values]
        conditions.append("_".join([predicate, *parts]))
    action_slots: dict[str, list[set[str]]] = {}
    costs: dict[str, set[int]] = {}
    for action in task.actions:
        slots = action_slots.setdefault(action.predicate, [set() for _ in action.objects])
        for slot, value in zip(slots, action.objects, strict=True):
            slot.add(value)
        costs.setdefault(action.predicate, set()).add(action.cost)
    actions = []
    for predicate in task.action_predicates:
        parts = [_describe(values, categories, used) for values in action_slots[predicate]]
        low, high = min(costs[predicate]), max(costs[predicate])
        cost = f"{low}" if low == high else f"{low}-{high}"
        actions.append(f"{'_'.join([predicate, *parts])} ({cost})")
    return Vocabulary(
        condition_predicates=tuple(conditions),
        action_predicates=tuple(actions),
        categories=tuple(sorted(used.items())),
        action_names=frozenset(a.signature.underscored for a in task.actions),
        predicate_names=frozenset(task.action_predicates),
        object_names=task.symbols,
    )
