"""Relaxed reachability: keep only the ground actions that can ever be applied from s0.

Under the delete relaxation, an atom is reachable when s0 holds it or a reachable action adds it; an
action is reachable when every atom of its precondition is (Fast Downward's translator instantiates
only such actions). The fixpoint counts, per action, the precondition atoms not reached yet, and
visits each reached atom once: linear in the total size of the preconditions and add effects.
"""

from __future__ import annotations

from collections.abc import Callable, Collection, Hashable, Iterable, Sequence
from typing import TypeVar

_A = TypeVar("_A", bound=Hashable)


def reachable_actions(
    initial: Iterable[_A],
    actions: Sequence[tuple[Collection[_A], Collection[_A]]],
    tick: Callable[[], None] | None = None,
) -> list[int]:
    """The indices, ascending, of the ``(pre, add)`` pairs reachable from ``initial`` when deletes are ignored.

    ``tick`` is called once per reached atom (a deadline's check point).
    """
    waiting = [len(pre) for pre, _ in actions]
    needed_by: dict[_A, list[int]] = {}
    for index, (pre, _) in enumerate(actions):
        for atom in pre:
            needed_by.setdefault(atom, []).append(index)
    reached: set[_A] = set()
    frontier: list[_A] = []
    ready = [index for index, count in enumerate(waiting) if count == 0]

    def reach(atoms: Iterable[_A]) -> None:
        for atom in atoms:
            if atom not in reached:
                reached.add(atom)
                frontier.append(atom)

    reach(initial)
    for index in ready:
        reach(actions[index][1])
    while frontier:
        atom = frontier.pop()
        if tick is not None:
            tick()
        for index in needed_by.get(atom, ()):
            waiting[index] -= 1
            if waiting[index] == 0:
                ready.append(index)
                reach(actions[index][1])
    return sorted(ready)
