"""The forms of PDDL both files share: names, typed lists, formulas, effects and costs, read from
s-expressions with their file, line and column for every message (:class:`FormReader`), in the
scope of the predicates, functions and names declared so far (:class:`Scope`).

:mod:`hbtp.domains.pddl_reader` reads whole domain and problem files with them.
"""

from __future__ import annotations

import logging
import re
from collections.abc import Iterable

from hbtp.deadline import Deadline
from hbtp.domains.lifted import (
    MAX_ACTION_COST,
    OBJECT_TYPE,
    AddEffect,
    And,
    AndEffect,
    AtomFormula,
    CostEffect,
    DeleteEffect,
    Effect,
    Equals,
    Exists,
    Forall,
    ForallEffect,
    Formula,
    Imply,
    Not,
    Or,
    TypedName,
    WhenEffect,
    is_variable,
)
from hbtp.domains.sexpr import Expr, SList, Symbol, parse_sexprs
from hbtp.errors import PddlError
from hbtp.logic.task import did_you_mean

SUPPORTED_REQUIREMENTS = frozenset(
    {
        ":strips",
        ":typing",
        ":equality",
        ":action-costs",
        ":negative-preconditions",
        ":disjunctive-preconditions",
        ":existential-preconditions",
        ":universal-preconditions",
        ":quantified-preconditions",
        ":conditional-effects",
        ":adl",
    }
)
#: A whole number as PDDL writes it: ASCII digits with an optional sign (Python's ``int`` would also
#: take ``1_0``, ``٣`` or surrounding spaces).
_WHOLE_NUMBER = re.compile(r"[+-]?[0-9]+")
_NAME = re.compile(r"[A-Za-z][A-Za-z0-9_\-]*\Z")  # what goals and trees can write and read back
UNSUPPORTED_SECTIONS = {
    ":derived": "derived predicates",
    ":durative-action": "durative actions",
    ":constraints": "constraints",
    ":process": "processes",
    ":event": "events",
}


log = logging.getLogger(__name__)


class FormReader:
    """Shared state while reading one file: its name, and where each type name is first written, for messages."""

    def __init__(self, source: str, deadline: Deadline | None = None) -> None:
        self.source = source
        self.deadline = deadline
        self.type_uses: dict[str, Symbol] = {}
        self.declared_types: set[str] | None = None  # known once the domain's types are read
        self.type_names: dict[str, str] = {OBJECT_TYPE: OBJECT_TYPE}  # lower case -> first spelling

    def warn(self, message: str, where: Expr) -> None:
        log.warning("%s:%d:%d: %s", self.source, where.line, where.column, message)

    def fail(self, message: str, where: Expr | None) -> PddlError:
        if where is None:
            return PddlError(message, self.source)
        return PddlError(message, self.source, where.line, where.column)

    # ------------------------------------------------------------- helpers
    def expect_list(self, expr: Expr, what: str) -> SList:
        if not isinstance(expr, SList):
            raise self.fail(f"expected {what}, found {expr.text!r}", expr)
        return expr

    def expect_symbol(self, expr: Expr, what: str) -> Symbol:
        if not isinstance(expr, Symbol):
            raise self.fail(f"expected {what}, found a list", expr)
        return expr

    def expect_name(self, expr: Expr, what: str) -> Symbol:
        """A symbol that names something hbtp writes into goals and trees and reads back: a letter,
        then letters, digits, ``-`` or ``_`` (``?`` first for a variable), as PDDL defines names."""
        symbol = self.expect_symbol(expr, what)
        if not _NAME.match(symbol.text.removeprefix("?")):
            shown = symbol.text if len(symbol.text) <= 60 else symbol.text[:60] + "..."
            raise self.fail(
                f"{shown!r} is not a PDDL name (a letter, then letters, digits, '-' or '_'): {what}", symbol
            )
        return symbol

    def define(self, text: str, kind: str) -> tuple[str, list[Expr], SList]:
        exprs = parse_sexprs(text, self.source, self.deadline)
        if not exprs:
            what = "is empty" if not text.strip() else "holds only comments"
            raise PddlError(f"the file {what}: expected (define ({kind} NAME) ...)", self.source, 1, 1)
        if len(exprs) != 1:
            raise self.fail("expected exactly one (define ...) form", exprs[1])
        top = self.expect_list(exprs[0], "(define ...)")
        if top.head() != "define" or len(top.items) < 2:
            raise self.fail("expected (define ...)", top)
        header = self.expect_list(top.items[1], f"({kind} NAME)")
        if header.head() != kind or len(header.items) != 2:
            raise self.fail(f"expected ({kind} NAME)", header)
        name = self.expect_symbol(header.items[1], f"{kind} name").text
        return name, list(top.items[2:]), top

    def typed_list(self, items: tuple[Expr, ...], variables: bool, keep_twice: bool = False) -> list[TypedName]:
        """Read ``a b - t c - (either u v) d``.

        A name declared twice (case-insensitively) is read once with a warning when both have the same
        type, and refused otherwise; with ``keep_twice`` (a predicate's parameters, which only count)
        both are kept."""
        result: list[TypedName] = []
        seen: dict[str, TypedName] = {}
        for symbol, typed in self.typed_symbols(items, variables):
            first = seen.setdefault(typed.name.lower(), typed)
            if first is typed or keep_twice:
                result.append(typed)
            elif first.types != typed.types:
                raise self.fail(f"{first.name!r} is declared twice, with different types", symbol)
            if first is not typed:
                self.warn(f"{first.name!r} is declared twice", symbol)
        return result

    def typed_symbols(self, items: tuple[Expr, ...], variables: bool) -> list[tuple[Symbol, TypedName]]:
        """Every name of a typed list with its type(s) and where it is written, duplicates included."""
        result: list[tuple[Symbol, TypedName]] = []
        pending: list[Symbol] = []
        index = 0
        while index < len(items):
            item = items[index]
            if isinstance(item, Symbol) and item.text == "-":
                if not pending or index + 1 >= len(items):
                    raise self.fail("'-' must stand between names and a type", item)
                types = self.type_spec(items[index + 1])
                result.extend((s, TypedName(s.text, types)) for s in pending)
                pending = []
                index += 2
                continue
            symbol = self.expect_name(item, "a name")
            if variables != is_variable(symbol.text):
                kind = "a variable (?x)" if variables else "a name without '?'"
                raise self.fail(f"expected {kind}, found {symbol.text!r}", symbol)
            pending.append(symbol)
            index += 1
        result.extend((s, TypedName(s.text)) for s in pending)
        return result

    def type_spec(self, expr: Expr) -> tuple[str, ...]:
        if isinstance(expr, Symbol):
            symbols = [expr]
        elif expr.head() != "either" or len(expr.items) < 2:
            raise self.fail("expected a type or (either t1 t2 ...)", expr)
        else:
            symbols = [self.expect_symbol(e, "a type") for e in expr.items[1:]]
        names = tuple(self.type_names.setdefault(symbol.lower, symbol.text) for symbol in symbols)
        for name, symbol in zip(names, symbols, strict=True):
            self.type_uses.setdefault(name, symbol)
        return names

    def number(self, symbol: Symbol, what: str = "") -> int:
        """A whole number written in ASCII digits, at most :data:`MAX_ACTION_COST` in size."""
        text = symbol.text
        if _WHOLE_NUMBER.fullmatch(text) is None:
            raise self.fail(f"{what}{text[:40]!r} is not a whole number", symbol)
        digits = text.lstrip("+-").lstrip("0")
        if len(digits) > len(str(MAX_ACTION_COST)) or int(text) > MAX_ACTION_COST or int(text) < -MAX_ACTION_COST:
            shown = text if len(text) <= 20 else f"{text[:12]}... ({len(digits)} digits)"
            raise self.fail(f"{what}{shown} is too large (at most {MAX_ACTION_COST})", symbol)
        return int(text)

    def check_types(self, names: Iterable[TypedName], what: str, declared: set[str]) -> None:
        """Reject a type that is not declared, pointing at the first place it is written."""
        for typed in names:
            for t in typed.types:
                if t not in declared:
                    raise self.fail(f"{what}unknown type {t!r} (of {typed.name!r})", self.type_uses.get(t))

    # ------------------------------------------------------------ formulas
    def formula(self, expr: Expr, context: Scope) -> Formula:
        node = self.expect_list(expr, "a condition")
        head = self.keyword(node, context)
        args = node.items[1:]
        if head == "and":
            return And(tuple(self.formula(a, context) for a in args), node.line)
        if head == "or":
            return Or(tuple(self.formula(a, context) for a in args), node.line)
        if head == "not":
            if len(args) != 1:
                raise self.fail("(not ...) takes one condition", node)
            return Not(self.formula(args[0], context), node.line)
        if head == "imply":
            if len(args) != 2:
                raise self.fail("(imply A B) takes two conditions", node)
            return Imply(self.formula(args[0], context), self.formula(args[1], context), node.line)
        if head == "=":
            if len(args) != 2:
                raise self.fail("(= a b) takes two terms", node)
            left, right = (self.term(a, context) for a in args)
            return Equals(left, right, node.line)
        if head in ("exists", "forall"):
            return self.quantified(node, context, Exists if head == "exists" else Forall)
        if head in ("<", ">", "<=", ">="):
            raise self.fail(f"numeric conditions ({head}) are not supported", node)
        return self.atom(node, context)

    def quantified(self, node: SList, context: Scope, kind: type[Exists] | type[Forall]) -> Formula:
        """``(exists (?v - t ...) body)`` or ``(forall ...)``, its variables in scope in ``body``."""
        args = node.items[1:]
        word = "exists" if kind is Exists else "forall"
        if len(args) != 2:
            raise self.fail(f"({word} (?vars) condition) takes two parts", node)
        variables = self.typed_list(self.expect_list(args[0], "(?vars)").items, variables=True)
        if not variables:
            raise self.fail(f"({word} ...) binds no variable", node)
        if self.declared_types is not None:
            self.check_types(variables, "", self.declared_types)
        return kind(tuple(variables), self.formula(args[1], context.extended(variables)), node.line)

    def keyword(self, node: SList, context: Scope) -> str:
        """The lower-cased head of ``node``, or '' when it names a declared predicate.

        PDDL keywords are case-insensitive, so a predicate called ``Exists`` would read as the
        quantifier; a declared predicate name always wins.
        """
        first = node.items[0] if node.items else None
        if isinstance(first, Symbol) and first.text in context.predicates:
            return ""
        return node.head()

    def atom(self, node: SList, context: Scope) -> AtomFormula:
        if not node.items:
            raise self.fail("empty condition ()", node)
        name = context.predicate(self.expect_symbol(node.items[0], "a predicate"), node, self)
        terms = tuple(self.term(t, context) for t in node.items[1:])
        context.check_atom(name, terms, node, self)
        return AtomFormula(name, terms, node.line)

    def term(self, expr: Expr, context: Scope) -> str:
        symbol = self.expect_symbol(expr, "a variable or object")
        return context.term(symbol, self)

    # ------------------------------------------------------------- effects
    def effect(self, expr: Expr, context: Scope) -> Effect:
        node = self.expect_list(expr, "an effect")
        head = self.keyword(node, context)
        args = node.items[1:]
        if head == "and":
            return AndEffect(tuple(self.effect(a, context) for a in args))
        if head == "not":
            if len(args) != 1:
                raise self.fail("(not ...) takes one atom", node)
            inner = self.expect_list(args[0], "an atom")
            inner_head = self.keyword(inner, context)
            if inner_head in ("and", "or", "not", "forall", "when", "="):
                raise self.fail(f"(not ({inner_head} ...)) is not an effect", inner)
            return DeleteEffect(self.atom(inner, context))
        if head == "forall":
            if len(args) != 2:
                raise self.fail("(forall (?vars) effect) takes two parts", node)
            variables = self.typed_list(self.expect_list(args[0], "(?vars)").items, variables=True)
            if self.declared_types is not None:
                self.check_types(variables, "", self.declared_types)
            scope = context.extended(variables)
            return ForallEffect(tuple(variables), self.effect(args[1], scope), node.line)
        if head == "when":
            if len(args) != 2:
                raise self.fail("(when condition effect) takes two parts", node)
            condition, body = self.formula(args[0], context), self.effect(args[1], context)
            return WhenEffect(condition, body, node.line, node.column)
        if head == "increase":
            return self.cost_effect(node, context)
        if head in ("decrease", "assign", "scale-up", "scale-down"):
            raise self.fail(f"numeric effect ({head}) is not supported (only increase total-cost)", node)
        if head == "=":
            raise self.fail("(= ...) is not an effect", node)
        return AddEffect(self.atom(node, context))

    def cost_effect(self, node: SList, context: Scope) -> CostEffect:
        if len(node.items) != 3:
            raise self.fail("expected (increase (total-cost) AMOUNT)", node)
        target = self.expect_list(node.items[1], "(total-cost)")
        if target.head() != "total-cost" or len(target.items) != 1:
            raise self.fail("only (increase (total-cost) ...) is supported", target)
        amount = node.items[2]
        if isinstance(amount, Symbol):
            value = self.number(amount, "cost ")
            if value < 0:
                raise self.fail("action costs must not be negative", amount)
            return CostEffect(value, node.line)
        symbol = self.expect_symbol(amount.items[0], "a function") if amount.items else None
        name = context.function_names.get(symbol.lower) if symbol is not None else None
        if name is None:
            raise self.fail("cost must be a number or a declared static function", amount)
        terms = tuple(self.term(t, context) for t in amount.items[1:])
        if len(terms) != len(context.functions[name]):
            raise self.fail(f"function {name!r} takes {len(context.functions[name])} argument(s)", amount)
        return CostEffect(AtomFormula(name, terms, amount.line), node.line)


class Scope:
    """Names visible in a formula: predicates, constants/objects, bound variables.

    ``names`` and ``variables`` map the lower-case spelling to the declared one."""

    def __init__(
        self,
        predicates: dict[str, tuple[TypedName, ...]],
        functions: dict[str, tuple[TypedName, ...]],
        names: dict[str, str],
        variables: dict[str, str],
    ) -> None:
        self.predicates = predicates
        self.functions = functions
        self.names = names
        self.variables = variables
        self.predicate_names = {p.lower(): p for p in predicates}
        self.function_names = {f.lower(): f for f in functions}

    def extended(self, variables: list[TypedName]) -> Scope:
        inner = Scope.__new__(Scope)
        inner.__dict__.update(self.__dict__)
        inner.variables = {**self.variables, **{v.name.lower(): v.name for v in variables}}
        return inner

    def predicate(self, symbol: Symbol, node: SList, reader: FormReader) -> str:
        """The declared spelling of the predicate ``symbol`` names."""
        name = self.predicate_names.get(symbol.lower)
        if name is None:
            hint = did_you_mean(symbol.text, self.predicates)
            raise reader.fail(f"unknown predicate {symbol.text!r}{hint}", node)
        return name

    def check_atom(self, name: str, terms: tuple[str, ...], node: SList, reader: FormReader) -> None:
        arity = len(self.predicates[name])
        if len(terms) != arity:
            raise reader.fail(f"predicate {name!r} takes {arity} argument(s), found {len(terms)}", node)

    def term(self, symbol: Symbol, reader: FormReader) -> str:
        """The declared spelling of the variable or object ``symbol`` names."""
        if is_variable(symbol.text):
            variable = self.variables.get(symbol.lower)
            if variable is None:
                raise reader.fail(f"unbound variable {symbol.text!r}", symbol)
            return variable
        name = self.names.get(symbol.lower)
        if name is None:
            hint = did_you_mean(symbol.text, self.names.values())
            raise reader.fail(f"unknown object or constant {symbol.text!r}{hint}", symbol)
        return name


# ====================================================================== domain


__all__ = ["SUPPORTED_REQUIREMENTS", "UNSUPPORTED_SECTIONS", "FormReader", "Scope"]
