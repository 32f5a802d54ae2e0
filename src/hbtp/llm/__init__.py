"""LLM reasoning: prompts, reply parsing, grammar checking, backends (issue in progress)."""

from hbtp.llm.parse import ParsedReply, parse_reply

__all__ = ["ParsedReply", "parse_reply"]
