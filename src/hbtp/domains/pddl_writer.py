"""Write PDDL: the lifted model back to text (the inverse of the reader), and a grounded task as a
plain STRIPS + action-costs domain/problem pair that any PDDL planner (Fast Downward) accepts.
"""

from __future__ import annotations

from collections.abc import Iterable

from hbtp.domains.lifted import (
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
    ForallEffect,
    Formula,
    Imply,
    Not,
    Or,
    Problem,
    TypedName,
    WhenEffect,
)
from hbtp.logic.atoms import Atom
from hbtp.logic.task import Goal, GroundTask


def _typed(names: Iterable[TypedName]) -> str:
    """``a b - t c - (either u v) d``. A name of type object is written bare only when no typed name
    follows it: in ``a c - t`` the type t would also apply to ``a``."""
    names = list(names)
    last_typed = max((i for i, t in enumerate(names) if t.types != (OBJECT_TYPE,)), default=-1)
    parts: list[str] = []
    for index, typed in enumerate(names):
        if typed.types == (OBJECT_TYPE,):
            parts.append(typed.name if index > last_typed else f"{typed.name} - {OBJECT_TYPE}")
        elif len(typed.types) == 1:
            parts.append(f"{typed.name} - {typed.types[0]}")
        else:
            parts.append(f"{typed.name} - (either {' '.join(typed.types)})")
    return " ".join(parts)


def format_formula(formula: Formula) -> str:
    if isinstance(formula, AtomFormula):
        return str(formula)
    if isinstance(formula, Equals):
        return f"(= {formula.left} {formula.right})"
    if isinstance(formula, Not):
        return f"(not {format_formula(formula.operand)})"
    if isinstance(formula, And):
        return f"(and {' '.join(format_formula(p) for p in formula.parts)})".replace("(and )", "(and)")
    if isinstance(formula, Or):
        return f"(or {' '.join(format_formula(p) for p in formula.parts)})"
    if isinstance(formula, Imply):
        return f"(imply {format_formula(formula.antecedent)} {format_formula(formula.consequent)})"
    word = "exists" if isinstance(formula, Exists) else "forall"
    return f"({word} ({_typed(formula.variables)}) {format_formula(formula.body)})"


def format_effect(effect: Effect) -> str:
    if isinstance(effect, AddEffect):
        return str(effect.atom)
    if isinstance(effect, DeleteEffect):
        return f"(not {effect.atom})"
    if isinstance(effect, AndEffect):
        return f"(and {' '.join(format_effect(p) for p in effect.parts)})".replace("(and )", "(and)")
    if isinstance(effect, ForallEffect):
        return f"(forall ({_typed(effect.variables)}) {format_effect(effect.body)})"
    if isinstance(effect, WhenEffect):
        return f"(when {format_formula(effect.condition)} {format_effect(effect.body)})"
    assert isinstance(effect, CostEffect)
    amount = effect.amount if isinstance(effect.amount, int) else str(effect.amount)
    return f"(increase (total-cost) {amount})"


def _action(action: ActionSchema) -> str:
    return (
        f"  (:action {action.name}\n"
        f"    :parameters ({_typed(action.parameters)})\n"
        f"    :precondition {format_formula(action.precondition)}\n"
        f"    :effect {format_effect(action.effect)})\n"
    )


def write_domain(domain: Domain) -> str:
    """The domain as PDDL text; ``read_domain(write_domain(d)) == d``."""
    lines = [f"(define (domain {domain.name})\n"]
    if domain.requirements:
        lines.append(f"  (:requirements {' '.join(domain.requirements)})\n")
    if domain.types:
        lines.append(f"  (:types {_typed(TypedName(c, (p,)) for c, p in domain.types.items())})\n")
    if domain.constants:
        lines.append(f"  (:constants {_typed(domain.constants)})\n")
    lines.append("  (:predicates\n")
    for name, params in domain.predicates.items():
        lines.append(f"    ({' '.join(filter(None, (name, _typed(params))))})\n")
    lines.append("  )\n")
    if domain.functions:
        decls = " ".join(f"({' '.join(filter(None, (n, _typed(a))))}) - number" for n, a in domain.functions.items())
        lines.append(f"  (:functions {decls})\n")
    lines.extend(_action(a) for a in domain.actions)
    lines.append(")\n")
    return "".join(lines)


def write_problem(problem: Problem) -> str:
    """The problem as PDDL text; the reader gives back an equal :class:`Problem`."""
    lines = [f"(define (problem {problem.name})\n", f"  (:domain {problem.domain_name})\n"]
    if problem.objects:
        lines.append(f"  (:objects {_typed(problem.objects)})\n")
    lines.append("  (:init\n")
    lines.extend(f"    {fact}\n" for fact in problem.init)
    for (name, args), value in problem.numeric_init.items():
        lines.append(f"    (= ({' '.join((name, *args))}) {value})\n")
    lines.append("  )\n")
    lines.append(f"  (:goal {format_formula(problem.goal)})\n")
    if problem.minimize_cost:
        lines.append("  (:metric minimize (total-cost))\n")
    lines.append(")\n")
    return "".join(lines)


# ---------------------------------------------------------------- grounded
#: Words that PDDL parsers read as syntax where a predicate may stand (compared case-insensitively,
#: as Fast Downward and unified-planning lowercase every name).
PDDL_KEYWORDS = frozenset(
    {
        "and", "or", "not", "imply", "exists", "forall", "when", "either", "preference",
        "increase", "decrease", "assign", "scale-up", "scale-down",
    }
)  # fmt: skip


def keyword_safe_predicates(predicates: Iterable[str]) -> dict[str, str]:
    """New names for the predicates named like a PDDL keyword: ``Exists`` becomes ``Exists_``.

    Underscores are appended until the name is neither a keyword nor another predicate's name.
    """
    names = set(predicates)
    taken = {p.lower() for p in names}
    renamed: dict[str, str] = {}
    for predicate in sorted(names):
        if predicate.lower() not in PDDL_KEYWORDS:
            continue
        new = f"{predicate}_"
        while new.lower() in taken or new.lower() in PDDL_KEYWORDS:
            new += "_"
        taken.add(new.lower())
        renamed[predicate] = new
    return renamed


#: The prefix of the proposition written for a negated twin ``~p`` (see :mod:`hbtp.logic.negation`).
TWIN_PREFIX = "not-"


def _written(atom: Atom) -> Atom:
    """The proposition written for an atom of a task: a negated twin ``~P(a)`` is ``not-P(a)``."""
    return Atom(TWIN_PREFIX + atom.predicate, atom.args) if atom.negated else atom


def _ground_atom(atom: Atom, rename: dict[str, str] | None = None) -> str:
    atom = _written(atom)
    predicate = rename.get(atom.predicate, atom.predicate) if rename else atom.predicate
    return f"({' '.join((predicate, *atom.args))})"


#: The proposition and the action-name prefix of the compiled disjunctive goal (see :func:`write_grounded`).
GOAL_REACHED = "hbtp-goal-reached"
GOAL_ACTION = "hbtp-reach-goal-"


def _goal_formula(task: GroundTask, goal: Goal, rename: dict[str, str]) -> list[str]:
    """Each disjunct of the goal as a conjunction of PDDL atoms, the literals in the order the goal
    gives them."""
    written = {atom: position for position, atom in enumerate(goal.atoms)}

    def order(atom_id: int) -> tuple[int, int]:
        return written.get(task.atoms[atom_id], len(written)), atom_id

    return [" ".join(_ground_atom(task.atoms[i], rename) for i in sorted(d, key=order)) for d in goal.disjuncts]


def write_grounded(
    task: GroundTask, goal: Goal, domain_name: str | None = None, *, rename_keywords: bool = True
) -> tuple[str, str]:
    """A grounded task as a STRIPS + ``:action-costs`` domain and problem (one action per ground action).

    The encoding is exactly the task the planners search (static facts already compiled away), so
    an independent planner's optimal cost on it is directly comparable. A predicate named like a
    PDDL keyword (RoboWaiter's ``Exists``) makes Fast Downward and unified-planning fail; with
    ``rename_keywords`` such predicates are written as ``Exists_`` (see :func:`keyword_safe_predicates`).

    It is meant for other planners, not as a round trip: read back, its actions are parameterless
    (``Walk_milk()``), every name is a constant, and a literal that no action changes (``IsStanding``,
    kept in the state with ``keep_fluent``) becomes a static fact unless ``--keep-fluent`` names it
    again; a comment at the top of the domain names them. The lifted files round-trip.
    """
    name = domain_name or _pddl_name(task.name)
    used: dict[str, int] = {}  # predicate -> arity
    for atom in task.atoms:
        used.setdefault(_written(atom).predicate, len(atom.args))
    rename = keyword_safe_predicates(used) if rename_keywords else {}
    init = " ".join(_ground_atom(task.atoms[i], rename) for i in sorted(task.initial_state))
    terms = _goal_formula(task, goal, rename)
    problem = (
        f"(define (problem {name}-task)\n"
        f"  (:domain {name})\n"
        f"  (:init {init} (= (total-cost) 0))\n"
        f"  (:goal (and {terms[0] if len(terms) == 1 else f'({GOAL_REACHED})'}))\n"
        "  (:metric minimize (total-cost))\n"
        ")\n"
    )
    return _grounded_domain(task, name, used, rename, terms if len(terms) > 1 else []), problem


def _grounded_domain(
    task: GroundTask, name: str, used: dict[str, int], rename: dict[str, str], disjuncts: list[str]
) -> str:
    """The domain of :func:`write_grounded`: one parameterless action per ground action, and one
    free action per disjunct of a disjunctive goal."""
    symbols = [*task.constants, *task.objects]
    changed = {_written(task.atoms[i]).predicate for action in task.actions for i in (*action.add, *action.delete)}
    unchanged = sorted(rename.get(p, p) for p in used if p not in changed and p in task.predicates)
    domain = [
        f"(define (domain {name})\n",
        (
            f"  ; No action changes {', '.join(unchanged)}: to keep it in the state when reading this file\n"
            f"  ; back into hbtp, add {' '.join(f'--keep-fluent {p}' for p in unchanged)}\n"
            if unchanged
            else ""
        ),
        "  (:requirements :strips :action-costs)\n",
        f"  (:constants {' '.join(symbols)})\n" if symbols else "",
        "  (:predicates\n",
        *(
            f"    ({' '.join((rename.get(p, p), *(f'?a{i}' for i in range(arity))))})\n"
            for p, arity in sorted(used.items())
        ),
        f"    ({GOAL_REACHED})\n" if disjuncts else "",
        "  )\n",
        "  (:functions (total-cost) - number)\n",
    ]
    for action in task.actions:
        pre = " ".join(_ground_atom(task.atoms[i], rename) for i in sorted(action.pre))
        eff = [_ground_atom(task.atoms[i], rename) for i in sorted(action.add)]
        eff += [f"(not {_ground_atom(task.atoms[i], rename)})" for i in sorted(action.delete)]
        eff.append(f"(increase (total-cost) {action.cost})")
        domain.append(
            f"  (:action {action.signature.underscored}\n"
            f"    :parameters ()\n"
            f"    :precondition (and {pre})\n"
            f"    :effect (and {' '.join(eff)}))\n"
        )
    for number, disjunct in enumerate(disjuncts):
        domain.append(
            f"  (:action {GOAL_ACTION}{number}\n"
            f"    :parameters ()\n"
            f"    :precondition (and {disjunct})\n"
            f"    :effect (and ({GOAL_REACHED}) (increase (total-cost) 0)))\n"
        )
    domain.append(")\n")
    return "".join(domain)


def _pddl_name(text: str) -> str:
    cleaned = "".join(c if c.isalnum() or c in "-_" else "-" for c in text)
    return cleaned if cleaned[:1].isalpha() else f"d-{cleaned}"
