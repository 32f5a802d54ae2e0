"""Read PDDL domains and problems (the subset described in :mod:`hbtp.domains.lifted`).

Like Fast Downward, every name is case-insensitive (``ADMilk`` and ``admilk`` are one object); the
first spelling declared is the one kept for display. The quirks Fast Downward's translator tolerates
are read with a warning (logged with file:line:column): a name or parameter declared twice, a type
declared twice with ``object`` as one of its parents, ``name?var`` without a space. Anything outside
the subset is rejected with the construct and its line and column.
"""

from __future__ import annotations

import logging
import re
from collections.abc import Iterable
from dataclasses import dataclass, field
from pathlib import Path

from hbtp.deadline import Deadline
from hbtp.domains.lifted import (
    MAX_ACTION_COST,
    OBJECT_TYPE,
    ActionSchema,
    AddEffect,
    And,
    AndEffect,
    AtomFormula,
    CostEffect,
    DeleteEffect,
    Domain,
    Effect,
    Equals,
    Exists,
    Forall,
    ForallEffect,
    Formula,
    Imply,
    Not,
    Or,
    Problem,
    TypedName,
    WhenEffect,
    is_variable,
)
from hbtp.domains.sexpr import Expr, SList, Symbol, parse_sexprs
from hbtp.errors import PddlError, SourceError
from hbtp.files import InputKind, read_text
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


class _Reader:
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
    def formula(self, expr: Expr, context: _Scope) -> Formula:
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

    def quantified(self, node: SList, context: _Scope, kind: type[Exists] | type[Forall]) -> Formula:
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

    def keyword(self, node: SList, context: _Scope) -> str:
        """The lower-cased head of ``node``, or '' when it names a declared predicate.

        PDDL keywords are case-insensitive, so a predicate called ``Exists`` would read as the
        quantifier; a declared predicate name always wins.
        """
        first = node.items[0] if node.items else None
        if isinstance(first, Symbol) and first.text in context.predicates:
            return ""
        return node.head()

    def atom(self, node: SList, context: _Scope) -> AtomFormula:
        if not node.items:
            raise self.fail("empty condition ()", node)
        name = context.predicate(self.expect_symbol(node.items[0], "a predicate"), node, self)
        terms = tuple(self.term(t, context) for t in node.items[1:])
        context.check_atom(name, terms, node, self)
        return AtomFormula(name, terms, node.line)

    def term(self, expr: Expr, context: _Scope) -> str:
        symbol = self.expect_symbol(expr, "a variable or object")
        return context.term(symbol, self)

    # ------------------------------------------------------------- effects
    def effect(self, expr: Expr, context: _Scope) -> Effect:
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

    def cost_effect(self, node: SList, context: _Scope) -> CostEffect:
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


class _Scope:
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

    def extended(self, variables: list[TypedName]) -> _Scope:
        inner = _Scope.__new__(_Scope)
        inner.__dict__.update(self.__dict__)
        inner.variables = {**self.variables, **{v.name.lower(): v.name for v in variables}}
        return inner

    def predicate(self, symbol: Symbol, node: SList, reader: _Reader) -> str:
        """The declared spelling of the predicate ``symbol`` names."""
        name = self.predicate_names.get(symbol.lower)
        if name is None:
            hint = did_you_mean(symbol.text, self.predicates)
            raise reader.fail(f"unknown predicate {symbol.text!r}{hint}", node)
        return name

    def check_atom(self, name: str, terms: tuple[str, ...], node: SList, reader: _Reader) -> None:
        arity = len(self.predicates[name])
        if len(terms) != arity:
            raise reader.fail(f"predicate {name!r} takes {arity} argument(s), found {len(terms)}", node)

    def term(self, symbol: Symbol, reader: _Reader) -> str:
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
def read_domain(text: str, source: str = "<domain>", deadline: Deadline | None = None) -> Domain:
    """Parse a PDDL domain (past ``deadline``, :class:`~hbtp.deadline.TimeLimitReached`)."""
    reader = _Reader(source, deadline)
    name, sections, _ = reader.define(text, "domain")
    parts = _DomainSections()
    seen: set[str] = set()
    for section in sections:
        node = reader.expect_list(section, "a domain section")
        head = node.head()
        if head in UNSUPPORTED_SECTIONS:
            raise reader.fail(f"{UNSUPPORTED_SECTIONS[head]} ({head}) are not supported", node)
        if head != ":action" and head in seen:
            raise reader.fail(f"section {head} appears twice", node)
        seen.add(head)
        parts.read(reader, head, node)

    types, constants, predicates = parts.types, parts.constants, parts.predicates
    declared_types = {OBJECT_TYPE, *types, *types.values()}
    reader.check_types([*constants, *(p for params in predicates.values() for p in params)], "", declared_types)
    reader.declared_types = declared_types
    _check_type_cycles(reader, types)

    scope = _Scope(predicates, parts.functions, {c.name.lower(): c.name for c in constants}, {})
    actions: list[ActionSchema] = []
    action_names: set[str] = set()
    for position, node in enumerate(parts.action_nodes):
        if deadline is not None and position & 255 == 255:
            deadline.check("reading the PDDL files")
        action = _read_action(reader, node, scope, declared_types)
        if action.name.lower() in action_names:
            raise reader.fail(f"action {action.name!r} is declared twice", node)
        action_names.add(action.name.lower())
        actions.append(action)
    return Domain(
        name, tuple(parts.requirements), types, tuple(constants), predicates, parts.functions, tuple(actions), source
    )


@dataclass
class _DomainSections:
    """The sections of a domain as they are read; actions are read last, when every declaration is known."""

    requirements: list[str] = field(default_factory=list)
    types: dict[str, str] = field(default_factory=dict)
    constants: list[TypedName] = field(default_factory=list)
    predicates: dict[str, tuple[TypedName, ...]] = field(default_factory=dict)
    functions: dict[str, tuple[TypedName, ...]] = field(default_factory=dict)
    predicate_keys: set[str] = field(default_factory=set)  # the predicates' names in lower case
    action_nodes: list[SList] = field(default_factory=list)

    def read(self, reader: _Reader, head: str, node: SList) -> None:
        if head == ":requirements":
            for item in node.items[1:]:
                req = reader.expect_symbol(item, "a requirement").lower
                if req not in SUPPORTED_REQUIREMENTS:
                    raise reader.fail(f"requirement {req} is not supported", item)
                self.requirements.append(req)
        elif head == ":types":
            for item in node.items[1:]:  # the first spelling written is the one kept
                if isinstance(item, Symbol) and item.text != "-":
                    reader.type_names.setdefault(item.lower, item.text)
            for symbol, typed in reader.typed_symbols(node.items[1:], variables=False):
                if len(typed.types) != 1:
                    raise reader.fail(f"type {typed.name!r} cannot have an (either ...) parent", symbol)
                self.add_type(reader, symbol, typed.types[0])
        elif head == ":constants":
            self.constants = reader.typed_list(node.items[1:], variables=False)
        elif head == ":predicates":
            self.read_predicates(reader, node)
        elif head == ":functions":
            self.functions.update(_read_functions(reader, node))
        elif head == ":action":
            self.action_nodes.append(node)
        else:
            raise reader.fail(f"unknown domain section {head or '(list)'}", node)

    def add_type(self, reader: _Reader, symbol: Symbol, parent: str) -> None:
        """Declare a type; declared again, its parent ``object`` gives way to the other (with a warning)."""
        name = reader.type_names.setdefault(symbol.lower, symbol.text)
        reader.type_uses.setdefault(name, symbol)
        first = self.types.get(name)
        if first is None:
            self.types[name] = parent
            return
        if first != parent and OBJECT_TYPE not in (first, parent):
            raise reader.fail(f"type {name!r} is declared twice, with parents {first!r} and {parent!r}", symbol)
        reader.warn(f"type {name!r} is declared twice", symbol)
        if first == OBJECT_TYPE:
            self.types[name] = parent

    def read_predicates(self, reader: _Reader, node: SList) -> None:
        for item in node.items[1:]:
            decl = reader.expect_list(item, "(predicate ?args)")
            pname = reader.expect_name(decl.items[0], "a predicate name").text if decl.items else ""
            if not pname:
                raise reader.fail("empty predicate declaration", decl)
            if pname.lower() in self.predicate_keys:
                raise reader.fail(f"predicate {pname!r} is declared twice", decl)
            self.predicate_keys.add(pname.lower())
            self.predicates[pname] = tuple(reader.typed_list(decl.items[1:], variables=True, keep_twice=True))


def _read_functions(reader: _Reader, node: SList) -> dict[str, tuple[TypedName, ...]]:
    functions: dict[str, tuple[TypedName, ...]] = {}
    items = node.items[1:]
    index = 0
    while index < len(items):
        item = items[index]
        if isinstance(item, Symbol) and item.text == "-":
            kind = reader.expect_symbol(items[index + 1], "number") if index + 1 < len(items) else None
            if kind is None or kind.lower != "number":
                raise reader.fail("only numeric functions (- number) are supported", item)
            index += 2
            continue
        decl = reader.expect_list(item, "(function ?args)")
        fname = reader.expect_name(decl.items[0], "a function name").text if decl.items else ""
        if not fname:
            raise reader.fail("empty function declaration", decl)
        functions[fname] = tuple(reader.typed_list(decl.items[1:], variables=True, keep_twice=True))
        index += 1
    return functions


def _check_type_cycles(reader: _Reader, types: dict[str, str]) -> None:
    for start in types:
        seen = {start}
        current = types.get(start)
        while current is not None and current != OBJECT_TYPE:
            if current in seen:
                raise reader.fail(f"type {start!r} is its own ancestor", reader.type_uses.get(start))
            seen.add(current)
            current = types.get(current)


def _read_action(reader: _Reader, node: SList, scope: _Scope, declared_types: set[str]) -> ActionSchema:
    if len(node.items) < 2:
        raise reader.fail("(:action NAME ...) needs a name", node)
    name = reader.expect_name(node.items[1], "an action name").text
    fields: dict[str, Expr] = {}
    rest = node.items[2:]
    if len(rest) % 2:
        raise reader.fail(f"action {name!r}: keywords and values must come in pairs", node)
    for key, value in zip(rest[::2], rest[1::2], strict=True):
        keyword = reader.expect_symbol(key, "a keyword").lower
        if keyword not in (":parameters", ":precondition", ":effect"):
            raise reader.fail(f"action {name!r}: unknown keyword {keyword}", key)
        fields[keyword] = value
    params_node = fields.get(":parameters")
    parameters = (
        reader.typed_list(reader.expect_list(params_node, "(?params)").items, variables=True)
        if params_node is not None
        else []
    )
    reader.check_types(parameters, f"action {name!r}: ", declared_types)
    inner = scope.extended(parameters)
    pre_node = fields.get(":precondition")
    precondition: Formula = And(())
    if pre_node is not None and not (isinstance(pre_node, SList) and not pre_node.items):
        precondition = reader.formula(pre_node, inner)
    effect_node = fields.get(":effect")
    if effect_node is None:
        raise reader.fail(f"action {name!r} has no :effect", node)
    effect = reader.effect(effect_node, inner)
    return ActionSchema(name, tuple(parameters), precondition, effect, node.line, node.column)


# ===================================================================== problem
def read_problem(text: str, domain: Domain, source: str = "<problem>", deadline: Deadline | None = None) -> Problem:
    """Parse a PDDL problem of ``domain`` (past ``deadline``, :class:`~hbtp.deadline.TimeLimitReached`)."""
    reader = _Reader(source, deadline)
    for type_name in (*domain.types, *domain.types.values()):
        reader.type_names.setdefault(type_name.lower(), type_name)
    name, sections, _ = reader.define(text, "problem")
    domain_name = ""
    object_nodes: tuple[Expr, ...] = ()
    init_nodes: list[Expr] = []
    goal_node: Expr | None = None
    minimize = False
    for section in sections:
        node = reader.expect_list(section, "a problem section")
        head = node.head()
        if head == ":domain":
            domain_name = reader.expect_symbol(node.items[1], "a domain name").text if len(node.items) > 1 else ""
            if domain_name.lower() != domain.name.lower():
                raise reader.fail(f"problem is for domain {domain_name!r}, not {domain.name!r}", node)
        elif head == ":objects":
            object_nodes = node.items[1:]
        elif head == ":init":
            init_nodes = list(node.items[1:])
        elif head == ":goal":
            if len(node.items) != 2:
                raise reader.fail("(:goal ...) takes one condition", node)
            goal_node = node.items[1]
        elif head == ":metric":
            minimize = _read_metric(reader, node)
        elif head == ":requirements":
            continue
        else:
            raise reader.fail(f"unknown problem section {head or '(list)'}", node)

    objects, scope = _problem_scope(reader, domain, object_nodes)
    init: list[AtomFormula] = []
    numeric: dict[tuple[str, tuple[str, ...]], int] = {}
    for item in init_nodes:
        fact = reader.expect_list(item, "an initial fact")
        if fact.head() == "=":
            key, value = _read_numeric_fact(reader, fact, scope)
            numeric[key] = value
            continue
        if fact.head() in ("and", "or", "not", "forall", "when"):
            raise reader.fail(f"(:init ...) holds atoms only, found ({fact.head()} ...)", fact)
        atom = reader.atom(fact, scope)
        if any(is_variable(t) for t in atom.terms):
            raise reader.fail("initial facts cannot contain variables", fact)
        init.append(atom)
    goal: Formula = And(())
    if goal_node is not None:
        goal = reader.formula(goal_node, scope)
    return Problem(name, domain_name or domain.name, tuple(objects), tuple(init), numeric, goal, minimize)


def _problem_scope(reader: _Reader, domain: Domain, object_nodes: tuple[Expr, ...]) -> tuple[list[TypedName], _Scope]:
    """The problem's objects, and the names its facts may use (an object declared twice, or also a
    domain constant, is read once with a warning when both have the same type)."""
    seen = {c.name.lower(): c for c in domain.constants}
    objects: list[TypedName] = []
    for symbol, obj in reader.typed_symbols(object_nodes, variables=False):
        first = seen.setdefault(obj.name.lower(), obj)
        if first is obj:
            objects.append(obj)
            continue
        what = "a domain constant" if first in domain.constants else "an object"
        if first.types != obj.types:
            raise reader.fail(f"{obj.name!r} is already {what}, of another type", symbol)
        reader.warn(f"{obj.name!r} is declared twice (already {what})", symbol)
    reader.check_types(objects, "", {OBJECT_TYPE, *domain.types, *domain.types.values()})
    names = {key: typed.name for key, typed in seen.items()}
    return objects, _Scope(domain.predicates, domain.functions, names, {})


def _read_metric(reader: _Reader, node: SList) -> bool:
    items = node.items[1:]
    if (
        len(items) == 2
        and isinstance(items[0], Symbol)
        and items[0].lower == "minimize"
        and isinstance(items[1], SList)
        and items[1].head() == "total-cost"
    ):
        return True
    raise reader.fail("only (:metric minimize (total-cost)) is supported", node)


def _read_numeric_fact(reader: _Reader, fact: SList, scope: _Scope) -> tuple[tuple[str, tuple[str, ...]], int]:
    if len(fact.items) != 3:
        raise reader.fail("expected (= (function args) NUMBER)", fact)
    target = reader.expect_list(fact.items[1], "(function args)")
    written = reader.expect_symbol(target.items[0], "a function").text if target.items else ""
    fname = scope.function_names.get(written.lower(), "")
    if not fname:
        raise reader.fail(f"unknown function {written!r}{did_you_mean(written, scope.functions)}", target)
    args = tuple(reader.term(t, scope) for t in target.items[1:])
    value = reader.number(reader.expect_symbol(fact.items[2], "a number"))
    return (fname, args), value


def read_domain_file(path: str | Path, deadline: Deadline | None = None) -> Domain:
    path = Path(path)
    return read_domain(_read_text(path), str(path), deadline)


def read_problem_file(path: str | Path, domain: Domain, deadline: Deadline | None = None) -> Problem:
    path = Path(path)
    return read_problem(_read_text(path), domain, str(path), deadline)


def _read_text(path: Path) -> str:
    """A PDDL file's text: a regular file, at most :attr:`InputKind.PDDL`'s cap, UTF-8."""
    try:
        return read_text(path, InputKind.PDDL)
    except SourceError as error:
        raise PddlError(error.message, error.source, error.line, error.column) from None
