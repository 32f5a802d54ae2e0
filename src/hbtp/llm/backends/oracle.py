"""Backends that answer from the optimal plan instead of a model.

``oracle`` replies with an optimal plan (OBTEA with the landmark heuristic) in the datasets' format.
``noisy-oracle`` drops a fraction of its actions and inserts wrong ones, seeded per goal, for the
paper's error-tolerance study (Fig. 4); on feedback rounds it answers again with half the noise, a
simple stand-in for a model that learns from the feedback.
"""

from __future__ import annotations

import hashlib
import random
import time

from hbtp.domains.scenarios import Scenario
from hbtp.errors import BackendError, HbtpError
from hbtp.llm.backend import Reply, Request
from hbtp.planning.limits import Limits
from hbtp.planning.oracle import optimal_plan


def format_reply(names: list[str], predicates: list[str], objects: list[str]) -> str:
    return (
        f"Optimal Actions: {', '.join(names)}\n"
        f"Vital Action Predicates: {', '.join(predicates)}\n"
        f"Vital Objects: {', '.join(objects)}"
    )


class OracleBackend:
    """Answers with an optimal plan of the request's goal."""

    name = "oracle"

    def __init__(self, scenario: Scenario, time_limit: float = 60.0) -> None:
        self.scenario = scenario
        self.limits = Limits(time_s=time_limit)
        self._plans: dict[str, list[int]] = {}

    def optimal(self, goal: str) -> list[int]:
        if goal not in self._plans:
            task = self.scenario.task
            try:
                resolved = task.resolve_goal(goal)
                self._plans[goal] = optimal_plan(task, resolved, self.scenario.mutexes.proved_only(), self.limits)
            except HbtpError as error:
                raise BackendError(f"the oracle has no plan for {goal!r}: {error}") from None
        return self._plans[goal]

    def complete(self, request: Request) -> Reply:
        started = time.perf_counter()
        actions = [self.scenario.task.actions[i] for i in self.optimal(request.goal)]
        text = format_reply(
            [a.signature.underscored for a in actions],
            list(dict.fromkeys(a.predicate for a in actions)),
            list(dict.fromkeys(o for a in actions for o in a.objects)),
        )
        return Reply(text, time.perf_counter() - started)

    def close(self) -> None:
        self._plans.clear()


class NoisyOracleBackend(OracleBackend):
    """The oracle with errors: ``drop`` removes that fraction of the optimal actions (the correct
    rate is ``1 - drop``); ``insert`` adds that many wrong actions per optimal action (the error rate)."""

    name = "noisy-oracle"

    def __init__(
        self, scenario: Scenario, drop: float = 0.3, insert: float = 0.3, seed: int = 0, time_limit: float = 60.0
    ) -> None:
        super().__init__(scenario, time_limit)
        for label, value in (("drop", drop), ("insert", insert)):
            if not 0.0 <= value <= 10.0:
                raise BackendError(f"noisy-oracle: {label} must be between 0 and 10, not {value}")
        if drop > 1.0:
            raise BackendError(f"noisy-oracle: drop is a fraction of the plan (0..1), not {drop}")
        self.drop = drop
        self.insert = insert
        self.seed = seed

    def noisy_path(self, goal: str, round_: int) -> list[int]:
        optimal = self.optimal(goal)
        factor = 0.5**round_
        digest = hashlib.sha256(f"{self.seed}|{goal}|{round_}".encode()).digest()
        rng = random.Random(int.from_bytes(digest[:8], "big"))
        keep = [a for a in optimal if rng.random() >= self.drop * factor]
        count = round(self.insert * factor * len(optimal))
        wrong_pool = [a.index for a in self.scenario.task.actions if a.index not in set(optimal)]
        for _ in range(min(count, len(wrong_pool))):
            keep.insert(rng.randrange(len(keep) + 1), rng.choice(wrong_pool))
        return keep

    def complete(self, request: Request) -> Reply:
        started = time.perf_counter()
        actions = [self.scenario.task.actions[i] for i in self.noisy_path(request.goal, request.round)]
        text = format_reply(
            [a.signature.underscored for a in actions],
            list(dict.fromkeys(a.predicate for a in actions)),
            list(dict.fromkeys(o for a in actions for o in a.objects)),
        )
        return Reply(text, time.perf_counter() - started)
