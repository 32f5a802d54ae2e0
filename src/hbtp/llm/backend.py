"""The one small interface every LLM backend implements.

A :class:`Request` carries the conversation in two shapes: ``messages`` (system/user/assistant turns,
for chat models and OpenAI-compatible servers) and ``completion_prompt`` (one plain text ending in
``Optimal Actions:``, for base models such as the local Gemma-3 270M, which continue text rather than
follow instructions). A backend uses whichever suits it and returns a :class:`Reply`.

``goal`` and ``scenario`` travel along for backends that do not need a prompt at all (the oracles).

Each backend declares the :class:`PromptStyle` it reads (``prompt_style``); the prompt builder
shapes its defaults by it (a completion reply is cut shorter).
"""

from __future__ import annotations

import enum
import hashlib
import json
from dataclasses import dataclass, field
from typing import Any, Protocol

from hbtp.deadline import Deadline
from hbtp.llm.constrain import Constraint
from hbtp.llm.spelling import Spelling
from hbtp.logic.goal import Goal


class PromptStyle(enum.Enum):
    """Which shape of a :class:`Request` a backend reads."""

    CHAT = "chat"  # ``messages``: chat models and OpenAI-compatible chat endpoints
    COMPLETION = "completion"  # ``completion_prompt``: base models that continue text


@dataclass(frozen=True)
class Message:
    role: str  # "system", "user" or "assistant"
    content: str


@dataclass(frozen=True)
class Request:
    """One question to the model."""

    messages: tuple[Message, ...]
    completion_prompt: str
    goal: str = ""
    scenario: str = ""
    round: int = 0  # 0: first answer; 1, 2, ...: reflective feedback rounds; grammar retries keep the round
    attempt: int = 0  # grammar-check retries within a round
    max_tokens: int = 256
    temperature: float = 0.0
    seed: int = 0
    stop: tuple[str, ...] = ()
    #: When this one call must be over (the command's deadline, capped for the call), or ``None``; a
    #: backend that can stops by then (the OpenAI backend by this or its own timeout, if sooner).
    deadline: Deadline | None = field(default=None, compare=False, repr=False)
    #: The reply's grammar and JSON schema (constrained decoding), or ``None``: free text.
    constraint: Constraint | None = None
    #: The instruction a goal is asked for (:mod:`hbtp.llm.goal_prompt`), for the instruction oracle.
    instruction: str = ""
    #: ``goal`` as the loop resolved it (bookkeeping, like ``round``): an oracle that plans in the
    #: same task answers from it instead of reading the text again.
    resolved: Goal | None = field(default=None, compare=False, repr=False)
    #: The completion prompt is the short one of a model taught the world (a local adapter answers
    #: it; a few-shot prompt is answered by the base model alone).
    taught: bool = False
    #: How the plan a taught model answers spells its actions (its adapter's): the prompt's plan so
    #: far and the grammar are spelled so; the backend gives the reply back in the datasets' spelling.
    spelling: Spelling = Spelling.UNDERSCORED

    def key(self) -> str:
        """A stable hash of what the model is asked (for record/replay).

        Only the question itself counts: the conversation, the completion prompt, the temperature
        and the seed. ``max_tokens`` and ``stop`` are left out: they are defaults of the prompt
        style (chat or completion) rather than part of the question, so a run recorded with one
        backend replays with another; ``round``, ``attempt`` and ``deadline`` are bookkeeping.
        The ``constraint`` is left out too: it is a function of the scenario and only narrows the
        replies, so files recorded with or without it replay either way (a replayed free-text reply
        goes through the grammar checker like any other).
        """
        payload = {
            "messages": [[m.role, m.content] for m in self.messages],
            "completion_prompt": self.completion_prompt,
            "temperature": self.temperature,
            "seed": self.seed,
        }
        return _digest(payload)

    def sent_key(self, style: PromptStyle) -> str:
        """A hash of what a backend of ``style`` is sent: two requests with the same one get the
        same greedy answer, so the second need not be sent (a completion backend never sees the
        chat turns, a chat backend never sees the completion prompt)."""
        payload = {
            "prompt": self.completion_prompt
            if style is PromptStyle.COMPLETION
            else [[m.role, m.content] for m in self.messages],
            "temperature": self.temperature,
            "seed": self.seed,
            "constraint": None if self.constraint is None else self.constraint.gbnf,
            "max_tokens": self.max_tokens,
            "stop": list(self.stop),
        }
        return _digest(payload)


def _digest(payload: dict[str, Any]) -> str:
    return hashlib.sha256(json.dumps(payload, sort_keys=True).encode()).hexdigest()


@dataclass(frozen=True)
class Reply:
    """The model's answer and what it cost."""

    text: str
    seconds: float = 0.0
    prompt_tokens: int | None = None
    completion_tokens: int | None = None
    meta: dict[str, Any] = field(default_factory=dict)


class Backend(Protocol):
    """An LLM: ``complete`` answers a request or raises :class:`hbtp.errors.BackendError`."""

    name: str

    @property
    def prompt_style(self) -> PromptStyle:
        """The shape of request this backend reads (a wrapper: its inner backend's)."""
        ...

    def complete(self, request: Request) -> Reply: ...

    def close(self) -> None: ...
