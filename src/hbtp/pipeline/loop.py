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
already searched) and ends the asking: the loop goes to the fallback at once. So does a round whose
question the backend has already answered at temperature 0 (it would answer the same), and a grammar
retry whose prompt did not change is not sent: no call is wasted. Every call is counted and timed
(``RoundRecord.calls``).

The ``deadline`` of :func:`run_hbtp` (the command's, ``hbtp plan -t``) bounds the whole run: every
LLM call gets it (``Request.deadline``), every round's search it capped at ``round_time_limit``,
grounding a part of the world it as is; no round starts once it passed, and the fallback gets what
remains (at most ``fallback_time_limit``); when nothing remains the result is a timeout.
"""

from __future__ import annotations

import logging
import time
from collections.abc import Callable, Sequence
from dataclasses import dataclass, field, replace
from typing import Any

from hbtp.datasets.records import Record
from hbtp.deadline import Deadline, TimeLimitReached, expired, within
from hbtp.domains.pruned import GroundedWorld, World
from hbtp.domains.scenarios import Scenario
from hbtp.errors import BackendError
from hbtp.llm.backend import Backend, Reply, Request
from hbtp.llm.checked import checked_answer
from hbtp.llm.grammar import GrammarCheck, check_reply
from hbtp.llm.parse import parse_reply
from hbtp.llm.prompt import Feedback, PromptOptions, build_request, feedback_request, retry_request
from hbtp.llm.redact import redact
from hbtp.llm.spelling import Spelling
from hbtp.logic.names import ActionNames
from hbtp.logic.task import Goal, GroundTask
from hbtp.pipeline.results import REPEATED, Exchange, LoopResult, Outcome, RoundRecord, call_record
from hbtp.planning.heuristic_names import DEFAULT_HEURISTIC, HeuristicName
from hbtp.planning.hints import Hints, pruned_action_space, resolve_hints
from hbtp.planning.limits import Limits
from hbtp.planning.planners import Space, confirmed_search, plan, planner_config
from hbtp.planning.result import PlanResult, Status
from hbtp.planning.search import search

__all__ = ["LoopOptions", "LoopResult", "RoundRecord", "longest_paths", "run_hbtp"]

log = logging.getLogger(__name__)

#: Told what the loop is doing, one short line at a time (``hbtp plan`` shows it on a terminal).
Progress = Callable[[str], None]


def _quiet(message: str) -> None:
    log.debug("%s", message)


@dataclass(frozen=True)
class LoopOptions:
    planner: str = "hbtp-s"
    feedback_rounds: int = 3
    grammar_retries: int = 2
    top_k: int = 3
    round_time_limit: float = 5.0
    fallback: bool = True
    fallback_time_limit: float = 60.0
    heuristic: HeuristicName = HeuristicName.NONE  # inside the pruned rounds (the paper's planners by default)
    fallback_heuristic: HeuristicName = DEFAULT_HEURISTIC
    #: Its ``style`` (``None`` by default) is the backend's own prompt style.
    prompt: PromptOptions = field(default_factory=PromptOptions)
    #: Told what the loop is doing (round k of N, tokens/s, planning); ``None``: logged at DEBUG.
    progress: Progress | None = None


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


class _Asker:
    """Asks the LLM once per round, with grammar retries; keeps the blacklist of the whole run.

    A request is never sent twice at temperature 0: a backend of the same prompt style would see
    the same text and answer the same, so a retry whose prompt did not change is not sent, and a
    round whose question was already answered is skipped (it cannot help).

    ``checking``: the whole world's task and the goal resolved in it, when the world is grounded:
    a taught model's first answer is then made to run there (:mod:`hbtp.llm.checked`)."""

    def __init__(
        self,
        names: ActionNames,
        backend: Backend,
        retries: int,
        progress: Progress,
        checking: tuple[GroundTask, Goal] | None = None,
    ) -> None:
        self.names = names
        self.backend = backend
        self.retries = retries
        self.progress = progress
        self.checking = checking
        self.blacklist: list[str] = []
        self.answered: set[str] = set()

    def ask(self, request: Request, deadline: Deadline | None) -> Exchange:
        if self.checking is not None and request.taught and not expired(deadline) and not self.repeated(request):
            task, goal = self.checking
            if not goal.holds(task.initial_state):
                return self.ask_checked(request, task, goal, deadline)
        return self.ask_plainly(request, deadline)

    def ask_checked(self, request: Request, task: GroundTask, goal: Goal, deadline: Deadline | None) -> Exchange:
        """A taught model's answer made to run (:func:`hbtp.llm.checked.checked_answer`): every call
        is recorded with its raw reply; the round's last reply is the plan kept."""
        self.progress(f"asking {self.backend.name} (each action checked)")
        calls: list[tuple[Request, Reply]] = []

        def complete(step: Request) -> Reply:
            reply = self.backend.complete(replace(step, deadline=deadline))
            calls.append((step, reply))
            return reply

        started = time.perf_counter()
        try:
            answer = checked_answer(complete, request, task, goal, deadline)
        except BackendError as failure:
            error = redact(str(failure))
            log.warning("round %d: the LLM failed: %s", request.round, error)
            return Exchange(request, (request,), (), None, sum(r.seconds for _, r in calls), error)
        self.answered.add(request.sent_key(self.backend.prompt_style))
        check = self.check(answer.text, path_only=True)
        records = tuple(call_record(step, reply, check) for step, reply in answer.calls)
        self.progress(_call_summary(records[-1]) + f", {len(records)} call(s), plan of {len(answer.plan)} actions")
        return Exchange(
            request,
            tuple(step for step, _ in answer.calls),
            (*(reply.text for _, reply in answer.calls), answer.text),
            check,
            answer.seconds,
            "",
            records,
            max(0.0, time.perf_counter() - started - answer.seconds),
        )

    def ask_plainly(self, request: Request, deadline: Deadline | None) -> Exchange:
        prompts: list[Request] = []
        replies: list[str] = []
        calls: list[dict[str, Any]] = []
        check: GrammarCheck | None = None
        error = ""
        for attempt in range(self.retries + 1):
            if expired(deadline):
                if not replies:
                    error = "the time limit ran out before the LLM was asked"
                break
            if self.repeated(request):
                if not replies:
                    error = REPEATED
                else:  # continue from the last request that was answered
                    request = prompts[-1]
                break
            prompts.append(request)
            self.progress(f"asking {self.backend.name}" + _retry_note(attempt))
            try:
                reply = self.backend.complete(replace(request, deadline=deadline))
            except BackendError as failure:
                error = redact(str(failure))
                log.warning("round %d: the LLM failed: %s", request.round, error)
                if replies:  # continue from the last request that was answered
                    request = prompts[-2]
                break
            self.answered.add(request.sent_key(self.backend.prompt_style))
            replies.append(reply.text)
            check = self.check(reply.text, path_only=request.taught)
            calls.append(call_record(request, reply, check))
            self.progress(_call_summary(calls[-1]))
            if check.clean or not check.problems or attempt == self.retries:
                break  # (no retry request after the last attempt: it would never be answered)
            request = retry_request(request, reply.text, check.problems, self.blacklist)
        seconds = sum(float(call["seconds"]) for call in calls)
        return Exchange(request, tuple(prompts), tuple(replies), check, seconds, error, tuple(calls))

    def repeated(self, request: Request) -> bool:
        """Whether the backend already answered, greedily, what it would now be sent."""
        return request.temperature <= 0 and request.sent_key(self.backend.prompt_style) in self.answered

    def check(self, text: str, path_only: bool = False) -> GrammarCheck:
        """The grammar check of a reply (of a taught model: ``path_only``); its unknown names join the blacklist."""
        parsed = parse_reply(text)
        if "path" not in parsed.found:  # a base model continues after "Optimal Actions:"
            parsed = parse_reply("Optimal Actions:" + text)
        check = check_reply(parsed, self.names, path_only=path_only)
        self.blacklist.extend(n for n in check.unknown if n not in self.blacklist)
        return check


def _retry_note(attempt: int) -> str:
    return f" again (grammar retry {attempt})" if attempt else ""


def _call_summary(call: dict[str, Any]) -> str:
    rate = call.get("tokens_per_second")
    speed = f", {rate:.1f} tokens/s" if rate else ""
    tokens = call.get("completion_tokens")
    size = f"{tokens} tokens" if tokens is not None else "a reply"
    return f"answered: {size} in {call['seconds']:.2f} s{speed}, {call['unknown']} unknown name(s)"


class _Loop:
    """One run of the loop: its state between rounds and its steps (round, fallback)."""

    def __init__(
        self,
        world: World,
        goal: Goal,
        backend: Backend,
        pool: Sequence[Record],
        options: LoopOptions,
        deadline: Deadline | None,
    ) -> None:
        #: The whole run's deadline: every LLM call, every round (grounding and search), the fallback.
        self.deadline = deadline
        self.world, self.names, self.goal = world, world.names, goal
        self.pool, self.options = pool, options
        self.prompt = options.prompt.for_backend(
            backend.prompt_style, getattr(backend, "taught", False), getattr(backend, "spelling", Spelling.UNDERSCORED)
        )
        self.config = planner_config(options.planner, heuristic=options.heuristic)
        self.progress = options.progress or _quiet
        checking = None
        if isinstance(world, GroundedWorld):
            grounded, resolved = self.goal_in(world.scenario)
            checking = (grounded.task, resolved)
        self.asker = _Asker(self.names, backend, options.grammar_retries, self.progress, checking)
        #: What a taught model's plans leave to the check (:mod:`hbtp.train.abridge`).
        self.filled: tuple[str, ...] = tuple(getattr(backend, "filled_predicates", ()))
        self.rounds: list[RoundRecord] = []
        self.llm_seconds = self.planning_seconds = 0.0
        #: The latest round's p̂ and the action predicates and objects of every round so far (the space only grows).
        self.hints = Hints()
        #: The scenario the last round planned in (a part of the world, or all of it) and its result.
        self.scenario: Scenario | None = None
        self.last: PlanResult | None = None
        request = build_request(self.names, str(goal), pool, self.prompt, scenario=world.name)
        self.request = replace(request, resolved=goal)

    def run(self) -> LoopResult:
        for number in range(self.options.feedback_rounds + 1):
            if expired(self.deadline):
                log.info("the time limit ran out before round %d", number)
                break
            result = self.round(number)
            if result is None:
                break
            if result.solved:
                return self.result(Outcome.after(number), result)
        return self.fallback()

    def round(self, number: int) -> PlanResult | None:
        """Ask, check, prune and plan once; ``None`` when the round planned nothing (the asking ends)."""
        if self.last is not None:
            self.request = feedback_request(
                self.request, self.rounds[-1].replies[-1], self.feedback(), self.pool, self.prompt, self.asker.blacklist
            )
        self.progress(f"round {number + 1} of {self.options.feedback_rounds + 1}")
        exchange = self.asker.ask(self.request, self.deadline)
        self.request = exchange.request
        self.llm_seconds += exchange.seconds
        self.planning_seconds += exchange.check_seconds
        if not exchange.replies:
            # Nothing new was said: the space is the last round's (already searched), so the
            # asking ends here and the loop goes to the fallback.
            self.rounds.append(RoundRecord.of(number, exchange, tuple(self.asker.blacklist)))
            return None
        self.hints = self.hints.grown_by(self.unchecked(exchange.hints), self.names)
        if expired(self.deadline):
            log.info("the time limit ran out before round %d could plan", number)
            return None
        started = time.perf_counter()
        try:
            scenario = self.world.part(frozenset(self.hints.predicates), frozenset(self.hints.objects), self.deadline)
        except TimeLimitReached as stop:
            log.info("round %d: %s", number, stop)
            return None
        scenario, goal = self.goal_in(scenario)
        task = scenario.task
        hints = resolve_hints(task, self.hints)
        space = task.restricted(pruned_action_space(task, hints))
        self.progress(f"planning in {len(space)} of {len(self.names.actions)} actions")
        # Declared mutexes speed the rounds up; without a fallback, a failed round's verdict is the
        # answer, so it must not rest on them (confirmed_search re-decides it without them).
        result = (search if self.options.fallback else confirmed_search)(
            task,
            goal,
            space,
            self.config,
            mutexes=scenario.mutexes,
            hints=hints,
            limits=Limits(deadline=within(self.deadline, self.options.round_time_limit)),
        )
        self.planning_seconds += time.perf_counter() - started
        self.scenario = scenario
        self.rounds.append(RoundRecord.of(number, exchange, tuple(self.asker.blacklist), len(space), result))
        self.last = result
        return result

    def unchecked(self, hints: Hints) -> Hints:
        """A taught reply's hints as they prune: where the world is not grounded, its plan is not
        checked (no gap is filled), so the predicates of the actions the adapter leaves to the check
        join the reply's (its objects already name theirs: :mod:`hbtp.train.abridge`)."""
        if self.asker.checking is not None or not self.request.taught or not self.filled:
            return hints
        return replace(hints, predicates=tuple(dict.fromkeys((*hints.predicates, *self.filled))))

    def goal_in(self, scenario: Scenario) -> tuple[Scenario, Goal]:
        """``scenario`` (with the negated twins the goal needs) and the goal in its atoms (a part of a
        world has atoms of its own)."""
        if self.goal.resolved_in(scenario.task):
            return scenario, self.goal
        return scenario.resolve_goal(self.goal)

    def feedback(self) -> Feedback:
        """What the last round's failure tells the model: its longest paths and what its space left out."""
        assert self.last is not None
        assert self.scenario is not None
        actions = [a.signature.underscored for a in self.scenario.task.actions]
        return Feedback(
            tuple(tuple(path) for path in longest_paths(self.last, actions, self.options.top_k)),
            tuple(sorted(set(self.names.action_predicates) - set(self.hints.predicates))),
            tuple(sorted(set(self.names.objects) - set(self.hints.objects))),
        )

    def fallback(self) -> LoopResult:
        """The full action space with the LLM-free heuristic, in the time that is left."""
        if not self.options.fallback:
            return self.result(Outcome.FAILED, self.last or self.no_round())
        if expired(self.deadline):
            message = "the time limit ran out before the fallback"
            if self.last is not None:
                return self.result(Outcome.FAILED, replace(self.last, status=Status.TIMEOUT, message=message))
            return self.result(
                Outcome.FAILED, PlanResult(Status.TIMEOUT, self.options.planner, self.goal, message=message)
            )
        self.progress("fallback: planning in the full action space")
        started = time.perf_counter()
        try:
            whole = self.world.whole(self.deadline)
        except TimeLimitReached as stop:
            timeout = PlanResult(Status.TIMEOUT, self.options.planner, self.goal, message=str(stop))
            return self.result(Outcome.FAILED, timeout)
        whole, goal = self.goal_in(whole)
        self.scenario = whole
        # The fallback prunes with proved mutexes only: declared ones could cut off the only solution.
        final = plan(
            whole.task,
            goal,
            self.options.planner,
            hints=resolve_hints(whole.task, self.hints),
            space=Space.FULL,
            mutexes=whole.mutexes.proved_only(),
            heuristic=self.options.fallback_heuristic,
            limits=Limits(deadline=within(self.deadline, self.options.fallback_time_limit)),
        )
        self.planning_seconds += time.perf_counter() - started
        return self.result(Outcome.FALLBACK if final.solved else Outcome.FAILED, final)

    def no_round(self) -> PlanResult:
        """The result when no round planned and there is no fallback: no verdict, not a proof."""
        error = self.rounds[-1].error if self.rounds else ""
        message = f"no round planned: {error}" if error else "no round ran"
        return PlanResult(Status.NOT_PLANNED, self.options.planner, self.goal, message=message)

    def result(self, outcome: Outcome, final: PlanResult) -> LoopResult:
        scenario = self.scenario or self.world.part(frozenset(), frozenset())
        return LoopResult(outcome, final, tuple(self.rounds), self.llm_seconds, self.planning_seconds, scenario)


def run_hbtp(
    world: Scenario | World,
    goal: Goal | str,
    backend: Backend,
    pool: Sequence[Record] = (),
    options: LoopOptions = LoopOptions(),
    deadline: Deadline | None = None,
) -> LoopResult:
    """Plan ``goal`` with LLM hints, reflective feedback and the full-space fallback, by ``deadline``.

    ``world`` is a grounded scenario, or a :class:`~hbtp.domains.pruned.PrunedWorld` that each round
    grounds only in the pruned space (and whole only for the fallback). The result's ``scenario``
    is the one its tree's actions belong to.
    """
    if isinstance(world, Scenario):
        world = GroundedWorld(world)
    if isinstance(goal, str):  # checked against the world's names, its static facts and its objects
        goal = world.part(frozenset(), frozenset()).resolve_goal(goal)[1]
    return _Loop(world, goal, backend, pool, options, deadline).run()
