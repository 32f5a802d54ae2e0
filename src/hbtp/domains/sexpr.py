"""A small s-expression reader that remembers where every token stands (for PDDL error messages)."""

from __future__ import annotations

from dataclasses import dataclass

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


def parse_sexprs(text: str, source: str = "<string>") -> list[Expr]:
    """Read every top-level expression of ``text``."""
    stack: list[tuple[list[Expr], int, int]] = []
    top: list[Expr] = []
    line, column = 1, 1
    index = 0
    length = len(text)
    while index < length:
        char = text[index]
        if char == ";":
            while index < length and text[index] != "\n":
                index += 1
            continue
        if char == "\n":
            line += 1
            column = 1
            index += 1
            continue
        if char.isspace():
            column += 1
            index += 1
            continue
        if char == "(":
            stack.append(([], line, column))
            column += 1
            index += 1
            continue
        if char == ")":
            if not stack:
                raise PddlError("unbalanced ')'", source, line, column)
            items, open_line, open_column = stack.pop()
            node = SList(tuple(items), open_line, open_column)
            (stack[-1][0] if stack else top).append(node)
            column += 1
            index += 1
            continue
        start_column = column
        start = index
        while index < length and not text[index].isspace() and text[index] not in "();":
            index += 1
        column += index - start
        token = Symbol(text[start:index], line, start_column)
        (stack[-1][0] if stack else top).append(token)
    if stack:
        _, open_line, open_column = stack[-1]
        raise PddlError("'(' is never closed", source, open_line, open_column)
    return top
