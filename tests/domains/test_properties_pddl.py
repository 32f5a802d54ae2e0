"""Properties of the PDDL reader and writer (hbtp.domains.sexpr, pddl_reader, pddl_writer), on
generated input.

* Any lifted domain and problem of the supported subset (typed lists with ``either`` and objects
  before typed names, nested conditions with quantifiers, ``=`` and ``imply``, effects with
  ``forall``, ``when`` and costs, predicates named like keywords) written out and read back is the
  same domain and problem. The shipped files round-trip too (tests/domains/test_pddl_writer.py), but they
  use a few constructs in a few combinations; here Hypothesis combines them and shrinks a failure to
  the smallest domain that does not read back.
* Any text, deep nesting included, is read into s-expressions exactly when it is balanced, at most
  :data:`~hbtp.domains.sexpr.MAX_NESTING` deep and free of NUL bytes, the places recorded point at
  the tokens and parentheses, and anything else is one :class:`~hbtp.errors.PddlError` placed at
  the offending character (never another exception): checked against a model of the reader.
"""

from __future__ import annotations

import contextlib
import re

import pytest
from hypothesis import given, settings
from hypothesis import strategies as st

from hbtp.domains import read_domain, read_problem, write_domain, write_problem
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
)
from hbtp.domains.pddl_forms import SUPPORTED_REQUIREMENTS
from hbtp.domains.sexpr import MAX_NESTING, Expr, SList, Symbol, parse_sexprs
from hbtp.errors import PddlError

PROPERTY = settings(max_examples=120, deadline=None, derandomize=True)

#: The stem of a domain's names: every name is the stem and a number, so names never clash.
STEMS = st.from_regex(r"[A-Za-z][A-Za-z0-9_\-]{0,4}", fullmatch=True)
#: Predicates spelled like a keyword but not in its (lower) case: a declared predicate wins over the
#: keyword (RoboWaiter's ``Exists``).
KEYWORD_PREDICATES = st.sampled_from(["Exists", "Not", "And", "Or", "Imply", "Forall", "When", "Increase", "EXISTS"])


class _Vocabulary:
    """What the formulas of one generated domain may use."""

    def __init__(
        self,
        predicates: dict[str, tuple[TypedName, ...]],
        functions: dict[str, tuple[TypedName, ...]],
        types: list[str],
        variables: list[str],
    ) -> None:
        self.predicates = predicates
        self.cost_functions = {name: len(params) for name, params in functions.items() if name != "total-cost"}
        self.types = types
        self.variables = variables


def _types(draw: st.DrawFn, vocabulary: _Vocabulary) -> tuple[str, ...]:
    """A type, or an ``(either ...)`` of two or three."""
    if len(vocabulary.types) < 2 or draw(st.booleans()):
        return (draw(st.sampled_from(vocabulary.types)),)
    return tuple(draw(st.lists(st.sampled_from(vocabulary.types), min_size=2, max_size=3, unique=True)))


def _typed_names(draw: st.DrawFn, names: list[str], vocabulary: _Vocabulary) -> tuple[TypedName, ...]:
    return tuple(TypedName(name, _types(draw, vocabulary)) for name in names)


def _variables(draw: st.DrawFn, vocabulary: _Vocabulary, min_size: int) -> tuple[TypedName, ...]:
    names = draw(st.lists(st.sampled_from(vocabulary.variables), min_size=min_size, max_size=2, unique=True))
    return _typed_names(draw, names, vocabulary)


def _atom(
    draw: st.DrawFn, vocabulary: _Vocabulary, terms: list[str], leave_out: frozenset[str] = frozenset()
) -> AtomFormula | None:
    usable = sorted(n for n, params in vocabulary.predicates.items() if (terms or not params) and n not in leave_out)
    if not usable:
        return None
    name = draw(st.sampled_from(usable))
    return AtomFormula(name, tuple(draw(st.sampled_from(terms)) for _ in vocabulary.predicates[name]))


def _formula(draw: st.DrawFn, vocabulary: _Vocabulary, terms: list[str], depth: int = 0) -> Formula:
    kinds = ["atom", "and", "not", "or", "imply", "exists", "forall", "="] if depth < 3 else ["atom"]
    kind = draw(st.sampled_from(kinds))
    if kind == "atom" or (kind == "=" and not terms):
        return _atom(draw, vocabulary, terms) or And(())
    if kind == "=":
        return Equals(draw(st.sampled_from(terms)), draw(st.sampled_from(terms)))
    if kind in ("exists", "forall"):
        variables = _variables(draw, vocabulary, min_size=1)
        inner = sorted({*terms, *(v.name for v in variables)})
        body = _formula(draw, vocabulary, inner, depth + 1)
        return Exists(variables, body) if kind == "exists" else Forall(variables, body)
    if kind == "not":
        return Not(_formula(draw, vocabulary, terms, depth + 1))
    if kind == "imply":
        return Imply(_formula(draw, vocabulary, terms, depth + 1), _formula(draw, vocabulary, terms, depth + 1))
    parts = tuple(_formula(draw, vocabulary, terms, depth + 1) for _ in range(draw(st.integers(0, 3))))
    return And(parts) if kind == "and" else Or(parts)


def _effect(draw: st.DrawFn, vocabulary: _Vocabulary, terms: list[str], depth: int = 0) -> Effect:
    kinds = ["add", "and", "delete", "cost", "forall", "when"] if depth < 2 else ["add", "delete", "cost"]
    kind = draw(st.sampled_from(kinds))
    if kind in ("add", "delete"):
        atom = _atom(draw, vocabulary, terms)
        if atom is None:
            return AndEffect(())
        return AddEffect(atom) if kind == "add" else DeleteEffect(atom)
    if kind == "cost":
        functions = sorted(name for name, arity in vocabulary.cost_functions.items() if terms or not arity)
        by_function = draw(st.booleans())
        if functions and by_function:
            name = draw(st.sampled_from(functions))
            arguments = tuple(draw(st.sampled_from(terms)) for _ in range(vocabulary.cost_functions[name]))
            return CostEffect(AtomFormula(name, arguments))
        return CostEffect(draw(st.integers(0, MAX_ACTION_COST)))
    if kind == "forall":
        variables = _variables(draw, vocabulary, min_size=1)
        inner = sorted({*terms, *(v.name for v in variables)})
        return ForallEffect(variables, _effect(draw, vocabulary, inner, depth + 1))
    if kind == "when":
        return WhenEffect(_formula(draw, vocabulary, terms, 1), _effect(draw, vocabulary, terms, depth + 1))
    return AndEffect(tuple(_effect(draw, vocabulary, terms, depth + 1) for _ in range(draw(st.integers(0, 3)))))


@st.composite
def domains_and_problems(draw: st.DrawFn) -> tuple[Domain, Problem]:
    """A lifted domain of the supported subset and a problem of it, both well formed."""
    stem = draw(STEMS)
    names = iter(f"{stem}{number}" for number in range(100))  # distinct in any case: no two things clash
    type_names = [next(names) for _ in range(draw(st.integers(0, 3)))]
    types: dict[str, str] = {}
    for position, name in enumerate(type_names):  # a parent declared before: no cycle
        types[name] = draw(st.sampled_from([OBJECT_TYPE, *type_names[:position]]))
    variables = [f"?{next(names)}" for _ in range(4)]
    vocabulary = _Vocabulary({}, {}, [OBJECT_TYPE, *type_names], variables)

    keyword_predicate = draw(st.lists(KEYWORD_PREDICATES, max_size=1))
    predicate_names = keyword_predicate + [next(names) for _ in range(draw(st.integers(1, 4)))]
    for name in predicate_names:
        vocabulary.predicates[name] = _variables(draw, vocabulary, min_size=0)
    functions: dict[str, tuple[TypedName, ...]] = {}
    if draw(st.booleans()):
        functions["total-cost"] = ()
    for _ in range(draw(st.integers(0, 2))):
        functions[next(names)] = _variables(draw, vocabulary, min_size=0)
    vocabulary.cost_functions = {name: len(params) for name, params in functions.items() if name != "total-cost"}

    constant_names = [next(names) for _ in range(draw(st.integers(0, 2)))]
    constants = _typed_names(draw, constant_names, vocabulary)
    actions = []
    for _ in range(draw(st.integers(0, 3))):
        parameters = _variables(draw, vocabulary, min_size=0)
        terms = sorted({*constant_names, *(p.name for p in parameters)})
        actions.append(
            ActionSchema(next(names), parameters, _formula(draw, vocabulary, terms), _effect(draw, vocabulary, terms))
        )
    requirements = tuple(draw(st.lists(st.sampled_from(sorted(SUPPORTED_REQUIREMENTS)), max_size=4, unique=True)))
    domain = Domain(next(names), requirements, types, constants, dict(vocabulary.predicates), functions, tuple(actions))

    object_names = [next(names) for _ in range(draw(st.integers(0, 3)))]
    objects = _typed_names(draw, object_names, vocabulary)
    ground = [*constant_names, *object_names]
    facts = (_atom(draw, vocabulary, ground) for _ in range(draw(st.integers(0, 4))))
    init = tuple(fact for fact in facts if fact is not None)
    numeric: dict[tuple[str, tuple[str, ...]], int] = {}
    for name, arity in vocabulary.cost_functions.items():
        if ground or not arity:
            arguments = tuple(draw(st.sampled_from(ground)) for _ in range(arity))
            numeric[name, arguments] = draw(st.integers(-MAX_ACTION_COST, MAX_ACTION_COST))
    goal = _formula(draw, vocabulary, ground)
    problem = Problem(next(names), domain.name, objects, init, numeric, goal, draw(st.booleans()))
    return domain, problem


@PROPERTY
@given(case=domains_and_problems())
def test_a_written_domain_and_problem_read_back_unchanged(case: tuple[Domain, Problem]) -> None:
    domain, problem = case
    domain_text = write_domain(domain)
    assert read_domain(domain_text) == domain, domain_text
    problem_text = write_problem(problem)
    assert read_problem(problem_text, domain) == problem, problem_text
    assert write_domain(read_domain(domain_text)) == domain_text  # and the text is a fixed point


# ----------------------------------------------------------------------------- s-expressions
PIECES = st.sampled_from(
    [
        "(", ")", "(", ")", " ", "\n", "\r\n", "\t", "a", "?x", "name?var", "-", ":init", "x-1", "; note", ";)",
        "\u00e9", "\u00a0", "\ufeff", "\0", "(and", "(not ", "))",
    ]
)  # fmt: skip
#: Nesting around the limit: ``depth`` parentheses opened, ``depth + extra`` closed, around a piece.
NESTED = st.builds(
    lambda depth, extra, inner: "(" * depth + inner + ")" * max(0, depth + extra),
    st.integers(MAX_NESTING - 2, MAX_NESTING + 2),
    st.integers(-1, 1),
    st.sampled_from(["", "x", "(a)", "\n(a\n b)"]),
)
TEXTS = st.one_of(st.lists(PIECES, max_size=40).map("".join), NESTED, st.text(max_size=30))
_TOKEN = re.compile(r"\(|\)|[^\s();]+")


def _expected(text: str) -> tuple[str, int, int] | None:
    """What the reader must say of ``text``: ``None`` (it reads), or the error's start and place,
    found by scanning the text character by character."""
    if "\0" in text:
        before = text[: text.index("\0")]
        return "a NUL byte", before.count("\n") + 1, len(before) - (before.rfind("\n") + 1) + 1
    opened: list[tuple[int, int]] = []
    for number, line in enumerate(text.split("\n"), start=1):
        for column, char in enumerate(line.split(";")[0], start=1):
            if char == "(":
                if len(opened) == MAX_NESTING:
                    return "parentheses nested deeper", number, column
                opened.append((number, column))
            elif char == ")":
                if not opened:
                    return "unbalanced ')'", number, column
                opened.pop()
    if opened:
        return "'(' is never closed", *opened[-1]
    return None


def _check_places(exprs: list[Expr], lines: list[str]) -> list[str]:
    """Each expression's tokens, checked to stand at the recorded line and column."""
    tokens: list[str] = []
    for expr in exprs:
        if isinstance(expr, Symbol):
            assert lines[expr.line - 1][expr.column - 1 :].startswith(expr.text), expr
            tokens.append(expr.text)
        else:
            assert isinstance(expr, SList)
            assert lines[expr.line - 1][expr.column - 1] == "(", expr
            tokens += ["(", *_check_places(list(expr.items), lines), ")"]
    return tokens


@PROPERTY
@given(text=TEXTS)
def test_any_text_reads_into_placed_s_expressions_or_one_placed_error(text: str) -> None:
    body = text.removeprefix("\ufeff")
    expected = _expected(body)
    with contextlib.suppress(PddlError):  # anything else (an IndexError, a RecursionError) fails the test
        read_domain(text)
    if expected is not None:
        message, line, column = expected
        with pytest.raises(PddlError) as caught:
            parse_sexprs(text, "t.pddl")
        error = caught.value
        assert error.message.startswith(message), (text, error.message, expected)
        assert (error.source, error.line, error.column) == ("t.pddl", line, column), (text, str(error))
        return
    exprs = parse_sexprs(text, "t.pddl")
    lines = body.split("\n")
    read = _check_places(exprs, lines)
    written = [t for line in lines for t in _TOKEN.findall(line.split(";")[0])]
    # every token in order, ``name?var`` read as ``name ?var`` (as Fast Downward reads it)
    assert read == " ".join(t[0] + t[1:].replace("?", " ?") for t in written).split(), text
