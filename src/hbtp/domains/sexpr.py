"""A small s-expression reader that remembers where every token stands (for PDDL error messages)."""

from __future__ import annotations

import logging
import re
from dataclasses import dataclass

from hbtp.deadline import Deadline
from hbtp.errors import PddlError


@dataclass(frozen=True, slots=True)
class Symbol:
    """A token with its position (1-based line and column)."""

    text: str
    line: int
    column: int

    @property
    def lower(self) -> str:
        return self.text.lower()


@dataclass(frozen=True, slots=True)
class SList:
    """A parenthesised list with the position of its opening parenthesis."""

    items: tuple[Expr, ...]
    line: int
    column: int

    def head(self) -> str:
        """The lower-cased first symbol, or '' when the list is empty or starts with a list."""
        if self.items and isinstance(self.items[0], Symbol):
            return self.items[0].lower
        return ""


Expr = Symbol | SList


#: Deepest nesting of parentheses accepted. Real PDDL nests a few levels; the readers and the grounder
#: walk formulas recursively, so a deeper file is refused with its position instead of overflowing.
MAX_NESTING = 100

_TOKEN = re.compile(r"[()]|[^\s();]+")
_BOM = "\ufeff"

log = logging.getLogger(__name__)


def _split_variables(token: str, line: int, column: int, source: str) -> list[Symbol]:
    """``name?var`` run together, as Fast Downward's tokenizer reads it: ``name ?var`` (with a warning)."""
    parts = [part for part in token.replace("?", " ?").split(" ") if part]
    log.warning("%s:%d:%d: %r read as %r (a missing space)", source, line, column, token, " ".join(parts))
    symbols: list[Symbol] = []
    offset = 0
    for part in parts:
        offset = token.index(part, offset)
        symbols.append(Symbol(part, line, column + offset))
        offset += len(part)
    return symbols


def parse_sexprs(text: str, source: str = "<string>", deadline: Deadline | None = None) -> list[Expr]:
    """Read every top-level expression of ``text`` (a leading UTF-8 byte-order mark is skipped).

    Past ``deadline`` it raises :class:`~hbtp.deadline.TimeLimitReached`."""
    stack: list[tuple[list[Expr], int, int]] = []
    top: list[Expr] = []
    if text.startswith(_BOM):
        text = text[1:]
    nul = text.find("\0")
    if nul >= 0:
        where = text.count("\n", 0, nul) + 1, nul - text.rfind("\n", 0, nul)
        raise PddlError("a NUL byte: not a text file", source, *where)
    current = top
    for line_number, line in enumerate(text.split("\n"), start=1):
        if deadline is not None and line_number & 1023 == 0:
            deadline.check("reading the PDDL files")
        comment = line.find(";")
        if comment >= 0:
            line = line[:comment]
        for match in _TOKEN.finditer(line):
            token = match.group()
            column = match.start() + 1
            if token == "(":
                if len(stack) >= MAX_NESTING:
                    raise PddlError(f"parentheses nested deeper than {MAX_NESTING} levels", source, line_number, column)
                stack.append((current, line_number, column))
                current = []
            elif token == ")":
                if not stack:
                    raise PddlError("unbalanced ')'", source, line_number, column)
                outer, open_line, open_column = stack.pop()
                outer.append(SList(tuple(current), open_line, open_column))
                current = outer
            elif "?" in token[1:]:
                current.extend(_split_variables(token, line_number, column, source))
            else:
                current.append(Symbol(token, line_number, column))
    if stack:
        _, open_line, open_column = stack[-1]
        raise PddlError("'(' is never closed", source, open_line, open_column)
    return top
