"""What the HBTP loop returns: typed values, serialised to the JSON of ``hbtp plan --json`` and the
benchmarks' rows.

* :class:`Outcome`: solved by an LLM round after k feedback rounds (``NF``, ``1F``, ``2F``, ...), by
  the full-space fallback (``fallback``), or not at all (``failed``).
* :class:`RoundStatus`: how one round ended: its search's :class:`~hbtp.planning.result.Status`,
  or ``skipped`` when the LLM gave no answer to plan with.
* :class:`Exchange`: what one round asked the LLM and was answered, grammar retries included.
* :class:`RoundRecord` and :class:`LoopResult`: the record of a round and of the whole run; API keys
  never reach their JSON (:func:`hbtp.llm.redact.redact`).
"""

from __future__ import annotations

import enum
from dataclasses import dataclass
from typing import Any, ClassVar

from hbtp.domains.scenarios import Scenario
from hbtp.errors import InputError
from hbtp.llm.backend import Reply, Request
from hbtp.llm.grammar import GrammarCheck
from hbtp.llm.redact import redact
from hbtp.planning.hints import Hints
from hbtp.planning.result import PlanResult, Status


class Ending(enum.Enum):
    """Who solved the task: an LLM round, the fallback, or nobody."""

    ROUND = "round"
    FALLBACK = "fallback"
    FAILED = "failed"


@dataclass(frozen=True, slots=True)
class Outcome:
    """How the loop ended; ``feedback_rounds`` is set exactly when an LLM round solved the task."""

    ending: Ending
    feedback_rounds: int | None = None

    FALLBACK: ClassVar[Outcome]
    FAILED: ClassVar[Outcome]

    def __post_init__(self) -> None:
        if (self.ending is Ending.ROUND) != (self.feedback_rounds is not None):
            raise ValueError("feedback_rounds is given exactly when an LLM round solved the task")

    @classmethod
    def after(cls, feedback_rounds: int) -> Outcome:
        """Solved by the LLM round that followed ``feedback_rounds`` feedback rounds."""
        return cls(Ending.ROUND, feedback_rounds)

    @property
    def label(self) -> str:
        """``NF`` (no feedback), ``kF`` (after k feedback rounds), ``fallback`` or ``failed``."""
        if self.feedback_rounds is None:
            return self.ending.value
        return "NF" if self.feedback_rounds == 0 else f"{self.feedback_rounds}F"

    def __str__(self) -> str:
        return self.label

    @classmethod
    def parse(cls, label: str) -> Outcome:
        """The outcome written as ``label`` (a benchmark row read back)."""
        if label == "NF":
            return cls.after(0)
        if label.endswith("F") and label[:-1].isdigit():
            return cls.after(int(label[:-1]))
        try:
            return cls(Ending(label))
        except ValueError:
            raise InputError(f"unknown loop outcome {label!r}") from None


Outcome.FALLBACK = Outcome(Ending.FALLBACK)
Outcome.FAILED = Outcome(Ending.FAILED)


class RoundStatus(enum.Enum):
    """How a round ended: as its search did (:class:`~hbtp.planning.result.Status`), or skipped."""

    SOLVED = Status.SOLVED.value
    UNSOLVABLE = Status.UNSOLVABLE.value
    TIMEOUT = Status.TIMEOUT.value
    NODE_LIMIT = Status.NODE_LIMIT.value
    MEMORY_LIMIT = Status.MEMORY_LIMIT.value
    ERROR = "error"  # the search failed inside (Status.ERROR)
    NOT_PLANNED = Status.NOT_PLANNED.value
    SKIPPED = "skipped"  # the LLM gave no answer, so nothing new was planned

    @classmethod
    def of(cls, status: Status) -> RoundStatus:
        return cls(status.value)

    def __str__(self) -> str:
        return self.value


#: The error of a round that was not asked: the backend had answered the very same question.
REPEATED = "the LLM already answered this very question (temperature 0), so the round cannot help"


def call_record(request: Request, reply: Reply, check: GrammarCheck) -> dict[str, Any]:
    """One backend call as ``--json`` shows it: which request, how long, how many tokens and how
    fast, how it ended, and how many names of the reply were unknown to the domain."""
    tokens = reply.completion_tokens
    rate = reply.meta.get("predicted_per_second")
    if rate is None and tokens and reply.seconds > 0:
        rate = tokens / reply.seconds
    return {
        "round": request.round,
        "attempt": request.attempt,
        "key": request.key(),
        "seconds": round(reply.seconds, 6),
        "prompt_tokens": reply.prompt_tokens,
        "completion_tokens": tokens,
        "tokens_per_second": None if rate is None else round(float(rate), 2),
        "finish_reason": reply.meta.get("finish_reason"),
        "constrained": bool(reply.meta.get("constrained", False)),
        "unknown": len(check.unknown),
    }


@dataclass(frozen=True)
class Exchange:
    """What one round asked and was answered: every request sent (grammar retries included), the
    replies, the grammar check of the last reply, the LLM's time, and its error if it failed."""

    request: Request  # the last request answered (the next round continues the conversation from it)
    prompts: tuple[Request, ...]
    replies: tuple[str, ...]
    check: GrammarCheck | None
    seconds: float
    error: str = ""
    calls: tuple[dict[str, Any], ...] = ()  # one :func:`call_record` per backend call
    #: Seconds spent checking a taught plan beyond the model's calls (its gap searches: planning).
    check_seconds: float = 0.0

    @property
    def hints(self) -> Hints:
        """The checked hints of the last reply (none without a reply)."""
        return self.check.hints if self.check is not None else Hints()

    def prompt_records(self) -> tuple[dict[str, Any], ...]:
        return tuple(
            {
                "key": request.key(),
                "round": request.round,
                "attempt": request.attempt,
                "messages": [{"role": m.role, "content": m.content} for m in request.messages],
                "completion_prompt": request.completion_prompt,
            }
            for request in self.prompts
        )


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
    status: RoundStatus
    explored: int
    llm_seconds: float
    planning_seconds: float
    error: str = ""
    calls: tuple[dict[str, Any], ...] = ()

    @classmethod
    def of(
        cls,
        number: int,
        exchange: Exchange,
        blacklist: tuple[str, ...],
        space: int = 0,
        result: PlanResult | None = None,
    ) -> RoundRecord:
        """The record of round ``number``: planned in an action space of ``space`` actions with
        ``result``, or skipped (no ``result``)."""
        return cls(
            number,
            exchange.prompt_records(),
            exchange.replies,
            exchange.hints,
            exchange.check.repairs if exchange.check is not None else (),
            blacklist,
            space,
            RoundStatus.of(result.status) if result is not None else RoundStatus.SKIPPED,
            result.stats.explored if result is not None else 0,
            exchange.seconds,
            result.stats.time_s if result is not None else 0.0,
            exchange.error,
            exchange.calls,
        )

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
            "status": self.status.value,
            "explored": self.explored,
            "llm_seconds": round(self.llm_seconds, 6),
            "planning_seconds": round(self.planning_seconds, 6),
            "error": redact(self.error),
            "calls": [dict(call) for call in self.calls],
        }


@dataclass(frozen=True)
class LoopResult:
    outcome: Outcome
    result: PlanResult
    rounds: tuple[RoundRecord, ...]
    llm_seconds: float
    planning_seconds: float
    #: The scenario the result's tree belongs to: the world's, or the part of it the last round grounded.
    scenario: Scenario

    @property
    def solved(self) -> bool:
        return self.result.solved

    @property
    def space_hints(self) -> Hints | None:
        """The hints whose pruned space the tree was planned in (the solving round's); ``None`` when
        no round solved the task (the fallback searched the full space)."""
        if self.outcome.ending is not Ending.ROUND or not self.rounds:
            return None
        return self.rounds[-1].hints

    def to_dict(self) -> dict[str, Any]:
        return {
            "outcome": self.outcome.label,
            "llm_seconds": round(self.llm_seconds, 6),
            "planning_seconds": round(self.planning_seconds, 6),
            "llm_calls": sum(len(r.calls) for r in self.rounds),
            "rounds": [r.to_dict() for r in self.rounds],
        }
