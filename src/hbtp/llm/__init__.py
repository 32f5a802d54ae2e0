"""LLM reasoning: prompts, reply parsing, grammar checking, backends."""

from hbtp.llm.parse import ParsedReply, parse_reply

__all__ = ["ParsedReply", "parse_reply"]
