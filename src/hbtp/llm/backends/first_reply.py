"""Replay recorded LLM outputs given as dataset records: each record's plan, predicates and objects
become the first-round reply for its goal (``hbtp bench table2 --hints-from FILE``). Later rounds go
to ``then`` (another backend) or fail, which sends the loop to its fallback."""

from __future__ import annotations

import time

from hbtp.datasets.records import Record
from hbtp.errors import BackendError
from hbtp.llm.backend import Backend, PromptStyle, Reply, Request
from hbtp.logic.atoms import parse_conjunction


def _goal_key(goal: str) -> frozenset[str]:
    return frozenset(str(a) for a in parse_conjunction(goal))


class FirstReplyBackend:
    def __init__(self, records: list[Record], then: Backend | None = None) -> None:
        self.name = "hints-from" + (f"+{then.name}" if then is not None else "")
        self.replies: dict[frozenset[str], str] = {}
        for record in records:
            self.replies.setdefault(_goal_key(record.goal), record.reply_block())
        self.then = then

    @property
    def prompt_style(self) -> PromptStyle:
        """The style of the backend that answers the later rounds (chat without one)."""
        return self.then.prompt_style if self.then is not None else PromptStyle.CHAT

    def complete(self, request: Request) -> Reply:
        if request.round == 0 and request.attempt == 0:
            text = self.replies.get(_goal_key(request.goal))
            if text is None:
                raise BackendError(f"no recorded reply for goal {request.goal!r}")
            return Reply(text, 0.0, meta={"replayed": True})
        if self.then is None:
            raise BackendError("recorded replies cover the first round only (give --llm for feedback rounds)")
        started = time.perf_counter()
        reply = self.then.complete(request)
        return Reply(
            reply.text, reply.seconds or time.perf_counter() - started, reply.prompt_tokens, reply.completion_tokens
        )

    def close(self) -> None:
        if self.then is not None:
            self.then.close()
