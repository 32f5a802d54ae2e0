"""An index of atom sets that answers "is a stored set a subset of ``c``?" without scanning them all.

Each stored set is filed under one of its atoms, the one whose list is shortest so far; a set can
only be a subset of ``c`` if it is filed under an atom of ``c``, so a query looks at the lists of
``c``'s atoms alone. Every set carries a value (the search stores its cost ``g``), and a query can
ask for a subset whose value is at most a bound.
"""

from __future__ import annotations

from fractions import Fraction

#: The value stored with a set (compared with ``<=``).
Value = int | float | Fraction


class SubsetIndex:
    """Atom sets with a value each; see the module docstring."""

    __slots__ = ("_empty", "_filed")

    def __init__(self) -> None:
        self._filed: dict[int, list[tuple[frozenset[int], Value]]] = {}
        self._empty: Value | None = None  # the smallest value of the empty set, if stored

    def add(self, items: frozenset[int], value: Value = 0) -> None:
        """Store ``items`` with ``value``."""
        filed = self._filed
        key = min(items, key=lambda atom: len(filed.get(atom, ())), default=None)
        if key is not None:
            filed.setdefault(key, []).append((items, value))
        elif self._empty is None or value < self._empty:
            self._empty = value

    def has_subset(self, container: frozenset[int], at_most: Value | None = None) -> bool:
        """Whether a stored set is a subset of ``container`` (with a value of at most ``at_most``)."""
        empty = self._empty
        if empty is not None and (at_most is None or empty <= at_most):
            return True
        filed = self._filed
        if at_most is None:
            for atom in container:
                for items, _ in filed.get(atom, ()):
                    if items <= container:
                        return True
            return False
        for atom in container:
            for items, value in filed.get(atom, ()):
                if value <= at_most and items <= container:
                    return True
        return False


__all__ = ["SubsetIndex", "Value"]
