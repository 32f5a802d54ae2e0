"""Goals with "or" and "not" (issue 11, item 2): parsing into DNF, resolution, the negated twins,
and planning over a disjunction, each checked against a brute-force optimum on random tasks."""

from __future__ import annotations

import random
from collections.abc import Callable

import pytest

from hbtp.bt import full_tree, path_tree
from hbtp.bt.btcpp import tree_from_btcpp, tree_to_btcpp
from hbtp.bt.disturb import disturbed_runs
from hbtp.bt.simulate import simulate
from hbtp.bt.verify import verify
from hbtp.domains import infer_mutexes, load_scenario
from hbtp.domains.mutex import with_negation_groups
from hbtp.errors import InputError
from hbtp.logic.atoms import Atom
from hbtp.logic.goals import MAX_TERMS, format_goal, parse_goal
from hbtp.logic.negation import with_negations
from hbtp.logic.resolve import negations_needed
from hbtp.logic.task import GroundTask
from hbtp.planning import Status, plan
from helpers import brute_force, kitchen_builder, random_task

A, B, C, D = (Atom(name) for name in "ABCD")


@pytest.fixture(scope="module")
def kitchen() -> GroundTask:
    return kitchen_builder().build()


# ------------------------------------------------------------------------------------- parsing
@pytest.mark.parametrize(
    ("text", "terms"),
    [
        ("A & B | C", ((A, B), (C,))),
        ("A & (B | C)", ((A, B), (A, C))),
        ("~(A | B)", ((A.negate(), B.negate()),)),
        ("~(A & B)", ((A.negate(),), (B.negate(),))),
        ("~~A", ((A,),)),
        ("A | A & B | A", ((A,), (A, B))),
        ("(or (A) (and (B) (not (C))))", ((A,), (B, C.negate()))),
        ("(imply (A) (B))", ((A.negate(),), (B,))),
        ("(and (on a b) (not (clear a)))", ((Atom("on", ("a", "b")), Atom("clear", ("a",), True)),)),
        (
            "IsIn(milk,fridge) | ~IsOpen_fridge",
            ((Atom("IsIn", ("milk", "fridge")),), (Atom("IsOpen", ("fridge",), True),)),
        ),
        ("(IsIn(milk,fridge))", ((Atom("IsIn", ("milk", "fridge")),),)),
    ],
)
def test_goal_texts_read_into_disjunctive_normal_form(text: str, terms: tuple[tuple[Atom, ...], ...]) -> None:
    assert parse_goal(text) == terms


def test_format_goal_reads_back() -> None:
    terms = parse_goal("IsIn_milk_fridge & ~IsOpen_fridge | IsOn_milk_table")
    assert format_goal(terms) == "IsIn_milk_fridge & ~IsOpen_fridge | IsOn_milk_table"
    assert parse_goal(format_goal(terms)) == terms


@pytest.mark.parametrize(
    ("text", "message"),
    [
        ("A &", "expected a literal at character 4"),
        ("A | | B", "unexpected '|'"),
        ("(A | B", "expected ')'"),
        ("A B", "unexpected 'B'"),
        ("(and (on a) (not))", "takes 1 condition"),
        ("(and (on a)", "ends too early"),
        ("   ", "empty goal"),
        ("A(x,)", "unexpected ')'"),
    ],
)
def test_malformed_goals_are_one_line_errors(text: str, message: str) -> None:
    with pytest.raises(InputError, match=message.replace("(", r"\(").replace(")", r"\)").replace("|", r"\|")):
        parse_goal(text)


def test_a_goal_too_large_for_dnf_is_refused() -> None:
    text = " & ".join(f"(P{i} | Q{i})" for i in range(9))  # 2^9 = 512 terms
    with pytest.raises(InputError, match=f"more than {MAX_TERMS} alternatives"):
        parse_goal(text)


# ---------------------------------------------------------------------------------- resolution
def test_resolution_drops_contradictions_subsumed_terms_and_always_true_negations(kitchen: GroundTask) -> None:
    task = with_negations(kitchen, negations_needed(kitchen, "~IsOpen(fridge)"))
    goal = task.resolve_goal(
        "IsIn(milk,fridge) & IsOpen(fridge) | IsIn(milk,fridge) | IsOpen(fridge) & ~IsOpen(fridge)"
    )
    assert goal.disjuncts == (frozenset({task.atom_id("IsIn(milk,fridge)")}),)
    assert goal.contradictory == ((Atom("IsOpen", ("fridge",)), Atom("IsOpen", ("fridge",), True)),)
    contradiction = task.resolve_goal("IsOpen(fridge) & ~IsOpen(fridge)")
    assert "asks for a literal and its negation" in (contradiction.unsolvable or "")
    assert plan(task, contradiction, "obtea").status is Status.UNSOLVABLE


def test_a_negative_literal_needs_the_twin(kitchen: GroundTask) -> None:
    with pytest.raises(InputError, match="needs the task with negated literals"):
        kitchen.resolve_goal("~IsOpen(fridge)")
    assert negations_needed(kitchen, "~IsOpen(fridge) | IsIn(milk,fridge)") == {kitchen.atom_id("IsOpen(fridge)")}
    task = with_negations(kitchen, negations_needed(kitchen, "~IsOpen(fridge)"))
    assert with_negations(kitchen, negations_needed(kitchen, "~IsOpen(fridge)")) is task  # kept with the task
    assert task.atoms[: len(kitchen.atoms)] == kitchen.atoms  # ids stay valid
    twin = task.negation_ids[task.atom_id("IsOpen(fridge)")]
    assert str(task.atoms[twin]) == "~IsOpen(fridge)"
    assert task.complete({task.atom_id("IsOpen(fridge)")}) == {task.atom_id("IsOpen(fridge)")}
    assert twin in task.complete(set())


def test_the_scenario_resolves_negations_and_keeps_mutexes_exact() -> None:
    scenario = load_scenario("virtualhome")
    extended, goal = scenario.resolve_goal("IsIn_milk_fridge & ~IsOpen_fridge")
    assert extended is not scenario
    assert extended.task is not scenario.task
    assert scenario.resolve_goal("IsIn_milk_fridge & ~IsOpen_fridge")[0] is extended
    opened = extended.task.atom_id("IsOpen(fridge)")
    twin = extended.task.negation_ids[opened]
    assert extended.mutexes.conflict({opened, twin}) == {opened, twin}
    assert extended.mutexes.atom_count == len(extended.task.atoms)
    result = plan(extended.task, goal, "obtea", mutexes=extended.mutexes, heuristic="lm")
    assert result.solved
    tree = full_tree(result.expansions)
    assert verify(tree, extended.task, goal, from_initial_state=True).ok
    run = simulate(tree, extended.task)
    assert run.reached(goal)
    assert opened not in run.final_state


# ------------------------------------------------------- random tasks against brute force
def _holds(task: GroundTask, terms: tuple[tuple[Atom, ...], ...]) -> Callable[[frozenset[int]], bool]:
    """The goal's meaning on the positive task alone (a literal ~p holds when p is absent)."""
    ids = task.atom_ids

    def literal(atom: Atom, state: frozenset[int]) -> bool:
        present = ids.get(atom.positive) in state
        return not present if atom.negated else present

    return lambda state: any(all(literal(a, state) for a in term) for term in terms)


def _random_goal(task: GroundTask, rng: random.Random) -> str:
    atoms = [a for a in task.atoms if not a.negated]
    terms = []
    for _ in range(rng.randint(1, 3)):
        chosen = rng.sample(atoms, min(len(atoms), rng.randint(1, 3)))
        terms.append(" & ".join(("~" if rng.random() < 0.35 else "") + a.underscored for a in chosen))
    return " | ".join(terms)


SEEDS = range(120)


@pytest.mark.parametrize("seed", SEEDS)
def test_obtea_over_or_and_not_is_optimal_against_brute_force(seed: int) -> None:
    """OBTEA's cost over a DNF goal with negations equals the brute-force optimum on the original
    task (and the cheapest disjunct's optimum); every tree is verified and reaches the goal."""
    base, _ = random_task(seed)
    rng = random.Random(1000 + seed)
    text = _random_goal(base, rng)
    terms = parse_goal(text)
    optimum, _plan = brute_force(base, _holds(base, terms))
    per_term = [brute_force(base, _holds(base, (term,)))[0] for term in terms]
    finite = [cost for cost in per_term if cost is not None]
    assert optimum == (min(finite) if finite else None)
    task = with_negations(base, negations_needed(base, text))
    goal = task.resolve_goal(text)
    mutexes = with_negation_groups(infer_mutexes(base), task)
    assert mutexes == infer_mutexes(task)
    for heuristic in ("none", "lm"):
        for pruning in (None, mutexes):
            result = plan(task, goal, "obtea", heuristic=heuristic, mutexes=pruning)
            where = f"seed={seed} goal={text} heuristic={heuristic} mutexes={pruning is not None}: {result.message}"
            if optimum is None:
                assert result.status is Status.UNSOLVABLE, where
                continue
            assert result.solved, where
            assert result.cost == optimum, where
            for tree in (full_tree(result.expansions), path_tree(result.expansions, result.final)):
                assert verify(tree, task, goal, from_initial_state=True).ok, where
                run = simulate(tree, task)
                assert run.reached(goal), where
                assert run.cost == optimum, where
                assert _holds(base, terms)(frozenset(i for i in run.final_state if i < len(base.atoms))), where


@pytest.mark.parametrize("seed", range(0, 120, 7))
def test_every_planner_reaches_a_disjunctive_negative_goal(seed: int) -> None:
    base, _ = random_task(seed)
    text = _random_goal(base, random.Random(2000 + seed))
    optimum, _ = brute_force(base, _holds(base, parse_goal(text)))
    task = with_negations(base, negations_needed(base, text))
    goal = task.resolve_goal(text)
    for planner in ("bte", "hbtp-o", "hbtp-s"):
        result = plan(task, goal, planner)
        assert result.solved == (optimum is not None), (seed, text, planner)
        if result.solved:
            assert optimum is not None
            assert result.cost is not None
            assert result.cost >= optimum
            assert simulate(full_tree(result.expansions), task).reached(goal)


def test_disturbances_keep_each_twin_exact() -> None:
    scenario, goal = load_scenario("virtualhome").resolve_goal(
        "IsIn_milk_fridge & ~IsOpen_fridge | IsOn_milk_kitchentable"
    )
    task = scenario.task
    result = plan(task, goal, "obtea", mutexes=scenario.mutexes, heuristic="lm")
    tree = full_tree(result.expansions)
    runs = disturbed_runs(tree, task, scenario.mutexes, 0.3, 30, seed=3)
    assert sum(run.reached(goal) for run in runs) >= 20
    for run in runs:
        state = run.final_state
        for atom, twin in task.negation_ids.items():
            assert (atom in state) != (twin in state)


def test_btcpp_writes_negated_literals_as_inverters_and_reads_them_back() -> None:
    scenario, goal = load_scenario("virtualhome").resolve_goal("IsIn_milk_fridge & ~IsOpen_fridge")
    task = scenario.task
    tree = full_tree(plan(task, goal, "obtea", mutexes=scenario.mutexes, heuristic="lm").expansions)
    xml = tree_to_btcpp(tree, task)
    assert '<Inverter name="~IsOpen(fridge)">' in xml
    assert tree_from_btcpp(xml, task) == tree
    with pytest.raises(InputError, match="which no goal or precondition of the task negates"):
        tree_from_btcpp(xml, load_scenario("virtualhome").task)


@pytest.mark.validate
@pytest.mark.parametrize("name", ["robowaiter", "virtualhome", "robothow-small"])
def test_obtea_over_or_and_not_matches_fast_downward(name: str) -> None:
    """The written goals of the instruction dataset (disjunctions, negations): OBTEA's cost equals
    Fast Downward's optimum on the exported task, where the disjunction is compiled into free actions."""
    pytest.importorskip("up_fast_downward")
    from hbtp.datasets.instructions import load_instructions
    from hbtp.validation import run_fast_downward

    loaded = load_scenario(name)
    checked = 0
    for record in load_instructions(name):
        if record.task is not None:
            continue
        scenario, goal = loaded.resolve_goal(record.goal)
        result = plan(scenario.task, goal, "obtea", mutexes=scenario.mutexes, heuristic="lm")
        fd = run_fast_downward(scenario.task, goal, time_limit=60, engine="driver")
        assert fd.cost is not None, (record.id, fd.message)
        assert result.cost == fd.cost, (record.id, record.goal)
        checked += 1
    assert checked >= 10


def test_an_unknown_object_lists_the_valid_ones(kitchen: GroundTask) -> None:
    virtualhome = load_scenario("virtualhome").task
    with pytest.raises(
        InputError, match=r"unknown object 'unicorn' in IsIn\(milk,unicorn\) \(IsIn takes at argument 2: cabinet, "
    ):
        virtualhome.resolve_goal("IsIn_milk_unicorn")
    with pytest.raises(InputError, match=r"did you mean 'fridge'"):
        virtualhome.resolve_goal("IsOpen_fride")
