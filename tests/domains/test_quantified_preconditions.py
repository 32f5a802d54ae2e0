"""PDDL preconditions and goals with ``or``, ``not``, ``imply``, ``exists`` and ``forall`` over fluents
(issue 11 item 3, issue 13 item 1): random lifted domains, grounded by hbtp (quantifiers expanded,
disjunctions split into one ground action per alternative) and evaluated by an independent brute
force written here, which reads the formulas directly; OBTEA's cost is checked against the
brute-force optimum, and every tree is verified and executed."""

from __future__ import annotations

import itertools
import random
from pathlib import Path
from typing import Any

import pytest

from hbtp.cli import main
from hbtp.domains.scenarios import ScenarioOptions, load_pddl_scenario
from hbtp.errors import GroundingError, InputError
from hbtp.planning import plan
from helpers import ROAD_OR_RAIL_DOMAIN, assert_obtea_optimal, cheapest

Ground = frozenset[tuple[str, ...]]
Formula = tuple[
    Any, ...
]  # ("atom", p, terms) | ("not", f) | ("and"/"or", [f]) | ("imply", f, g) | ("exists"/"forall", v, f)


class RandomQuantified:
    """A small random domain whose preconditions and goal are random formulas over fluents."""

    def __init__(self, seed: int) -> None:
        self.rng = rng = random.Random(seed)
        self.objects = [f"o{i}" for i in range(rng.randint(2, 3))]
        self.predicates = {f"p{i}": rng.randint(0, 2) if i else 0 for i in range(rng.randint(2, 3))}
        self.actions: list[tuple[str, int, Formula, list[tuple[bool, str, tuple[int, ...]]], int]] = []
        for number in range(rng.randint(2, 4)):
            arity = rng.randint(0, 2)
            params = [f"?x{i}" for i in range(arity)]
            pre = self._formula(params, depth=2, quantifiers=0)
            effects = [
                (rng.random() < 0.4, p, tuple(rng.randrange(arity) for _ in range(n)))
                for p, n in (self._predicate(arity) for _ in range(rng.randint(1, 3)))
            ]
            self.actions.append((f"a{number}", arity, pre, effects, rng.randint(1, 5)))
        atoms = [(p, *a) for p, n in sorted(self.predicates.items()) for a in itertools.product(self.objects, repeat=n)]
        self.initial = frozenset(rng.sample(atoms, rng.randint(0, min(3, len(atoms)))))
        self.goal = self._formula([], depth=2, quantifiers=0)

    def _predicate(self, arity: int) -> tuple[str, int]:
        usable = sorted(p for p, n in self.predicates.items() if n == 0 or arity > 0)
        name = self.rng.choice(usable)
        return name, self.predicates[name]

    def _formula(self, variables: list[str], depth: int, quantifiers: int) -> Formula:
        rng = self.rng
        kind = rng.choice(["atom", "atom", "not", "and", "or", "imply", "exists", "forall"]) if depth else "atom"
        if kind == "atom" or (kind in ("exists", "forall") and quantifiers >= 2):
            name, n = self._predicate(len(variables))
            return ("atom", name, tuple(rng.choice(variables) for _ in range(n)))
        if kind == "not":
            return ("not", self._formula(variables, depth - 1, quantifiers))
        if kind in ("and", "or"):
            return (kind, [self._formula(variables, depth - 1, quantifiers) for _ in range(rng.randint(1, 3))])
        if kind == "imply":
            return ("imply", self._formula(variables, depth - 1, quantifiers), self._formula(variables, 0, quantifiers))
        bound = f"?q{quantifiers}"
        return (kind, bound, self._formula([*variables, bound], depth - 1, quantifiers + 1))

    # ------------------------------------------------------------------------------ the files
    def domain_text(self) -> str:
        predicates = " ".join(f"({' '.join((p, *(f'?y{i}' for i in range(n))))})" for p, n in self.predicates.items())
        actions = "".join(
            f"(:action {name} :parameters ({' '.join(f'?x{i}' for i in range(arity))}) "
            f":precondition {_pddl(pre)} :effect (and {_effects(effects)} (increase (total-cost) {cost})))\n"
            for name, arity, pre, effects, cost in self.actions
        )
        return (
            "(define (domain rq) (:requirements :adl :action-costs)\n"
            f"(:predicates {predicates}) (:functions (total-cost))\n{actions})"
        )

    def problem_text(self) -> str:
        init = " ".join(f"({' '.join(a)})" for a in sorted(self.initial))
        return (
            f"(define (problem r) (:domain rq) (:objects {' '.join(self.objects)})\n"
            f"(:init {init} (= (total-cost) 0)) (:goal {_pddl(self.goal)}) (:metric minimize (total-cost)))"
        )

    # ------------------------------------------------------------------------ brute force
    def holds(self, formula: Formula, state: Ground, binding: dict[str, str]) -> bool:
        kind = formula[0]
        if kind == "atom":
            return (formula[1], *(binding[t] for t in formula[2])) in state
        if kind == "not":
            return not self.holds(formula[1], state, binding)
        if kind == "and":
            return all(self.holds(f, state, binding) for f in formula[1])
        if kind == "or":
            return any(self.holds(f, state, binding) for f in formula[1])
        if kind == "imply":
            return not self.holds(formula[1], state, binding) or self.holds(formula[2], state, binding)
        cases = (self.holds(formula[2], state, {**binding, formula[1]: o}) for o in self.objects)
        return any(cases) if kind == "exists" else all(cases)

    def successors(self, state: Ground) -> list[tuple[int, Ground]]:
        found = []
        for _name, arity, pre, effects, cost in self.actions:
            for args in itertools.product(self.objects, repeat=arity):
                if self.holds(pre, state, {f"?x{i}": a for i, a in enumerate(args)}):
                    adds = {(p, *(args[i] for i in pos)) for neg, p, pos in effects if not neg}
                    deletes = {(p, *(args[i] for i in pos)) for neg, p, pos in effects if neg}
                    found.append((cost, frozenset((state - deletes) | adds)))
        return found

    def optimum(self) -> int | None:
        return cheapest(self.initial, lambda state: self.holds(self.goal, state, {}), self.successors)


def _pddl(formula: Formula) -> str:
    kind = formula[0]
    if kind == "atom":
        return f"({' '.join((formula[1], *formula[2]))})"
    if kind == "not":
        return f"(not {_pddl(formula[1])})"
    if kind in ("and", "or"):
        return f"({kind} {' '.join(_pddl(f) for f in formula[1])})"
    if kind == "imply":
        return f"(imply {_pddl(formula[1])} {_pddl(formula[2])})"
    return f"({kind} ({formula[1]}) {_pddl(formula[2])})"


def _effects(effects: list[tuple[bool, str, tuple[int, ...]]]) -> str:
    atoms = [(neg, f"({' '.join((p, *(f'?x{i}' for i in pos)))})") for neg, p, pos in effects]
    return " ".join(f"(not {atom})" if neg else atom for neg, atom in atoms)


def _scenario(case: RandomQuantified, tmp_path: Path) -> Any:
    (tmp_path / "d.pddl").write_text(case.domain_text(), encoding="utf-8")
    (tmp_path / "p.pddl").write_text(case.problem_text(), encoding="utf-8")
    return load_pddl_scenario(tmp_path / "d.pddl", tmp_path / "p.pddl", ScenarioOptions(name="rq"))


@pytest.mark.parametrize("seed", range(200))
def test_quantified_and_disjunctive_conditions_against_brute_force(seed: int, tmp_path: Path) -> None:
    case = RandomQuantified(seed)
    where = f"seed={seed}\n{case.domain_text()}\n{case.problem_text()}"
    scenario = _scenario(case, tmp_path)
    optimum = case.optimum()
    try:
        goal_text = scenario.problem_goal()
    except InputError as error:  # the goal is decided by its quantifiers alone
        decided = str(error)
    else:
        decided = ""
    if decided:
        assert ("always" in decided and optimum == 0) or ("never" in decided and optimum is None), where
        return
    extended, goal = scenario.resolve_goal(goal_text)
    assert_obtea_optimal(extended.task, goal, extended.mutexes, optimum, where)


def test_the_random_cases_exercise_what_they_claim(tmp_path: Path) -> None:
    """Enough random cases need a plan, use quantifiers, and have actions split into alternatives."""
    cases = [RandomQuantified(seed) for seed in range(200)]
    assert sum((case.optimum() or 0) > 0 for case in cases) >= 40
    assert sum("exists" in c.domain_text() or "forall" in c.domain_text() for c in cases) >= 100
    split = 0
    for seed, case in enumerate(cases):
        folder = tmp_path / str(seed)
        folder.mkdir()
        split += any("-alt" in a.name for a in _scenario(case, folder).task.actions)
    assert split >= 60


def test_a_disjunctive_precondition_gives_one_action_per_alternative(tmp_path: Path) -> None:
    (tmp_path / "d.pddl").write_text(ROAD_OR_RAIL_DOMAIN, encoding="utf-8")
    (tmp_path / "p.pddl").write_text(
        "(define (problem p) (:domain d) (:objects x y z) (:init (at x) (rail x y) (rail y z)) (:goal (at z)))",
        encoding="utf-8",
    )
    scenario = load_pddl_scenario(tmp_path / "d.pddl", tmp_path / "p.pddl", ScenarioOptions(name="d"))
    task = scenario.task
    pres = {a.name: task.names(a.pre) for a in task.actions if a.predicate.startswith("go") and a.objects == ("y", "z")}
    assert pres == {"go(y,z)": ["at(y)", "road(y,z)"], "go-alt2(y,z)": ["at(y)", "rail(y,z)"]}  # as written
    assert task.action("go(y,z)").add == task.action("go-alt2(y,z)").add
    assert main(["plan", "--pddl", str(tmp_path / "d.pddl"), str(tmp_path / "p.pddl"), "-p", "obtea"]) == 0


def test_forall_in_a_precondition_expands_over_the_objects_of_its_type(tmp_path: Path) -> None:
    (tmp_path / "d.pddl").write_text(
        "(define (domain d) (:requirements :typing :universal-preconditions) (:types box room)"
        " (:predicates (closed ?b - box) (done))"
        " (:action close :parameters (?b - box) :precondition (not (closed ?b)) :effect (closed ?b))"
        " (:action finish :parameters () :precondition (forall (?b - box) (closed ?b)) :effect (done)))",
        encoding="utf-8",
    )
    (tmp_path / "p.pddl").write_text(
        "(define (problem p) (:domain d) (:objects b1 b2 - box r - room) (:init (closed b1))"
        " (:goal (and (done) (exists (?b - box) (closed ?b)))))",
        encoding="utf-8",
    )
    scenario = load_pddl_scenario(tmp_path / "d.pddl", tmp_path / "p.pddl", ScenarioOptions(name="d"))
    assert scenario.task.names(scenario.task.action("finish()").pre) == ["closed(b1)", "closed(b2)"]
    extended, goal = scenario.resolve_goal(scenario.problem_goal())
    result = plan(extended.task, goal, "obtea", mutexes=extended.mutexes)
    assert result.solved
    assert result.cost == 2


def test_an_alternative_named_like_a_declared_action_is_refused(tmp_path: Path) -> None:
    (tmp_path / "d.pddl").write_text(
        "(define (domain d) (:requirements :adl) (:predicates (p) (q) (r))"
        " (:action go :parameters () :precondition (or (p) (q)) :effect (r))"
        " (:action go-alt2 :parameters () :precondition (p) :effect (r)))",
        encoding="utf-8",
    )
    (tmp_path / "p.pddl").write_text("(define (problem p) (:domain d) (:init (p)) (:goal (r)))", encoding="utf-8")
    with pytest.raises(GroundingError, match="declares an action 'go-alt2'"):
        load_pddl_scenario(tmp_path / "d.pddl", tmp_path / "p.pddl", ScenarioOptions(name="d"))


def test_a_huge_forall_is_refused_in_one_line(tmp_path: Path) -> None:
    objects = " ".join(f"o{i}" for i in range(60))
    (tmp_path / "d.pddl").write_text(
        "(define (domain d) (:requirements :adl) (:predicates (p ?a ?b ?c) (r))"
        " (:action go :parameters () :precondition (forall (?a ?b ?c) (p ?a ?b ?c)) :effect (r)))",
        encoding="utf-8",
    )
    (tmp_path / "p.pddl").write_text(
        f"(define (problem p) (:domain d) (:objects {objects}) (:init) (:goal (r)))", encoding="utf-8"
    )
    code = main(["plan", "--pddl", str(tmp_path / "d.pddl"), str(tmp_path / "p.pddl")])
    assert code == 2


@pytest.mark.validate
def test_fast_downwards_own_translator_agrees_on_random_quantified_domains(tmp_path: Path) -> None:
    """Fast Downward reads the original files with its translator; its optimum equals OBTEA's."""
    pytest.importorskip("up_fast_downward")
    from hbtp.validation import lifted_fast_downward_cost

    checked = 0
    for seed in range(40):
        case = RandomQuantified(seed)
        folder = tmp_path / str(seed)
        folder.mkdir()
        scenario = _scenario(case, folder)
        try:
            extended, goal = scenario.resolve_goal(scenario.problem_goal())
        except InputError:
            continue  # a goal decided by its quantifiers alone
        result = plan(extended.task, goal, "obtea", mutexes=extended.mutexes)
        expected = result.cost if result.solved else None
        assert lifted_fast_downward_cost(folder / "d.pddl", folder / "p.pddl", time_limit=30) == expected, seed
        checked += 1
    assert checked >= 30
