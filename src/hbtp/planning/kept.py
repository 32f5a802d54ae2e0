"""What the re-plans of one goal keep between them (:class:`KeptSearch`): the full space's search they
continue (:class:`hbtp.planning.repair.RepairableSearch`), the hints' pruned space indexed once, and
the answers the hints' space gave from each state (a re-plan from a state searched before recalls its
answer: the searches are deterministic, so it is the one a new search would give)."""

from __future__ import annotations

from collections.abc import Hashable

from hbtp.logic.task import Goal, GroundTask
from hbtp.planning.hints import Hints, PrunedSpace, resolve_hints
from hbtp.planning.repair import RepairableSearch
from hbtp.planning.result import PlanResult
from hbtp.planning.search_state import SearchConfig

#: Answers of the hints' space a :class:`KeptSearch` keeps for re-plans from a state planned from
#: before (each holds at most :data:`hbtp.replanning.PRUNED_EXPANSIONS` conditions).
KEPT_ANSWERS = 256


class KeptSearch:
    """What re-plans keep for one goal and planner: the search they continue
    (:class:`hbtp.planning.repair.RepairableSearch`), the hints' pruned space and its answers.
    Replanners given the same one share it (the runs of a benchmark task, the episodes of a robot with
    the same goal), so each continues what the others explored. Memory: at most
    :data:`hbtp.planning.repair.MAX_CONDITIONS` conditions in the search, then it is dropped and
    started anew, and :data:`KEPT_ANSWERS` answers."""

    def __init__(self) -> None:
        self.search: RepairableSearch | None = None
        self._space: tuple[GroundTask, Hints, PrunedSpace] | None = None
        #: The hints' space's answers by what decides them (:meth:`recall`), oldest first.
        self._answers: dict[Hashable, PlanResult | None] = {}

    def recall(self, key: Hashable) -> tuple[bool, PlanResult | None]:
        """Whether a re-plan with ``key`` (goal, planner, state and the actions left out: with the
        pruned space, everything a search of the hints' space depends on) was searched there before,
        and what it found (``None``: no tree in that space). The searches are deterministic, so the
        answer is the one a new search would give."""
        if key not in self._answers:
            return False, None
        return True, self._answers[key]

    def remember(self, key: Hashable, answer: PlanResult | None) -> None:
        """Keep the hints' space's ``answer`` for ``key`` (at most :data:`KEPT_ANSWERS`, the oldest
        dropped first)."""
        if len(self._answers) >= KEPT_ANSWERS:
            self._answers.pop(next(iter(self._answers)))
        self._answers[key] = answer

    def pruned_space(self, task: GroundTask, hints: Hints) -> PrunedSpace:
        """The pruned space of ``hints`` in ``task``, built once for the re-plans that share this."""
        if self._space is None or self._space[0] is not task or self._space[1] != hints:
            self._answers.clear()  # answers of another space
            space = PrunedSpace(task, resolve_hints(task, hints))
            space.prepare()  # with the tree, not at the first re-plan
            self._space = (task, hints, space)
        return self._space[2]

    def take(self, goal: Goal, config: SearchConfig) -> RepairableSearch | None:
        """The kept search if it is one for ``goal`` and ``config`` (else it is dropped)."""
        search = self.search
        if search is not None and (search.goal.disjuncts != goal.disjuncts or search.config != config):
            self.search = search = None
        return search


__all__ = ["KEPT_ANSWERS", "KeptSearch"]
