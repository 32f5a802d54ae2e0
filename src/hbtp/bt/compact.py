"""Compaction: factor the literals that adjacent branches share, without changing behaviour.

A planned tree ``Fallback(goal, Sequence(c1, a1), ..., Sequence(cn, an))`` repeats many literals:
neighbouring conditions were regressed from the same parent. For a run of *adjacent* guarded
branches ``Sequence(Condition(c_i), tail_i)`` (i = j..k) whose conditions all contain a literal set
``L``, the rewrite

    Fallback(..., Sequence(Condition(L), Fallback(Sequence(Condition(c_j - L), tail_j), ...,
                                                  Sequence(Condition(c_k - L), tail_k))), ...)

ticks exactly like the original in every state:

* if ``L`` does not hold, every original branch of the run fails at its condition and the outer
  Fallback goes on to the branch after the run; the new Sequence fails and it does the same;
* if ``L`` holds, ``c_i - L`` holds iff ``c_i`` does, so the inner Fallback tries the same branches in
  the same order and returns the first status that is not FAILURE (with the same running action);
  when all fail, it fails, and the outer Fallback goes on to the branch after the run, as before.

Only adjacent branches are merged, so the Fallback's first-match order is kept. An empty
``c_i - L`` leaves no Condition node, and one-child Sequences and Fallbacks are replaced by their
child. A normalisation that keeps behaviour in any BT engine comes first: nested Sequences
(Fallbacks) are inlined into their Sequence (Fallback) parent and adjacent Conditions of a
Sequence are merged.

Which runs to merge: for each Fallback a dynamic program over its children chooses the runs that
save the most *size*, counted as nodes plus literal occurrences; a run of ``k`` branches sharing
``L`` saves ``(k - 1)|L|`` literals and costs three nodes (Sequence, Condition, Fallback), less the
nodes that disappear. The inner Fallbacks are compacted the same way.
"""

from __future__ import annotations

import bisect
import logging
from collections.abc import Sequence
from dataclasses import dataclass
from typing import Any

from hbtp.bt.nodes import Action, Condition, Fallback, Node, TreeSize, size
from hbtp.bt.nodes import Sequence as SequenceNode

log = logging.getLogger(__name__)


@dataclass(frozen=True, slots=True)
class CompactionReport:
    before: TreeSize
    after: TreeSize
    merges: int  # runs of branches factored

    def to_dict(self) -> dict[str, Any]:
        return {"before": self.before.to_dict(), "after": self.after.to_dict(), "merges": self.merges}

    def __str__(self) -> str:
        b, a = self.before, self.after
        return (
            f"nodes {b.nodes} -> {a.nodes}, depth {b.depth} -> {a.depth}, "
            f"literals {b.literals} -> {a.literals} ({self.merges} merge(s))"
        )


def compact(tree: Node) -> Node:
    """A tree that ticks exactly like ``tree`` in every state, with shared literals factored."""
    return _Compactor().node(tree)


def compact_with_report(tree: Node) -> tuple[Node, CompactionReport]:
    """:func:`compact` and the sizes before and after."""
    compactor = _Compactor()
    result = compactor.node(tree)
    report = CompactionReport(size(tree), size(result), compactor.merges)
    log.debug("compact: %s", report)
    return result, report


# ------------------------------------------------------------------------ building
def _sequence(children: Sequence[Node]) -> Node:
    """A Sequence of ``children``: nested Sequences inlined, adjacent Conditions merged, empty
    Conditions dropped (while other children remain), a single child returned as it is."""
    flat: list[Node] = []
    for child in children:
        parts = child.children if isinstance(child, SequenceNode) else (child,)
        for part in parts:
            if isinstance(part, Condition) and flat and isinstance(flat[-1], Condition):
                flat[-1] = Condition(flat[-1].literals | part.literals)
            else:
                flat.append(part)
    if len(flat) > 1:
        flat = [c for c in flat if not (isinstance(c, Condition) and not c.literals)] or flat[:1]
    if len(flat) == 1:
        return flat[0]
    return SequenceNode(tuple(flat))


def _fallback(children: Sequence[Node]) -> Node:
    flat: list[Node] = []
    for child in children:
        flat.extend(child.children if isinstance(child, Fallback) else (child,))
    if len(flat) == 1:
        return flat[0]
    return Fallback(tuple(flat))


@dataclass(frozen=True, slots=True)
class _Guarded:
    """A Fallback child ``Sequence(Condition(guard), *tail)``."""

    guard: frozenset[int]
    tail: tuple[Node, ...]

    def node(self, remove: frozenset[int] = frozenset()) -> Node:
        rest = self.guard - remove
        return _sequence(((Condition(rest),) if rest else ()) + self.tail)


def _guarded(node: Node) -> _Guarded | None:
    if (
        isinstance(node, SequenceNode)
        and len(node.children) >= 2
        and isinstance(node.children[0], Condition)
        and node.children[0].literals
    ):
        return _Guarded(node.children[0].literals, node.children[1:])
    return None


class _Compactor:
    def __init__(self) -> None:
        self.merges = 0

    def node(self, node: Node) -> Node:
        if isinstance(node, Condition | Action):
            return node
        if isinstance(node, SequenceNode):
            return _sequence([self.node(child) for child in node.children]) if node.children else node
        if not node.children:
            return node
        children = _fallback([self.node(child) for child in node.children])
        if not isinstance(children, Fallback):
            return children
        return _fallback(self.factor(children.children))

    def factor(self, children: Sequence[Node]) -> list[Node]:
        """The children of a Fallback with runs of adjacent guarded branches factored."""
        result: list[Node] = []
        segment: list[_Guarded] = []
        for child in children:
            guarded = _guarded(child)
            if guarded is None:
                result.extend(self.segment(segment))
                segment = []
                result.append(child)
            else:
                segment.append(guarded)
        result.extend(self.segment(segment))
        return result

    def segment(self, branches: Sequence[_Guarded]) -> list[Node]:
        """Factor a list of guarded branches, choosing runs by dynamic programming."""
        n = len(branches)
        if n < 2:
            return [b.node() for b in branches]
        guards = [b.guard for b in branches]
        # end[i][l]: the last position of the run of consecutive guards from i that contain l.
        ends: list[dict[int, int]] = [{} for _ in range(n)]
        for i in range(n - 1, -1, -1):
            following = ends[i + 1] if i + 1 < n else {}
            ends[i] = {atom: following.get(atom, i) if i + 1 < n and atom in guards[i + 1] else i for atom in guards[i]}
        # Nodes saved when a branch's guard equals L (its Condition goes, and a one-child Sequence).
        weight = [1 + (len(b.tail) == 1) for b in branches]
        prefix: dict[int, list[int]] = {}
        for i, guard in enumerate(guards):
            prefix.setdefault(len(guard), []).append(i)
        cumulative = {length: [0] for length in prefix}
        for length, positions in prefix.items():
            for position in positions:
                cumulative[length].append(cumulative[length][-1] + weight[position])

        def dropped(length: int, start: int, stop: int) -> int:
            positions = prefix.get(length)
            if not positions:
                return 0
            lo = bisect.bisect_left(positions, start)
            hi = bisect.bisect_right(positions, stop)
            return cumulative[length][hi] - cumulative[length][lo]

        best = [0] * (n + 1)
        choice: list[tuple[int, frozenset[int]] | None] = [None] * (n + 1)
        for i in range(n - 1, -1, -1):
            best[i] = best[i + 1]
            choice[i] = None
            for stop in sorted({e for e in ends[i].values() if e > i}):
                shared = frozenset(atom for atom, e in ends[i].items() if e >= stop)
                k = stop - i + 1
                gain = (k - 1) * len(shared) - 3 + dropped(len(shared), i, stop)
                if gain > 0 and gain + best[stop + 1] > best[i]:
                    best[i] = gain + best[stop + 1]
                    choice[i] = (stop, shared)
        result: list[Node] = []
        i = 0
        while i < n:
            picked = choice[i]
            if picked is None:
                result.append(branches[i].node())
                i += 1
                continue
            stop, shared = picked
            self.merges += 1
            inner = self.factor([b.node(shared) for b in branches[i : stop + 1]])
            result.append(_sequence((Condition(shared), _fallback(inner))))
            i = stop + 1
        return result


__all__ = ["CompactionReport", "compact", "compact_with_report"]
