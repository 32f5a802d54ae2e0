"""An index of atom sets that answers "is a stored set a subset of ``c``?" without scanning them all.

The sets are kept in a *set-trie*: each set is a path of its atoms in increasing order, and each
node knows the smallest value stored below it. A query walks only the paths made of ``c``'s atoms
(in order), and skips every subtree whose smallest value exceeds the bound, so its cost depends on
the stored subsets of ``c``, not on how many sets share an atom with ``c``. Every set carries a
value (the search stores its cost ``g``), and a query can ask for a subset whose value is at most a
bound.

The trie is kept in C when the optional extension ``hbtp.logic._subsets`` is built (it is whenever a
C compiler is found at install): the same nodes in flat arrays, the same answers. Without it the
nodes below, in Python, answer the queries several times slower (:data:`COMPILED` says which).
"""

from __future__ import annotations

from fractions import Fraction
from typing import Any

from hbtp import compiled as extensions

_EXTENSION = extensions.SUBSETS
_compiled = extensions.extension(_EXTENSION)

#: Whether the trie is kept in C (the optional extension is built).
COMPILED = _compiled is not None

#: The value stored with a set (compared with ``<=``).
Value = int | float | Fraction

# A node: [children by atom, the smallest value stored in its subtree, the value of the set ending here or None]
_Node = list[Any]
_CHILDREN, _LOWEST, _HERE = 0, 1, 2


class SubsetIndex:
    """Atom sets with a value each; see the module docstring."""

    __slots__ = ("_root", "_trie")

    def __init__(self, compiled: bool = COMPILED) -> None:
        """``compiled``: keep the trie in C (only where the extension is built: :data:`COMPILED`)."""
        kernel = extensions.kernel(_compiled, _EXTENSION, compiled=compiled, slower="the subset index")
        self._trie: Any = None if kernel is None else kernel.Trie()
        self._root: _Node = [{}, None, None]

    def add(self, items: frozenset[int], value: Value = 0) -> None:
        """Store ``items`` (atom ids, ints from 0) with ``value`` (a set stored twice keeps its smaller value)."""
        if self._trie is not None:
            self._trie.add(items, value)
            return
        node = self._root
        for atom in sorted(items):
            if node[_LOWEST] is None or value < node[_LOWEST]:
                node[_LOWEST] = value
            children = node[_CHILDREN]
            child = children.get(atom)
            if child is None:
                child = children[atom] = [{}, None, None]
            node = child
        if node[_LOWEST] is None or value < node[_LOWEST]:
            node[_LOWEST] = value
        if node[_HERE] is None or value < node[_HERE]:
            node[_HERE] = value

    def has_subset(self, container: frozenset[int], at_most: Value | None = None) -> bool:
        """Whether a stored set is a subset of ``container`` (with a value of at most ``at_most``)."""
        if self._trie is not None:
            return bool(self._trie.has_subset(container, at_most))
        root = self._root
        if root[_LOWEST] is None or (at_most is not None and root[_LOWEST] > at_most):
            return False
        atoms = sorted(container)
        position = {atom: i for i, atom in enumerate(atoms)}
        return _search(root, atoms, position, 0, at_most)


def _search(node: _Node, atoms: list[int], position: dict[int, int], start: int, at_most: Value | None) -> bool:
    """Whether the subtree of ``node`` holds a set made of ``atoms[start:]`` (valued at most ``at_most``)."""
    here = node[_HERE]
    if here is not None and (at_most is None or here <= at_most):
        return True
    children: dict[int, _Node] = node[_CHILDREN]
    if len(children) < len(atoms) - start:  # walk the fewer of the children and the atoms left
        for atom, child in children.items():
            index = position.get(atom)
            if (
                index is not None
                and index >= start
                and (at_most is None or child[_LOWEST] <= at_most)
                and _search(child, atoms, position, index + 1, at_most)
            ):
                return True
        return False
    for index in range(start, len(atoms)):
        found = children.get(atoms[index])
        if (
            found is not None
            and (at_most is None or found[_LOWEST] <= at_most)
            and _search(found, atoms, position, index + 1, at_most)
        ):
            return True
    return False


__all__ = ["SubsetIndex", "Value"]
