"""Read PDDL domains and problems (the subset described in :mod:`hbtp.domains.lifted`).

Like Fast Downward, every name is case-insensitive (``ADMilk`` and ``admilk`` are one object); the
first spelling declared is the one kept for display. The quirks Fast Downward's translator tolerates
are read with a warning (logged with file:line:column): a name or parameter declared twice, a type
declared twice with ``object`` as one of its parents, ``name?var`` without a space. Anything outside
the subset is rejected with the construct and its line and column.
"""

from __future__ import annotations

from dataclasses import dataclass, field
from pathlib import Path

from hbtp.deadline import Deadline
from hbtp.domains.lifted import (
    OBJECT_TYPE,
    ActionSchema,
    And,
    AtomFormula,
    Domain,
    Formula,
    Problem,
    TypedName,
    is_variable,
)
from hbtp.domains.pddl_forms import SUPPORTED_REQUIREMENTS, UNSUPPORTED_SECTIONS, FormReader, Scope
from hbtp.domains.sexpr import Expr, SList, Symbol
from hbtp.errors import PddlError, SourceError
from hbtp.files import InputKind, read_text
from hbtp.logic.task import did_you_mean


def read_domain(text: str, source: str = "<domain>", deadline: Deadline | None = None) -> Domain:
    """Parse a PDDL domain (past ``deadline``, :class:`~hbtp.deadline.TimeLimitReached`)."""
    reader = FormReader(source, deadline)
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

    scope = Scope(predicates, parts.functions, {c.name.lower(): c.name for c in constants}, {})
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

    def read(self, reader: FormReader, head: str, node: SList) -> None:
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

    def add_type(self, reader: FormReader, symbol: Symbol, parent: str) -> None:
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

    def read_predicates(self, reader: FormReader, node: SList) -> None:
        for item in node.items[1:]:
            decl = reader.expect_list(item, "(predicate ?args)")
            pname = reader.expect_name(decl.items[0], "a predicate name").text if decl.items else ""
            if not pname:
                raise reader.fail("empty predicate declaration", decl)
            if pname.lower() in self.predicate_keys:
                raise reader.fail(f"predicate {pname!r} is declared twice", decl)
            self.predicate_keys.add(pname.lower())
            self.predicates[pname] = tuple(reader.typed_list(decl.items[1:], variables=True, keep_twice=True))


def _read_functions(reader: FormReader, node: SList) -> dict[str, tuple[TypedName, ...]]:
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


def _check_type_cycles(reader: FormReader, types: dict[str, str]) -> None:
    for start in types:
        seen = {start}
        current = types.get(start)
        while current is not None and current != OBJECT_TYPE:
            if current in seen:
                raise reader.fail(f"type {start!r} is its own ancestor", reader.type_uses.get(start))
            seen.add(current)
            current = types.get(current)


def _read_action(reader: FormReader, node: SList, scope: Scope, declared_types: set[str]) -> ActionSchema:
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
    reader = FormReader(source, deadline)
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
        if reader.keyword(fact, scope) in ("and", "or", "not", "forall", "when"):  # a predicate may be named so
            raise reader.fail(f"(:init ...) holds atoms only, found ({fact.head()} ...)", fact)
        atom = reader.atom(fact, scope)
        if any(is_variable(t) for t in atom.terms):
            raise reader.fail("initial facts cannot contain variables", fact)
        init.append(atom)
    goal: Formula = And(())
    if goal_node is not None:
        goal = reader.formula(goal_node, scope)
    return Problem(name, domain_name or domain.name, tuple(objects), tuple(init), numeric, goal, minimize)


def _problem_scope(reader: FormReader, domain: Domain, object_nodes: tuple[Expr, ...]) -> tuple[list[TypedName], Scope]:
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
    return objects, Scope(domain.predicates, domain.functions, names, {})


def _read_metric(reader: FormReader, node: SList) -> bool:
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


def _read_numeric_fact(reader: FormReader, fact: SList, scope: Scope) -> tuple[tuple[str, tuple[str, ...]], int]:
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
