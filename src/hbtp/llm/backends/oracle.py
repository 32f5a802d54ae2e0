"""Backends that answer from the optimal plan instead of a model.

``oracle`` replies with an optimal plan (OBTEA with the landmark heuristic) in the datasets' format.
``noisy-oracle`` applies :class:`~hbtp.planning.hints.PathNoise` to it (drops a fraction of its
actions and inserts wrong ones), seeded per goal, for the paper's error-tolerance study (Fig. 4); on
feedback rounds it answers again with half the noise, a simple stand-in for a model that learns from
the feedback.
"""

from __future__ import annotations

import time
from collections.abc import Sequence

from hbtp.datasets.instructions import load_instructions
from hbtp.domains.scenarios import Scenario
from hbtp.errors import BackendError, HbtpError, InputError
from hbtp.llm.backend import PromptStyle, Reply, Request
from hbtp.llm.parse import hints_reply
from hbtp.logic.goal import Goal
from hbtp.planning.hints import Hints, PathNoise, seeded_random
from hbtp.planning.limits import Limits
from hbtp.planning.oracle import optimal_plan


class OracleBackend:
    """Answers with an optimal plan of the request's goal."""

    name = "oracle"
    prompt_style = PromptStyle.CHAT

    def __init__(self, scenario: Scenario, time_limit: float = 60.0) -> None:
        self.scenario = scenario
        self.limits = Limits(time_s=time_limit)
        self._plans: dict[str, list[int]] = {}

    def optimal(self, goal: str, resolved: Goal | None = None) -> list[int]:
        """An optimal plan of ``goal`` (``resolved``: the goal already resolved against this
        oracle's task, when the caller has it)."""
        if goal not in self._plans:
            task = self.scenario.task
            try:
                if resolved is None or not resolved.resolved_in(task):
                    resolved = task.resolve_goal(goal)
                self._plans[goal] = optimal_plan(task, resolved, self.scenario.mutexes.proved_only(), self.limits)
            except HbtpError as error:
                raise BackendError(f"the oracle has no plan for {goal!r}: {error}") from None
        return self._plans[goal]

    def path(self, request: Request) -> Sequence[int]:
        """The plan this backend answers ``request`` with."""
        return self.optimal(request.goal, request.resolved)

    def complete(self, request: Request) -> Reply:
        started = time.perf_counter()
        text = hints_reply(Hints.from_plan(self.scenario.task, self.path(request)))
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
        self.noise = PathNoise(correct=1.0 - drop, error=insert)

    def noisy_path(self, goal: str, round_: int, resolved: Goal | None = None) -> list[int]:
        """The optimal plan of ``goal`` with the noise, halved on each feedback round."""
        optimal = self.optimal(goal, resolved)
        chosen = set(optimal)
        wrong = [a.index for a in self.scenario.task.actions if a.index not in chosen]
        return self.noise.scaled(0.5**round_).apply(optimal, wrong, seeded_random(self.seed, goal, round_))

    def path(self, request: Request) -> Sequence[int]:
        return self.noisy_path(request.goal, request.round, request.resolved)


class InstructionOracle:
    """Answers an instruction of the shipped instruction dataset with the goal recorded for it
    (``--llm oracle`` with ``--instruction``: for tests and for the benchmark's upper bound)."""

    name = "oracle"
    prompt_style = PromptStyle.CHAT

    def __init__(self, scenario: Scenario) -> None:
        try:
            records = load_instructions(scenario.name)
        except InputError:
            records = ()
        self.goals = {_normal(text): r.goal for r in records for text in r.instructions}

    def complete(self, request: Request) -> Reply:
        goal = self.goals.get(_normal(request.instruction))
        if goal is None:
            raise BackendError("the instruction oracle knows only the instructions of the shipped dataset")
        return Reply(goal)

    def close(self) -> None:
        return None


def _normal(text: str) -> str:
    return " ".join(text.lower().split())
