"""The scenario's vocabulary as the prompt shows it, derived from its action names (a grounded task's or
a world's not yet grounded, :class:`~hbtp.logic.names.ActionNames`).

Condition predicates with argument categories (``IsOn_<GRABBABLE>_<SURFACE>``), action predicates
with categories and costs (``Walk_<ALL_OBJECTS> (15)``), and the categories' members. A category is
the smallest static unary predicate that covers every value an argument takes; a single value
(``self``) is written as is.
"""

from __future__ import annotations

from dataclasses import dataclass

from hbtp.logic.names import ActionNames, names_of
from hbtp.logic.tables import TaskTable
from hbtp.logic.task import GroundTask

ANY = "ANY"


@dataclass(frozen=True)
class Vocabulary:
    condition_predicates: tuple[str, ...]  # "IsOn_<GRABBABLE>_<SURFACE>"
    action_predicates: tuple[str, ...]  # "Walk_<ALL_OBJECTS> (15)"
    categories: tuple[tuple[str, tuple[str, ...]], ...]  # ("GRABBABLE", ("apple", ...))


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


def as_names(source: GroundTask | ActionNames) -> ActionNames:
    """The action names of a task (or the names themselves)."""
    return source if isinstance(source, ActionNames) else names_of(source)


_VOCABULARY: TaskTable[Vocabulary] = TaskTable("the prompt vocabulary")


def vocabulary_of(source: GroundTask | ActionNames) -> Vocabulary:
    """The prompt vocabulary of a task or of action names (built once, kept with the names)."""
    names = as_names(source)
    return _VOCABULARY.of(names, lambda: _vocabulary(names))


def _vocabulary(names: ActionNames) -> Vocabulary:
    categories = dict(names.categories)
    used: dict[str, tuple[str, ...]] = {}
    conditions = []
    for predicate, values_at in names.condition_slots.items():
        parts = [_describe(set(values), categories, used) for values in values_at if values]
        conditions.append("_".join([predicate, *parts]))
    action_slots: dict[str, list[set[str]]] = {}
    costs: dict[str, set[int]] = {}
    for action, cost in zip(names.actions, names.costs, strict=True):
        slots = action_slots.setdefault(action.predicate, [set() for _ in action.args])
        for slot, value in zip(slots, action.args, strict=True):
            slot.add(value)
        costs.setdefault(action.predicate, set()).add(cost)
    actions = []
    for predicate in names.action_predicates:
        parts = [_describe(values, categories, used) for values in action_slots[predicate]]
        low, high = min(costs[predicate]), max(costs[predicate])
        span = f"{low}" if low == high else f"{low}-{high}"
        actions.append(f"{'_'.join([predicate, *parts])} ({span})")
    return Vocabulary(
        condition_predicates=tuple(conditions),
        action_predicates=tuple(actions),
        categories=tuple(sorted(used.items())),
    )
