"""Conditional effects whose ``when`` condition is over fluents (issue 13 item 1): hbtp compiles each
ground action into one STRIPS variant per combination of conditions that hold
(:mod:`hbtp.domains.alternatives`). Random lifted domains are planned by OBTEA and checked against
an independent brute force that applies the PDDL semantics directly (every condition evaluated in
the state before the action, deletes before adds); every tree is verified, executed, and its
executed actions replayed by the brute force's semantics under their declared names."""

from __future__ import annotations

import itertools
import random
from pathlib import Path
from typing import Any

import pytest

from hbtp.bt import full_tree
from hbtp.bt.simulate import simulate
from hbtp.cli import main
from hbtp.domains.alternatives import MAX_ALTERNATIVES
from hbtp.domains.scenarios import ScenarioOptions, load_pddl_scenario
from hbtp.errors import GroundingError
from hbtp.logic.atoms import declared_action
from hbtp.planning import plan
from helpers import assert_obtea_optimal, cheapest

State = frozenset[tuple[str, ...]]
Formula = tuple[Any, ...]  # ("atom", p, terms) | ("not", f) | ("and"/"or", [f])
Literal = tuple[bool, str, tuple[str, ...]]  # (negated, predicate, terms)
# (condition, body, cost added): over the action's parameters, and ?q when quantified
When = tuple[Formula, list[Literal], int]


class RandomConditional:
    """A small random domain whose actions have conditional effects over fluents, some under a
    ``forall``, some nested, some adding to the cost, some with a static conjunct (``(marked ?q)``,
    which no action changes) beside the fluent ones."""

    def __init__(self, seed: int, conditional_costs: bool = True) -> None:
        self.rng = rng = random.Random(seed)
        self.conditional_costs = conditional_costs
        self.objects = [f"o{i}" for i in range(rng.randint(2, 3))]
        self.marked = sorted(rng.sample(self.objects, rng.randint(0, len(self.objects))))
        widest = 4 - len(self.objects)  # binary predicates over two objects only: the brute force stays small
        self.predicates = {f"p{i}": rng.randint(0, widest) if i else 0 for i in range(rng.randint(2, 4))}
        self.actions: list[dict[str, Any]] = []
        for number in range(rng.randint(2, 4)):
            arity = rng.randint(0, 2)
            params = [f"?x{i}" for i in range(arity)]
            self.actions.append(
                {
                    "name": f"a{number}",
                    "params": params,
                    "pre": ("and", [self._literal(params) for _ in range(rng.randint(0, 1))]),
                    "effects": [self._effect_literal(params) for _ in range(rng.randint(0, 2))],
                    "whens": [self._when(params) for _ in range(rng.randint(1, 2))],
                    "forall": self._when([*params, "?q"]) if rng.random() < 0.5 else None,
                    "nested": (self._when(params), self._when(params)) if rng.random() < 0.3 else None,
                    "cost": rng.randint(1, 4),
                }
            )
        atoms = [(p, *a) for p, n in sorted(self.predicates.items()) for a in itertools.product(self.objects, repeat=n)]
        fluents = frozenset(rng.sample(atoms, rng.randint(0, min(3, len(atoms)))))
        self.initial = fluents | {("marked", o) for o in self.marked}
        missing = [a for a in atoms if a not in fluents]
        self.goal = (
            "and",
            [
                ("atom", a[0], a[1:])
                for a in rng.sample(missing or atoms, min(len(missing or atoms), rng.randint(1, 2)))
            ],
        )

    def _atom(self, variables: list[str]) -> Formula:
        usable = sorted(p for p, n in self.predicates.items() if n == 0 or variables)
        name = self.rng.choice(usable)
        return ("atom", name, tuple(self.rng.choice(variables) for _ in range(self.predicates[name])))

    def _literal(self, variables: list[str]) -> Formula:
        atom = self._atom(variables)
        return ("not", atom) if self.rng.random() < 0.3 else atom

    def _effect_literal(self, variables: list[str]) -> Literal:
        atom = self._atom(variables)
        return (self.rng.random() < 0.4, atom[1], atom[2])

    def _when(self, variables: list[str]) -> When:
        rng = self.rng
        if rng.random() < 0.25:  # delete p if it holds, or add p if it does not (no variant needed)
            atom = self._atom(variables)
            holds = rng.random() < 0.5
            condition = ("and", [atom if holds else ("not", atom)])
            return condition, [(holds, atom[1], atom[2])], rng.choice([0, 0, 2]) if self.conditional_costs else 0
        parts = [self._literal(variables) for _ in range(rng.randint(1, 2))]
        if variables and rng.random() < 0.4:
            mark: Formula = ("atom", "marked", (rng.choice(variables),))
            parts.insert(rng.randint(0, len(parts)), mark if rng.random() < 0.7 else ("not", mark))
        condition = (rng.choice(["and", "and", "or"]), parts)
        body = [self._effect_literal(variables) for _ in range(rng.randint(1, 2))]
        return condition, body, rng.choice([0, 0, 1, 3]) if self.conditional_costs else 0

    # ------------------------------------------------------------------------------ the files
    def domain_text(self) -> str:
        predicates = " ".join(f"({' '.join((p, *(f'?y{i}' for i in range(n))))})" for p, n in self.predicates.items())
        predicates += " (marked ?y0)"
        actions = "".join(self._action_text(action) for action in self.actions)
        return (
            "(define (domain rc) (:requirements :adl :action-costs)\n"
            f"(:predicates {predicates}) (:functions (total-cost))\n{actions})"
        )

    def _action_text(self, action: dict[str, Any]) -> str:
        effects = [_literals(action["effects"]), *(_when_text(w) for w in action["whens"])]
        if action["forall"] is not None:
            effects.append(f"(forall (?q) {_when_text(action['forall'])})")
        if action["nested"] is not None:
            (condition, body, cost), inner = action["nested"]
            effects.append(f"(when {_pddl(condition)} (and {_literals(body)} {_cost(cost)} {_when_text(inner)}))")
        return (
            f"(:action {action['name']} :parameters ({' '.join(action['params'])}) :precondition {_pddl(action['pre'])}"
            f" :effect (and {' '.join(effects)} (increase (total-cost) {action['cost']})))\n"
        )

    def problem_text(self) -> str:
        init = " ".join(f"({' '.join(a)})" for a in sorted(self.initial))
        return (
            f"(define (problem r) (:domain rc) (:objects {' '.join(self.objects)})\n"
            f"(:init {init} (= (total-cost) 0)) (:goal {_pddl(self.goal)}) (:metric minimize (total-cost)))"
        )

    # ------------------------------------------------------------------------ brute force
    def holds(self, formula: Formula, state: State, binding: dict[str, str]) -> bool:
        kind = formula[0]
        if kind == "atom":
            return (formula[1], *(binding.get(t, t) for t in formula[2])) in state
        if kind == "not":
            return not self.holds(formula[1], state, binding)
        cases = (self.holds(f, state, binding) for f in formula[1])
        return all(cases) if kind == "and" else any(cases)

    def apply(self, name: str, args: tuple[str, ...], state: State) -> tuple[int, State] | None:
        """The cost and the next state of the ground action, ``None`` when it is not applicable."""
        action = next(a for a in self.actions if a["name"] == name)
        binding = dict(zip(action["params"], args, strict=True))
        if not self.holds(action["pre"], state, binding):
            return None
        fired: list[tuple[list[Literal], int, dict[str, str]]] = [(action["effects"], action["cost"], binding)]
        whens = [(w, binding) for w in action["whens"]]
        if action["forall"] is not None:
            whens += [(action["forall"], {**binding, "?q": o}) for o in self.objects]
        if action["nested"] is not None and self.holds(action["nested"][0][0], state, binding):
            whens += [(action["nested"][0], binding), (action["nested"][1], binding)]
        for (condition, body, cost), values in whens:
            if self.holds(condition, state, values):
                fired.append((body, cost, values))
        adds = {(p, *(v[t] for t in terms)) for body, _, v in fired for neg, p, terms in body if not neg}
        deletes = {(p, *(v[t] for t in terms)) for body, _, v in fired for neg, p, terms in body if neg}
        return sum(cost for _, cost, _ in fired), frozenset((state - deletes) | adds)

    def successors(self, state: State) -> list[tuple[int, State]]:
        found = []
        for action in self.actions:
            for args in itertools.product(self.objects, repeat=len(action["params"])):
                step = self.apply(action["name"], args, state)
                if step is not None:
                    found.append(step)
        return found

    def optimum(self) -> int | None:
        return cheapest(self.initial, lambda state: self.holds(self.goal, state, {}), self.successors)


def _pddl(formula: Formula) -> str:
    kind = formula[0]
    if kind == "atom":
        return f"({' '.join((formula[1], *formula[2]))})"
    if kind == "not":
        return f"(not {_pddl(formula[1])})"
    return f"({kind} {' '.join(_pddl(f) for f in formula[1])})"


def _literals(literals: list[Literal]) -> str:
    atoms = [(neg, f"({' '.join((p, *terms))})") for neg, p, terms in literals]
    return " ".join(f"(not {atom})" if neg else atom for neg, atom in atoms)


def _cost(cost: int) -> str:
    return f"(increase (total-cost) {cost})" if cost else ""


def _when_text(when: When) -> str:
    condition, body, cost = when
    return f"(when {_pddl(condition)} (and {_literals(body)} {_cost(cost)}))"


def _write(case: RandomConditional, folder: Path) -> tuple[Path, Path]:
    domain, problem = folder / "d.pddl", folder / "p.pddl"
    domain.write_text(case.domain_text(), encoding="utf-8")
    problem.write_text(case.problem_text(), encoding="utf-8")
    return domain, problem


def _replayed(case: RandomConditional, task: Any, executed: tuple[int, ...]) -> tuple[int, State] | None:
    """The executed ground actions replayed from s0 by the brute force's semantics, under their
    declared names; ``None`` if one of them is not applicable there."""
    state, total = case.initial, 0
    for index in executed:
        action = task.actions[index]
        step = case.apply(declared_action(action.predicate), action.objects, state)
        if step is None:
            return None
        total, state = total + step[0], step[1]
    return total, state


@pytest.mark.parametrize("seed", range(200))
def test_conditional_effects_over_fluents_against_brute_force(seed: int, tmp_path: Path) -> None:
    case = RandomConditional(seed)
    where = f"seed={seed}\n{case.domain_text()}\n{case.problem_text()}"
    scenario = load_pddl_scenario(*_write(case, tmp_path), ScenarioOptions(name="rc"))
    optimum = case.optimum()
    extended, goal = scenario.resolve_goal(scenario.problem_goal())
    for run in assert_obtea_optimal(extended.task, goal, extended.mutexes, optimum, where):
        replayed = _replayed(case, extended.task, run.executed)
        assert replayed is not None, where
        assert replayed[0] == optimum, where
        assert case.holds(case.goal, replayed[1], {}), where


def test_the_random_cases_exercise_what_they_claim(tmp_path: Path) -> None:
    """Enough random cases need a plan whose actions are variants with conditions that hold."""
    fired = 0
    for seed in range(200):
        case = RandomConditional(seed)
        if not case.optimum():
            continue
        folder = tmp_path / str(seed)
        folder.mkdir()
        scenario = load_pddl_scenario(*_write(case, folder), ScenarioOptions(name="rc"))
        extended, goal = scenario.resolve_goal(scenario.problem_goal())
        result = plan(extended.task, goal, "obtea", mutexes=extended.mutexes)
        fired += any(
            "-alt" in extended.task.actions[i].name
            for i in simulate(full_tree(result.expansions), extended.task).executed
        )
    assert fired >= 30


BRIEFCASE = """(define (domain briefcase)
 (:requirements :strips :typing :conditional-effects :negative-preconditions)
 (:types portable location)
 (:predicates (at ?y - portable ?x - location) (in ?x - portable) (is-at ?x - location))
 (:action move :parameters (?m ?l - location)
  :precondition (and (is-at ?m) (not (= ?m ?l)))
  :effect (and (is-at ?l) (not (is-at ?m))
    (forall (?x - portable) (when (in ?x) (and (at ?x ?l) (not (at ?x ?m)))))))
 (:action take-out :parameters (?x - portable) :precondition (in ?x) :effect (not (in ?x)))
 (:action put-in :parameters (?x - portable ?l - location)
  :precondition (and (not (in ?x)) (at ?x ?l) (is-at ?l)) :effect (in ?x)))"""


def _briefcase(tmp_path: Path, portables: int) -> tuple[Path, Path]:
    names = " ".join(f"b{i}" for i in range(portables))
    at = " ".join(f"(at b{i} home)" for i in range(portables))
    goal = " ".join(f"(at b{i} office)" for i in range(portables))
    (tmp_path / "d.pddl").write_text(BRIEFCASE, encoding="utf-8")
    (tmp_path / "p.pddl").write_text(
        f"(define (problem b) (:domain briefcase) (:objects home office - location {names} - portable)"
        f" (:init {at} (is-at home)) (:goal (and {goal} (is-at home))))",
        encoding="utf-8",
    )
    return tmp_path / "d.pddl", tmp_path / "p.pddl"


def test_briefcase_moves_what_is_in_the_case(tmp_path: Path) -> None:
    """Moving takes along exactly what is in the case: one variant of move per subset of portables
    in it, and the optimal plan puts everything in, moves, takes everything out, moves back."""
    scenario = load_pddl_scenario(*_briefcase(tmp_path, 2), ScenarioOptions(name="b"))
    task = scenario.task
    moves = sorted(a.name for a in task.actions if a.name.startswith("move") and a.objects == ("home", "office"))
    assert len(moves) == 4  # neither, b0, b1, both in the case
    carried = {frozenset(task.names(task.action(m).add)) for m in moves}
    assert carried == {
        frozenset({"is-at(office)"}),
        frozenset({"is-at(office)", "at(b0,office)"}),
        frozenset({"is-at(office)", "at(b1,office)"}),
        frozenset({"is-at(office)", "at(b0,office)", "at(b1,office)"}),
    }
    extended, goal = scenario.resolve_goal(scenario.problem_goal())
    result = plan(extended.task, goal, "obtea", mutexes=extended.mutexes)
    assert result.cost == 6  # put-in twice, move, take-out twice, move back
    assert simulate(full_tree(result.expansions), extended.task).reached(goal)


def test_the_plan_command_solves_briefcase(tmp_path: Path) -> None:
    domain, problem = _briefcase(tmp_path, 3)
    tree = tmp_path / "tree.json"
    assert main(["plan", "--pddl", str(domain), str(problem), "-p", "obtea", "-o", str(tree)]) == 0
    assert tree.is_file()


def test_too_many_combinations_are_refused_in_one_line(tmp_path: Path, capsys: pytest.CaptureFixture[str]) -> None:
    portables = MAX_ALTERNATIVES.bit_length()  # 2**portables variants of one move
    domain, problem = _briefcase(tmp_path, portables)
    with pytest.raises(GroundingError, match=f"more than {MAX_ALTERNATIVES:,} alternatives") as info:
        load_pddl_scenario(domain, problem, ScenarioOptions(name="b"))
    assert str(info.value).startswith(f"{domain}:5:2: action 'move': ")
    tree = tmp_path / "tree.json"
    assert main(["plan", "--pddl", str(domain), str(problem), "-o", str(tree)]) == 2
    assert capsys.readouterr().err.strip().count("\n") == 0
    assert not tree.exists()


@pytest.mark.validate
def test_fast_downwards_own_translator_agrees_on_random_conditional_effects(tmp_path: Path) -> None:
    """Fast Downward keeps conditional effects (A* with h_max, as LM-cut refuses them); its optimum
    on the original files equals OBTEA's on the compiled variants."""
    pytest.importorskip("up_fast_downward")
    from hbtp.validation import lifted_fast_downward_cost

    for seed in range(30):
        case = RandomConditional(seed, conditional_costs=False)
        folder = tmp_path / str(seed)
        folder.mkdir()
        domain, problem = _write(case, folder)
        scenario = load_pddl_scenario(domain, problem, ScenarioOptions(name="rc"))
        extended, goal = scenario.resolve_goal(scenario.problem_goal())
        result = plan(extended.task, goal, "obtea", mutexes=extended.mutexes)
        expected = result.cost if result.solved else None
        assert lifted_fast_downward_cost(domain, problem, time_limit=30) == expected, seed
