"""Properties of goal formulas (hbtp.logic.goals, hbtp.logic.resolve), on generated formulas.

A formula is a tree of ``and``, ``or`` and ``not`` over a few literals, written out in the infix
syntax (with minimal or full parentheses, either spelling of the literals) and in PDDL syntax. Its
meaning is evaluated here directly on every state of those literals, so:

* every text of a formula parses into a disjunctive normal form with exactly the formula's meaning;
* resolved against a task (negated twins added where needed) the goal holds in exactly the states
  where the formula does, and is unsolvable exactly when the formula is unsatisfiable;
* the normal form printed back (``format_goal``, ``GoalFormula``, the ``Pred(a,b)`` form of tree
  files) reads back into the same terms.

Hypothesis shrinks a counterexample to the smallest formula that breaks the property (one ``not``
over one ``or``, say), which a loop over seeds cannot do.
"""

from __future__ import annotations

import itertools
from dataclasses import dataclass

from hypothesis import given, settings
from hypothesis import strategies as st

from hbtp.bt.jsonio import goal_text
from hbtp.domains import DomainBuilder
from hbtp.logic.atoms import Atom
from hbtp.logic.goals import GoalFormula, format_goal, parse_goal
from hbtp.logic.negation import with_negations
from hbtp.logic.resolve import negations_needed
from hbtp.logic.task import GroundTask

PROPERTY = settings(max_examples=150, deadline=None, derandomize=True)

#: The literals formulas are made of: 0-ary, binary both ways round, a name with '-'. No name holds
#: '_': the datasets' spelling ``On_box_table`` splits at every '_', so such names do not read back
#: from it (by design; tree files write the ``On(box,table)`` form).
POOL = (Atom("Ready"), Atom("On", ("box", "table")), Atom("On", ("table", "box")), Atom("Is-Open", ("door2",)))
#: Every state of the pool's atoms.
STATES = [frozenset(chosen) for size in range(len(POOL) + 1) for chosen in itertools.combinations(POOL, size)]


@dataclass(frozen=True)
class Op:
    """A connective of a generated formula: ``and``, ``or`` (one or more parts) or ``not`` (one)."""

    kind: str
    parts: tuple[Formula, ...]


Formula = Atom | Op


def _connective(kind: str, parts: list[Formula]) -> Formula:
    return Op(kind, tuple(parts))


FORMULAS: st.SearchStrategy[Formula] = st.recursive(
    st.sampled_from(POOL),
    lambda inner: st.one_of(
        inner.map(lambda part: Op("not", (part,))),
        st.builds(_connective, st.sampled_from(["and", "or"]), st.lists(inner, min_size=1, max_size=3)),
    ),
    max_leaves=10,
)


def holds(formula: Formula, state: frozenset[Atom]) -> bool:
    """The formula's meaning, straight from its tree."""
    if isinstance(formula, Atom):
        return formula in state
    if formula.kind == "not":
        return not holds(formula.parts[0], state)
    values = (holds(part, state) for part in formula.parts)
    return all(values) if formula.kind == "and" else any(values)


def dnf_holds(terms: tuple[tuple[Atom, ...], ...], state: frozenset[Atom]) -> bool:
    """The meaning of parsed terms: some term whose every literal holds (``~p``: ``p`` is absent)."""
    return any(all((atom.positive in state) != atom.negated for atom in term) for term in terms)


_BINDS = {"or": 1, "and": 2, "not": 3}  # how tightly each connective binds in the infix syntax


def infix(formula: Formula, *, underscored: bool, minimal: bool, outer: str = "or", gap: str = " ") -> str:
    """The infix text: ``~`` binds tightest, then ``&``, then ``|``; with ``minimal``, parentheses
    only where the binding needs them, else around every ``and``, ``or`` and ``~(...)``."""
    if isinstance(formula, Atom):
        return formula.underscored if underscored else str(formula)
    kind = formula.kind
    parts = [infix(p, underscored=underscored, minimal=minimal, outer=kind, gap=gap) for p in formula.parts]
    text = "~" + parts[0] if kind == "not" else f"{gap}{'&' if kind == 'and' else '|'}{gap}".join(parts)
    if not minimal or _BINDS[kind] < _BINDS[outer]:
        text = f"({text})"
    return text


def pddl(formula: Formula) -> str:
    if isinstance(formula, Atom):
        return f"({' '.join((formula.predicate, *formula.args))})"
    return f"({formula.kind} {' '.join(pddl(part) for part in formula.parts)})"


def texts(formula: Formula) -> list[str]:
    """The formula in every syntax and spelling the goal reader takes."""
    written = [pddl(formula)]
    for underscored, minimal, gap in itertools.product((False, True), (False, True), (" ", "")):
        written.append(infix(formula, underscored=underscored, minimal=minimal, gap=gap))
    return written


@PROPERTY
@given(formula=FORMULAS)
def test_every_text_of_a_formula_parses_into_its_meaning(formula: Formula) -> None:
    first = parse_goal(pddl(formula))
    for text in texts(formula):
        terms = parse_goal(text)
        assert terms == first, text  # one normal form, whatever the syntax
        for state in STATES:
            assert dnf_holds(terms, state) == holds(formula, state), (text, sorted(map(str, state)))
        # "terms without repeats, in order": no term twice, no literal twice in a term
        assert len(set(terms)) == len(terms), text
        assert all(len(set(term)) == len(term) for term in terms), text


def _pool_task() -> GroundTask:
    """A task over the pool in which every literal can be made true and false again (so that no
    literal is dropped as always true or never reachable when a goal is resolved)."""
    builder = DomainBuilder("pool")
    for number, atom in enumerate(POOL):
        builder.action(f"Set(k{number})", add=[str(atom)], cost=1)
        builder.action(f"Clear(k{number})", pre=[str(atom)], delete=[str(atom)], cost=1)
    return builder.build()


POOL_TASK = _pool_task()


@PROPERTY
@given(formula=FORMULAS, underscored=st.booleans())
def test_a_resolved_goal_holds_exactly_where_its_formula_does(formula: Formula, underscored: bool) -> None:
    text = infix(formula, underscored=underscored, minimal=True)
    task = with_negations(POOL_TASK, negations_needed(POOL_TASK, text))
    goal = task.resolve_goal(text)
    ids = {atom: task.atom_id(atom) for atom in POOL}
    for state in STATES:
        complete = task.complete(ids[atom] for atom in state)  # with the twin of every absent atom
        assert goal.holds(complete) == holds(formula, state), (text, sorted(map(str, state)), goal.disjuncts)
    satisfiable = any(holds(formula, state) for state in STATES)
    assert (goal.unsolvable is None) == satisfiable, (text, goal.unsolvable)


@PROPERTY
@given(formula=FORMULAS, underscored=st.booleans())
def test_the_normal_form_printed_back_reads_back(formula: Formula, underscored: bool) -> None:
    terms = parse_goal(infix(formula, underscored=underscored, minimal=True))
    assert parse_goal(format_goal(terms)) == terms
    assert GoalFormula.parse(str(GoalFormula(terms))).terms == terms
    assert parse_goal(goal_text(format_goal(terms))) == terms  # the Pred(a,b) form of tree files
