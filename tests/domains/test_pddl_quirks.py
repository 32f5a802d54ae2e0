"""What Fast Downward loads: case-insensitive names and the quirks its translator tolerates.

The quirks are read with a warning that names file:line:column; the shipped IPC benchmark files
(../shared/benchmarks/ipc, skipped when absent) all load.
"""

from __future__ import annotations

import re
from pathlib import Path

import pytest

from hbtp.bt.export import read_tree
from hbtp.bt.simulate import simulate
from hbtp.cli import main
from hbtp.domains import ground, read_domain, read_domain_file, read_problem, read_problem_file
from hbtp.domains.lifted import AtomFormula, TypedName
from hbtp.domains.scenarios import ScenarioOptions, load_pddl_scenario
from hbtp.errors import PddlError, UnknownSymbolError

DOMAIN = """\
(define (domain Blocks)
  (:requirements :STRIPS :Typing)
  (:types Block Place - object block - place)
  (:predicates (On ?x ?y) (CLEAR ?x - block) (in ?o ?o))
  (:action Stack :parameters (?x - BLOCK ?Y - block)
    :precondition (and (clear ?X) (CLEAR ?y))
    :effect (and (ON ?x ?y) (not (Clear ?y)))))
"""

PROBLEM = """\
(define (problem P) (:domain BLOCKS)
  (:objects A B - BLOCK c - block a - block)
  (:init (clear a) (CLEAR b) (Clear C))
  (:goal (ON A b)))
"""


def test_names_are_case_insensitive_and_keep_the_first_declared_spelling() -> None:
    domain = read_domain(DOMAIN, "d.pddl")
    assert domain.types == {"Block": "Place", "Place": "object"}
    (stack,) = domain.actions
    assert stack.parameters == (TypedName("?x", ("Block",)), TypedName("?Y", ("Block",)))
    problem = read_problem(PROBLEM, domain, "p.pddl")
    assert [o.name for o in problem.objects] == ["A", "B", "c"]
    assert AtomFormula("CLEAR", ("B",)) in problem.init
    assert problem.goal == AtomFormula("On", ("A", "B"))
    task = ground(domain, problem)
    assert "Stack(A,B)" in [a.name for a in task.actions]
    assert "On(A,B)" in [str(atom) for atom in task.atoms]


def test_tolerated_quirks_are_warnings_with_their_place(caplog: pytest.LogCaptureFixture) -> None:
    domain = read_domain(DOMAIN, "d.pddl")
    assert domain.predicates["in"] == (TypedName("?o"), TypedName("?o"))  # the arity is kept
    read_problem(PROBLEM, domain, "p.pddl")
    assert "d.pddl:3:32: type 'Block' is declared twice" in caplog.text
    assert "d.pddl:4:53: '?o' is declared twice" in caplog.text
    assert "p.pddl:2:35: 'a' is declared twice (already an object)" in caplog.text


def test_name_and_variable_run_together_are_split_with_a_warning(caplog: pytest.LogCaptureFixture) -> None:
    text = DOMAIN.replace("(clear ?X)", "(clear?X)")
    (stack,) = read_domain(text, "d.pddl").actions
    assert AtomFormula("CLEAR", ("?x",)) in stack.precondition.parts  # type: ignore[union-attr]
    assert "d.pddl:6:25: 'clear?X' read as 'clear ?X' (a missing space)" in caplog.text


def test_an_unknown_name_suggests_the_closest_declared_ones() -> None:
    domain = read_domain(DOMAIN, "d.pddl")
    with pytest.raises(PddlError, match=r"unknown predicate 'Clearr' \(did you mean 'CLEAR'\?\)") as info:
        read_problem(PROBLEM.replace("(CLEAR b)", "(Clearr b)"), domain, "p.pddl")
    assert (info.value.line, info.value.column) == (3, 20)


def test_still_refused_a_type_with_two_parents_and_an_object_twice_with_two_types() -> None:
    with pytest.raises(PddlError, match="'Block' is declared twice, with parents 'Place' and 'Thing'") as info:
        read_domain(DOMAIN.replace("Place - object block - place", "Place Thing - object block - place BLOCK - thing"))
    assert (info.value.line, info.value.column) == (3, 52)
    domain = read_domain(DOMAIN)
    with pytest.raises(PddlError, match="'a' is already an object, of another type"):
        read_problem(PROBLEM.replace("a - block", "a - place"), domain)


def test_goals_match_names_case_insensitively_and_show_the_declared_spelling() -> None:
    domain = read_domain(DOMAIN)
    task = ground(domain, read_problem(PROBLEM, domain))
    goal = task.resolve_goal("on(a,B) & clear(c)")
    assert [str(atom) for atom in goal.atoms] == ["On(A,B)", "CLEAR(c)"]
    assert task.atom_id("ON(a,b)") == task.atom_id("On(A,B)")
    assert task.action("stack(a,b)").name == "Stack(A,B)"
    with pytest.raises(UnknownSymbolError, match=r"unknown predicate 'onn'.*did you mean 'On'\?"):
        task.resolve_goal("onn(a,b)")
    with pytest.raises(UnknownSymbolError, match=r"unknown object 'cc'.*did you mean 'c'"):
        task.resolve_goal("on(a,cc)")


# ============================================================== IPC benchmarks
BENCHMARKS = Path(__file__).resolve().parents[2] / ".." / "shared" / "benchmarks" / "ipc"
DOMAINS = sorted(p.name for p in BENCHMARKS.iterdir() if (p / "domain.pddl").is_file()) if BENCHMARKS.is_dir() else []


def _smallest_instance(folder: Path) -> Path:
    problems = [p for p in folder.glob("*.pddl") if not p.name.startswith("domain")]
    return min(problems, key=lambda p: (p.stat().st_size, p.name))


@pytest.mark.skipif(not DOMAINS, reason="the IPC benchmark files (../shared/benchmarks/ipc) are absent")
@pytest.mark.parametrize("name", DOMAINS)
def test_every_shipped_ipc_domain_loads_and_grounds(name: str) -> None:
    folder = BENCHMARKS / name
    domain = read_domain_file(folder / "domain.pddl")
    problem_file = _smallest_instance(folder)
    task = ground(domain, read_problem_file(problem_file, domain))
    assert task.actions, problem_file
    assert re.fullmatch(r"[^\s()]+", task.actions[0].name.replace("(", "").replace(")", "")), task.actions[0].name


CONDITIONAL_ON_FLUENTS = """(define (domain ce)
  (:requirements :strips :conditional-effects)
  (:predicates (a) (b) (c) (d))
  (:action flip :parameters () :precondition (a) :effect (c))
  (:action go :parameters ()
    :precondition (a)
    :effect (and (b) (when (c) (d)))))
"""


def test_a_conditional_effect_on_fluents_is_planned_through_its_variants(tmp_path: Path) -> None:
    """``go`` adds (d) only when (c) holds before it: the plan flips first."""
    (tmp_path / "d.pddl").write_text(CONDITIONAL_ON_FLUENTS, encoding="utf-8")
    (tmp_path / "p.pddl").write_text(
        "(define (problem p) (:domain ce) (:init (a)) (:goal (and (b) (d))))", encoding="utf-8"
    )
    tree = tmp_path / "tree.json"
    argv = ["plan", "--pddl", str(tmp_path / "d.pddl"), str(tmp_path / "p.pddl"), "-p", "obtea", "-o", str(tree)]
    assert main(argv) == 0
    scenario = load_pddl_scenario(tmp_path / "d.pddl", tmp_path / "p.pddl", ScenarioOptions(name="ce"))
    extended, goal = scenario.resolve_goal(scenario.problem_goal())
    run = simulate(read_tree(tree, extended.task), extended.task)
    assert run.reached(goal)
    assert [extended.task.actions[i].name for i in run.executed] == ["flip()", "go-alt2()"]
