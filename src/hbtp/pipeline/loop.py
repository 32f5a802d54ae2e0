"""The HBTP loop: reason, check, prune, plan; on failure, reflective feedback; at the end, a fallback.

Round 0 asks the LLM for hints (p̂, Q̂, Ô). The grammar checker repairs or blacklists names outside
the domain and asks again (``grammar_retries`` times). The hints prune the action space
(A⁻ = (Q⁻ × O⁻) ∩ A) and the planner searches it. If it fails or times out, the LLM gets the top-k
longest paths of the partial tree and the action predicates and objects the space left out, and
answers again (``feedback_rounds`` times); the predicates and objects of every round accumulate, so
the space only grows. After the last round the planner searches the full action space with the
LLM-free landmark heuristic, so every solvable task is solved. The LLM can make planning fast or
slow, never wrong: every tree comes from the sound search and is executed before it is returned.

A round whose LLM call failed without any answer plans nothing (its space is the previous round's,
already searched) and ends the asking: the loop goes to the fallback at once.

``LoopOptions.time_limit`` bounds the whole run (``hbtp plan -t``): every LLM call gets the time
that is left (``Request.time_limit``), every round's search at most that, no round starts once it is
gone, and the fallback gets what remains (at most ``fallback_time_limit``); when nothing remains the
result is a timeout.
"""

from __future__ import annotations

import logging
import math
import time
from collections.abc import Sequence
from dataclasses import dataclass, field, replace
from typing import Any

from hbtp.datasets.records import Record
from hbtp.domains.scenarios import Scenario
from hbtp.errors import BackendError
from hbtp.llm.backend import Backend, Request
from hbtp.llm.grammar import GrammarCheck, check_reply
from hbtp.llm.parse import parse_reply
from hbtp.llm.prompt import PromptOptions, build_request, feedback_request, retry_request
from hbtp.llm.redact import redact
from hbtp.logic.task import Goal
from hbtp.planning.heuristics import HeuristicName
from hbtp.planning.hints import Hints, pruned_action_space, resolve_hints
from hbtp.planning.limits import Limits
from hbtp.planning.planners import confirmed_search, plan, planner_config
from hbtp.planning.result import PlanResult, Status
from hbtp.planning.search import search

log = logging.getLogger(__name__)

#: "NF" (solved with no feedback), "1F", "2F", ... (after that many feedback rounds), "fallback"
#: (solved in the full space after the last round), or "failed".
Outcome = str


@dataclass(frozen=True)
class LoopOptions:
    planner: str = "hbtp-s"
    feedback_rounds: int = 3
    grammar_retries: int = 2
    top_k: int = 3
    round_time_limit: float = 5.0
    fallback: bool = True
    fallback_time_limit: float = 60.0
    heuristic: HeuristicName = "none"  # inside the pruned rounds (the paper's planners by default)
    fallback_heuristic: HeuristicName = "lm"
    prompt: PromptOptions = field(default_factory=PromptOptions)
    #: Seconds for the whole run (LLM calls, rounds and fallback); ``None``: no overall bound.
    time_limit: float | None = None


@dataclass(frozen=True)
class RoundRecord:
    """What happened in one round: the exchange(s) with the LLM and the planning run."""

    round: int
    prompts: tuple[dict[str, Any], ...]
    replies: tuple[str, ...]
    hints: Hints
    repairs: tuple[str, ...]
    blacklist: tuple[str, ...]
    action_space: int
    status: str
    explored: int
    llm_seconds: float
    planning_seconds: float
    error: str = ""

    def to_dict(self) -> dict[str, Any]:
        return {
            "round": self.round,
            "prompts": list(self.prompts),
            "replies": [redact(reply) for reply in self.replies],
            "hints": {
                "path": list(self.hints.path),
                "predicates": list(self.hints.predicates),
                "objects": list(self.hints.objects),
            },
            "repairs": list(self.repairs),
            "blacklist": list(self.blacklist),
            "action_space": self.action_space,
            "status": self.status,
            "explored": self.explored,
            "llm_seconds": round(self.llm_seconds, 6),
            "planning_seconds": round(self.planning_seconds, 6),
            "error": redact(self.error),
        }


@dataclass(frozen=True)
class LoopResult:
    outcome: Outcome
    result: PlanResult
    rounds: tuple[RoundRecord, ...]
    llm_seconds: float
    planning_seconds: float

    @property
    def solved(self) -> bool:
        return self.result.solved

    def to_dict(self) -> dict[str, Any]:
        return {
            "outcome": self.outcome,
            "llm_seconds": round(self.llm_seconds, 6),
            "planning_seconds": round(self.planning_seconds, 6),
            "rounds": [r.to_dict() for r in self.rounds],
        }


def round_label(round_number: int) -> Outcome:
    """``NF`` for the first answer, ``kF`` after k feedback rounds."""
    return "NF" if round_number == 0 else f"{round_number}F"


def feedback_rounds_of(outcome: Outcome) -> int | None:
    """The number of feedback rounds a successful outcome needed; ``None`` for fallback or failed."""
    if outcome == "NF":
        return 0
    if outcome.endswith("F") and outcome[:-1].isdigit():
        return int(outcome[:-1])
    return None


def _prompt_record(request: Request) -> dict[str, Any]:
    return {
        "key": request.key(),
        "round": request.round,
        "attempt": request.attempt,
        "messages": [{"role": m.role, "content": m.content} for m in request.messages],
        "completion_prompt": request.completion_prompt,
    }


def longest_paths(result: PlanResult, task_names: Sequence[str], k: int) -> list[list[str]]:
    """The action sequences (execution order) of the ``k`` deepest conditions of the partial tree."""
    expansions = result.expansions
    depth = [0] * len(expansions)
    for index, expansion in enumerate(expansions):
        if expansion.parent >= 0:
            depth[index] = depth[expansion.parent] + 1
    order = sorted(range(len(expansions)), key=lambda i: (-depth[i], i))
    paths: list[list[str]] = []
    for index in order[:k]:
        path: list[str] = []
        current = index
        while current > 0:
            action = expansions[current].action
            if action is not None:
                path.append(task_names[action])
            current = expansions[current].parent
        if path:
            paths.append(path)
    return paths


class _Round:
    """Ask (with grammar retries), check and plan once."""

    def __init__(self, scenario: Scenario, backend: Backend, options: LoopOptions) -> None:
        self.scenario = scenario
        self.backend = backend
        self.options = options
        self.names = [a.signature.underscored for a in scenario.task.actions]
        self.blacklist: list[str] = []

    def ask(
        self, request: Request, deadline: float = math.inf
    ) -> tuple[Request, GrammarCheck | None, list[Request], list[str], float, str]:
        prompts: list[Request] = []
        replies: list[str] = []
        seconds = 0.0
        check: GrammarCheck | None = None
        error = ""
        for attempt in range(self.options.grammar_retries + 1):
            left = deadline - time.perf_counter()
            if left <= 0:
                if not replies:
                    error = "the time limit ran out before the LLM was asked"
                break
            prompts.append(request)
            try:
                reply = self.backend.complete(request if math.isinf(left) else replace(request, time_limit=left))
            except BackendError as failure:
                error = redact(str(failure))
                log.warning("round %d: the LLM failed: %s", request.round, error)
                if replies:  # continue from the last request that was answered
                    request = prompts[-2]
                break
            seconds += reply.seconds
            replies.append(reply.text)
            parsed = parse_reply(reply.text)
            if "path" not in parsed.found:  # a base model continues after "Optimal Actions:"
                parsed = parse_reply("Optimal Actions:" + reply.text)
            check = check_reply(parsed, self.scenario.task)
            self.blacklist.extend(n for n in check.unknown if n not in self.blacklist)
            if check.clean or not check.problems or attempt == self.options.grammar_retries:
                break  # (no retry request after the last attempt: it would never be answered)
            request = retry_request(request, reply.text, check.problems, self.blacklist)
        return request, check, prompts, replies, seconds, error


def run_hbtp(
    scenario: Scenario,
    goal: Goal | str,
    backend: Backend,
    pool: Sequence[Record] = (),
    options: LoopOptions = LoopOptions(),
) -> LoopResult:
    """Plan ``goal`` with LLM hints, reflective feedback and the full-space fallback."""
    started_run = time.perf_counter()
    deadline = math.inf if options.time_limit is None else started_run + options.time_limit
    task = scenario.task
    resolved = task.resolve_goal(goal) if isinstance(goal, str) else goal
    goal_text = str(resolved)
    config = planner_config(options.planner, heuristic=options.heuristic)
    asker = _Round(scenario, backend, options)
    rounds: list[RoundRecord] = []
    llm_total = planning_total = 0.0
    predicates: set[str] = set()
    objects: set[str] = set()
    request = build_request(task, goal_text, pool, options.prompt, scenario=scenario.name)
    last: PlanResult | None = None
    hints = Hints()
    for round_number in range(options.feedback_rounds + 1):
        if time.perf_counter() >= deadline:
            log.info("the time limit ran out before round %d", round_number)
            break
        if round_number > 0 and last is not None:
            all_predicates = set(task.action_predicates)
            request = feedback_request(
                request,
                "\n".join(rounds[-1].replies[-1:]),
                longest_paths(last, asker.names, options.top_k),
                sorted(all_predicates - predicates),
                sorted(set(task.objects) - objects),
                task,
                pool,
                options.prompt.examples + 2 * round_number,
                options.prompt.exclude_same_goal,
                asker.blacklist,
                options.prompt.retrieval,
            )
        request, check, prompts, replies, llm_seconds, error = asker.ask(request, deadline)
        llm_total += llm_seconds
        if error and not replies:
            # Nothing new was said: the space is the last round's (already searched), so the
            # asking ends here and the loop goes to the fallback.
            rounds.append(
                RoundRecord(
                    round_number,
                    tuple(_prompt_record(p) for p in prompts),
                    (),
                    Hints(),
                    (),
                    tuple(asker.blacklist),
                    0,
                    "skipped",
                    0,
                    llm_seconds,
                    0.0,
                    error,
                )
            )
            break
        if check is not None:
            hints = check.hints
        resolved_hints = resolve_hints(task, hints)
        path_actions = [task.actions[i] for i in resolved_hints.path]
        predicates |= set(resolved_hints.predicates) | {a.predicate for a in path_actions}
        objects |= set(resolved_hints.objects) | {o for a in path_actions for o in a.objects}
        accumulated = resolve_hints(task, Hints(hints.path, tuple(sorted(predicates)), tuple(sorted(objects))))
        space = task.restricted(pruned_action_space(task, accumulated))
        left = deadline - time.perf_counter()
        if left <= 0:
            log.info("the time limit ran out before round %d could plan", round_number)
            break
        started = time.perf_counter()
        # Declared mutexes speed the rounds up; without a fallback, a failed round's verdict is the
        # answer, so it must not rest on them (confirmed_search re-decides it without them).
        result = (search if options.fallback else confirmed_search)(
            task,
            resolved,
            space,
            config,
            mutexes=scenario.mutexes,
            hints=accumulated,
            limits=Limits(time_s=min(options.round_time_limit, left)),
        )
        planning_total += time.perf_counter() - started
        rounds.append(
            RoundRecord(
                round_number,
                tuple(_prompt_record(p) for p in prompts),
                tuple(replies),
                hints,
                check.repairs if check is not None else (),
                tuple(asker.blacklist),
                len(space),
                result.status.value,
                result.stats.explored,
                llm_seconds,
                result.stats.time_s,
                error,
            )
        )
        last = result
        if result.solved:
            return LoopResult(round_label(round_number), result, tuple(rounds), llm_total, planning_total)
    left = deadline - time.perf_counter()
    if not options.fallback:
        message = f"no round planned: {rounds[-1].error}" if rounds and rounds[-1].error else "no round ran"
        final = last or PlanResult(Status.UNSOLVABLE, options.planner, resolved, message=message)
        return LoopResult("failed", final, tuple(rounds), llm_total, planning_total)
    if left <= 0:
        message = "the time limit ran out before the fallback"
        if last is not None:
            final = replace(last, status=Status.TIMEOUT, message=message)
        else:
            final = PlanResult(Status.TIMEOUT, options.planner, resolved, message=message)
        return LoopResult("failed", final, tuple(rounds), llm_total, planning_total)
    started = time.perf_counter()
    # The fallback prunes with proved mutexes only: declared ones could cut off the only solution.
    final = plan(
        task,
        resolved,
        options.planner,
        hints=Hints(hints.path, tuple(sorted(predicates)), tuple(sorted(objects))),
        space="full",
        mutexes=scenario.mutexes.proved_only(),
        heuristic=options.fallback_heuristic,
        limits=Limits(time_s=min(options.fallback_time_limit, left)),
    )
    planning_total += time.perf_counter() - started
    return LoopResult("fallback" if final.solved else "failed", final, tuple(rounds), llm_total, planning_total)
