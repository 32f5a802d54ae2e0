"""Goal formulas: ``and``, ``or`` and ``not`` over literals, read into disjunctive normal form.

Two syntaxes are read:

* infix, the datasets' style: ``IsIn_milk_fridge & ~IsOpen_fridge | IsOn_milk_table`` (``~`` binds
  tightest, then ``&``, then ``|``; parentheses group: ``(A | B) & C``);
* PDDL: ``(and (in milk fridge) (not (open fridge)))`` with ``and``, ``or``, ``not`` and ``imply``.

Both give the same value: a tuple of *terms* (conjunctions of literals, :class:`~hbtp.logic.atoms.Atom`
with ``negated`` for ``~``), one per disjunct, in the order written, without repeated literals or
terms. Negations are pushed down to the literals (De Morgan) before the product is taken; a formula
whose normal form would have more than :data:`MAX_TERMS` terms, or that nests parentheses and
negations more than :data:`MAX_DEPTH` deep, is refused. What the literals mean
(unknown names, contradictions, literals that can never hold) is decided against a task by
:meth:`hbtp.logic.task.GroundTask.resolve_goal`.
"""

from __future__ import annotations

import re
from collections.abc import Iterator, Sequence
from dataclasses import dataclass
from itertools import chain, product
from typing import ClassVar

from hbtp.errors import InputError
from hbtp.logic.atoms import Atom, parse_atom

#: The most disjuncts a goal may have once in normal form.
MAX_TERMS = 256
#: The deepest a goal may nest parentheses and ``not`` (a run of ``~`` counts once).
MAX_DEPTH = 100

Term = tuple[Atom, ...]
Dnf = tuple[Term, ...]

_TOKEN = re.compile(r"\s*(?:([A-Za-z][A-Za-z0-9_\-]*)|(\S))")
_SHOWN = 60
_PDDL_START = re.compile(r"\s*\(\s*[A-Za-z][A-Za-z0-9_\-]*(\s|\)|$)")  # "(and ...", "(on a)", not "(on(a))"


@dataclass(frozen=True, slots=True)
class _Op:
    """A connective over sub-formulas: ``and``, ``or`` or ``not`` (one operand)."""

    kind: str
    parts: tuple[_Formula, ...]


_Formula = Atom | _Op


@dataclass(frozen=True)
class GoalFormula:
    """A goal read once, before any task: its terms (disjunctive normal form) as written. Resolve it
    against each task it is planned in (:func:`hbtp.logic.resolve.resolve_goal`); it is never parsed
    again."""

    terms: Dnf

    @classmethod
    def parse(cls, text: str) -> GoalFormula:
        """The goal of ``text`` in either syntax (see :func:`parse_goal`)."""
        return cls(parse_goal(text))

    def __str__(self) -> str:
        return format_goal(self.terms)


def parse_goal(text: str) -> Dnf:
    """The terms of a goal text in either syntax (see the module docstring); :class:`InputError` on
    anything malformed, quoting where it went wrong."""
    if not text.strip():
        raise InputError("empty goal")
    if _PDDL_START.match(text) and not any(c in text for c in "&|~,"):
        formula = _PddlReader(text).read()
    else:
        formula = _InfixReader(text).read()
    return to_dnf(formula)


def format_goal(terms: Sequence[Term]) -> str:
    """The infix text of ``terms`` (``A & ~B | C``), in the datasets' spelling."""
    return " | ".join(" & ".join(atom.underscored for atom in term) for term in terms)


def to_dnf(formula: _Formula) -> Dnf:
    """The disjunctive normal form of ``formula``: terms without repeats, in order."""
    terms = _dnf(_nnf(formula, False))
    return tuple(dict.fromkeys(tuple(dict.fromkeys(term)) for term in terms))


def _nnf(formula: _Formula, negate: bool) -> _Formula:
    """``formula`` (negated when ``negate``) with every ``not`` moved onto a literal."""
    if isinstance(formula, Atom):
        return formula.negate() if negate else formula
    if formula.kind == "not":
        return _nnf(formula.parts[0], not negate)
    kind = formula.kind
    if negate:
        kind = "or" if kind == "and" else "and"
    return _Op(kind, tuple(_nnf(part, negate) for part in formula.parts))


def _dnf(formula: _Formula) -> list[Term]:
    if isinstance(formula, Atom):
        return [(formula,)]
    parts = [_dnf(part) for part in formula.parts]
    count = sum(map(len, parts)) if formula.kind == "or" else 1
    if formula.kind == "and":
        for part in parts:
            count *= len(part)
            if count > MAX_TERMS:
                break
    if count > MAX_TERMS:
        raise InputError(f"the goal has more than {MAX_TERMS} alternatives once in disjunctive normal form")
    if formula.kind == "or":
        return [term for part in parts for term in part]
    # each term joined once from its pieces: linear in the goal's length
    return [tuple(chain.from_iterable(pieces)) for pieces in product(*parts)]


class _Tokens:
    """The tokens of a goal text: names and single characters, with their positions."""

    def __init__(self, text: str) -> None:
        self.text = text
        self.items: list[tuple[str, int]] = []
        for match in _TOKEN.finditer(text):
            token = match.group(1) or match.group(2)
            if token:
                self.items.append((token, match.start(1) if match.group(1) else match.start(2)))
        self.index = 0
        self.depth = 0

    def enter(self) -> None:
        """One level deeper (a parenthesis or a negation); past :data:`MAX_DEPTH`, an error."""
        self.depth += 1
        if self.depth > MAX_DEPTH:
            raise self.error(f"nested more than {MAX_DEPTH} deep")

    def leave(self) -> None:
        self.depth -= 1

    def peek(self) -> str | None:
        return self.items[self.index][0] if self.index < len(self.items) else None

    def take(self) -> str:
        token = self.peek()
        if token is None:
            raise self.error("the goal ends too early")
        self.index += 1
        return token

    def expect(self, token: str) -> None:
        if self.peek() != token:
            raise self.error(f"expected {token!r}")
        self.index += 1

    def error(self, what: str) -> InputError:
        position = self.items[self.index][1] if self.index < len(self.items) else len(self.text)
        shown = self.text.strip()
        shown = shown if len(shown) <= _SHOWN else shown[:_SHOWN] + "..."
        return InputError(f"malformed goal {shown!r}: {what} at character {position + 1}")

    def finish(self) -> None:
        if self.peek() is not None:
            raise self.error(f"unexpected {self.peek()!r}")


class _InfixReader:
    """``expr := term ('|' term)*``, ``term := factor ('&' factor)*``,
    ``factor := '~' factor | '(' expr ')' | literal``."""

    def __init__(self, text: str) -> None:
        self.tokens = _Tokens(text)

    def read(self) -> _Formula:
        formula = self.expression()
        self.tokens.finish()
        return formula

    def expression(self) -> _Formula:
        parts = [self.term()]
        while self.tokens.peek() == "|":
            self.tokens.take()
            parts.append(self.term())
        return parts[0] if len(parts) == 1 else _Op("or", tuple(parts))

    def term(self) -> _Formula:
        parts = [self.factor()]
        while self.tokens.peek() == "&":
            self.tokens.take()
            parts.append(self.factor())
        return parts[0] if len(parts) == 1 else _Op("and", tuple(parts))

    def factor(self) -> _Formula:
        tokens = self.tokens
        negations = 0
        while tokens.peek() == "~":  # a run of negations, read without recursion
            tokens.take()
            negations += 1
        if negations:
            tokens.enter()
            inner = self.factor()
            tokens.leave()
            return _Op("not", (inner,)) if negations % 2 else inner
        token = tokens.peek()
        if token == "(":
            tokens.take()
            tokens.enter()
            inner = self.expression()
            tokens.expect(")")
            tokens.leave()
            return inner
        if token is None or not token[0].isalpha():
            raise tokens.error("expected a literal" if token is None else f"unexpected {token!r}")
        name = tokens.take()
        if tokens.peek() != "(":
            return parse_atom(name)
        tokens.take()
        args: list[str] = []
        while tokens.peek() != ")":
            if args:
                tokens.expect(",")
            arg = tokens.take()
            if not arg[0].isalpha():
                raise tokens.error(f"unexpected {arg!r} in the arguments of {name}")
            args.append(arg)
        tokens.take()
        return Atom(name, tuple(args))


class _PddlReader:
    """``(and F...)``, ``(or F...)``, ``(not F)``, ``(imply F G)`` and ``(pred obj...)``."""

    _ARITY: ClassVar[dict[str, int]] = {"not": 1, "imply": 2}

    def __init__(self, text: str) -> None:
        self.tokens = _Tokens(text)

    def read(self) -> _Formula:
        formula = self.formula()
        self.tokens.finish()
        return formula

    def formula(self) -> _Formula:
        tokens = self.tokens
        tokens.expect("(")
        tokens.enter()
        formula = self._inside()
        tokens.leave()
        return formula

    def _inside(self) -> _Formula:
        tokens = self.tokens
        head = tokens.take()
        if not head[0].isalpha():
            raise tokens.error(f"unexpected {head!r}")
        keyword = head.lower()
        if keyword in ("and", "or", "not", "imply"):
            parts = tuple(self._operands())
            wanted = self._ARITY.get(keyword)
            if wanted is not None and len(parts) != wanted:
                raise tokens.error(f"({keyword} ...) takes {wanted} condition(s)")
            if keyword == "imply":
                return _Op("or", (_Op("not", (parts[0],)), parts[1]))
            return _Op(keyword, parts)
        args: list[str] = []
        while tokens.peek() != ")":
            arg = tokens.take()
            if not arg[0].isalpha():
                raise tokens.error(f"unexpected {arg!r} in ({head} ...)")
            args.append(arg)
        tokens.take()
        return Atom(head, tuple(args)) if args or "_" not in head else parse_atom(head)

    def _operands(self) -> Iterator[_Formula]:
        while self.tokens.peek() != ")":
            if self.tokens.peek() is None:
                raise self.tokens.error("the goal ends too early")
            yield self.formula()
        self.tokens.take()


__all__ = ["MAX_DEPTH", "MAX_TERMS", "Dnf", "GoalFormula", "Term", "format_goal", "parse_goal", "to_dnf"]
