"""PDDL with ``:negative-preconditions`` and goals with ``or``/``not`` (issue 11, item 3; issue 13):
random lifted domains, grounded by hbtp and by an independent brute force written here, planned by
OBTEA and checked against the brute-force optimum; every tree verified and executed."""

from __future__ import annotations

import itertools
import random
from collections.abc import Callable
from pathlib import Path

import pytest

from hbtp.cli import main
from hbtp.domains.grounding import ground
from hbtp.domains.mutex import infer_mutexes
from hbtp.domains.pddl_reader import read_domain, read_problem
from hbtp.domains.scenarios import ScenarioOptions, load_pddl_scenario
from helpers import assert_obtea_optimal, cheapest

Ground = frozenset[tuple[str, ...]]  # a state: ground atoms as (predicate, *objects)


class RandomPddl:
    """A small random STRIPS domain with negative preconditions, a problem, and a DNF goal."""

    def __init__(self, seed: int) -> None:
        rng = random.Random(seed)
        self.objects = [f"o{i}" for i in range(rng.randint(2, 3))]
        self.predicates = {f"p{i}": rng.randint(0, 2) for i in range(rng.randint(2, 4))}
        self.actions: list[
            tuple[str, int, list[tuple[bool, str, tuple[int, ...]]], list[tuple[bool, str, tuple[int, ...]]], int]
        ] = []
        for number in range(rng.randint(2, 4)):
            arity = rng.randint(1, 2)
            pre = [self._literal(rng, arity, rng.random() < 0.4) for _ in range(rng.randint(0, 2))]
            effects = [self._literal(rng, arity, rng.random() < 0.4) for _ in range(rng.randint(1, 3))]
            self.actions.append((f"a{number}", arity, pre, effects, rng.randint(1, 5)))
        atoms = self.ground_atoms()
        changed = {p for *_, effects, _cost in self.actions for _neg, p, _pos in effects}
        goal_atoms = [a for a in atoms if a[0] in changed]  # a goal on a predicate no action changes is static
        self.initial = frozenset(rng.sample(atoms, rng.randint(0, min(3, len(atoms)))))
        self.goal = [
            [(rng.random() < 0.35, atom) for atom in rng.sample(goal_atoms, rng.randint(1, min(2, len(goal_atoms))))]
            for _ in range(rng.randint(1, 2))
        ]

    def _literal(self, rng: random.Random, arity: int, negative: bool) -> tuple[bool, str, tuple[int, ...]]:
        predicate = rng.choice(sorted(self.predicates))
        return negative, predicate, tuple(rng.randrange(arity) for _ in range(self.predicates[predicate]))

    def ground_atoms(self) -> list[tuple[str, ...]]:
        return [
            (p, *args) for p, n in sorted(self.predicates.items()) for args in itertools.product(self.objects, repeat=n)
        ]

    # ------------------------------------------------------------------------------ the files
    def domain_text(self) -> str:
        def formula(literals: list[tuple[bool, str, tuple[int, ...]]]) -> str:
            parts = []
            for negative, predicate, positions in literals:
                atom = f"({' '.join((predicate, *(f'?x{i}' for i in positions)))})"
                parts.append(f"(not {atom})" if negative else atom)
            return f"(and {' '.join(parts)})"

        predicates = " ".join(f"({' '.join((p, *(f'?y{i}' for i in range(n))))})" for p, n in self.predicates.items())
        actions = "".join(
            f"(:action {name} :parameters ({' '.join(f'?x{i}' for i in range(arity))}) "
            f":precondition {formula(pre)} :effect (and {formula(effects)[5:-1]} (increase (total-cost) {cost})))\n"
            for name, arity, pre, effects, cost in self.actions
        )
        return (
            "(define (domain rand) (:requirements :strips :negative-preconditions :action-costs)\n"
            f"(:predicates {predicates}) (:functions (total-cost))\n{actions})"
        )

    def problem_text(self) -> str:
        init = " ".join(f"({' '.join(a)})" for a in sorted(self.initial))
        terms = []
        for term in self.goal:
            literals = [f"(not ({' '.join(a)}))" if negative else f"({' '.join(a)})" for negative, a in term]
            terms.append(f"(and {' '.join(literals)})")
        goal = terms[0] if len(terms) == 1 else f"(or {' '.join(terms)})"
        return (
            f"(define (problem r) (:domain rand) (:objects {' '.join(self.objects)})\n"
            f"(:init {init} (= (total-cost) 0)) (:goal {goal}) (:metric minimize (total-cost)))"
        )

    # ------------------------------------------------------------------------ brute force
    def holds(self, state: Ground) -> bool:
        return any(all((atom in state) != negative for negative, atom in term) for term in self.goal)

    def successors(self, state: Ground) -> list[tuple[int, Ground]]:
        found = []
        for _name, arity, pre, effects, cost in self.actions:
            for args in itertools.product(self.objects, repeat=arity):
                if all((_grounded(p, pos, args) in state) != neg for neg, p, pos in pre):
                    adds = {_grounded(p, pos, args) for neg, p, pos in effects if not neg}
                    deletes = {_grounded(p, pos, args) for neg, p, pos in effects if neg}
                    found.append((cost, frozenset((state - deletes) | adds)))
        return found

    def optimum(self) -> int | None:
        return cheapest(self.initial, self.holds, self.successors)


def _grounded(predicate: str, positions: tuple[int, ...], args: tuple[str, ...]) -> tuple[str, ...]:
    return (predicate, *(args[i] for i in positions))


@pytest.mark.parametrize("seed", range(300))
def test_negative_preconditions_and_dnf_goals_against_brute_force(seed: int, tmp_path: Path) -> None:
    case = RandomPddl(seed)
    (tmp_path / "d.pddl").write_text(case.domain_text(), encoding="utf-8")
    (tmp_path / "p.pddl").write_text(case.problem_text(), encoding="utf-8")
    scenario = load_pddl_scenario(tmp_path / "d.pddl", tmp_path / "p.pddl", ScenarioOptions(name="rand"))
    extended, goal = scenario.resolve_goal(scenario.problem_goal())
    optimum = case.optimum()
    where = f"seed={seed}\n{case.domain_text()}\n{case.problem_text()}"
    assert_obtea_optimal(extended.task, goal, extended.mutexes, optimum, where)


def test_grounding_keeps_the_twins_exact() -> None:
    domain = read_domain(
        "(define (domain d) (:requirements :negative-preconditions) (:predicates (on ?x) (lit))"
        "(:action flip :parameters (?x) :precondition (not (on ?x)) :effect (and (on ?x) (not (lit)))))"
    )
    problem = read_problem("(define (problem p) (:domain d) (:objects a b) (:init (on a)) (:goal (on b)))", domain)
    task = ground(domain, problem)
    assert [str(a) for a in task.atoms] == ["lit()", "on(a)", "on(b)", "~on(a)", "~on(b)"]
    flip_b = task.action("flip(b)")
    assert task.names(flip_b.pre) == ["~on(b)"]
    assert task.names(flip_b.delete) == ["lit()", "~on(b)"]
    assert task.names(task.initial_state) == ["on(a)", "~on(b)"]
    assert infer_mutexes(task).conflict(task.atom_ids.values()) is not None
    assert not task.action("flip(a)").pre <= task.initial_state


def test_reachability_takes_negative_preconditions_as_reachable(tmp_path: Path) -> None:
    (tmp_path / "d.pddl").write_text(
        "(define (domain d) (:requirements :negative-preconditions) (:predicates (done) (blocked))"
        "(:action go :parameters () :precondition (not (blocked)) :effect (done)))",
        encoding="utf-8",
    )
    (tmp_path / "p.pddl").write_text(
        "(define (problem p) (:domain d) (:init) (:goal (and (done) (not (blocked)))))", encoding="utf-8"
    )
    assert main(["plan", "--pddl", str(tmp_path / "d.pddl"), str(tmp_path / "p.pddl"), "-p", "obtea"]) == 0


def _count(predicate: Callable[[int], bool]) -> int:
    return sum(predicate(seed) for seed in range(300))


def test_the_random_cases_exercise_what_they_claim() -> None:
    """Enough of the random cases are solvable with a plan, and use negative preconditions."""
    assert _count(lambda s: (RandomPddl(s).optimum() or 0) > 0) >= 60
    assert _count(lambda s: any(neg for _n, _a, pre, _e, _c in RandomPddl(s).actions for neg, _p, _q in pre)) >= 100
