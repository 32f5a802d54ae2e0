"""Hostile input through the command line, generated: goals, PDDL files and tree files that are
malformed in every way the generators find. Whatever they are, hbtp answers with a result (exit 0
or 1) or one ``hbtp: error:`` line (exit 1 or 2), never an internal error (exit 3) or a traceback.

Bounded: small scenarios, ``-t`` on every plan, a fixed number of examples, in this process, no
device files.
"""

from __future__ import annotations

import json
from pathlib import Path

import pytest
from hypothesis import HealthCheck, event, given, settings
from hypothesis import strategies as st

from hbtp.cli import EXIT_INTERNAL, main

FUZZ = settings(max_examples=60, deadline=None, suppress_health_check=list(HealthCheck), derandomize=True)

DOMAIN = """\
(define (domain gripper-strips)
  (:requirements :strips :typing)
  (:types room ball gripper)
  (:predicates (at-robby ?r - room) (at ?b - ball ?r - room) (free ?g - gripper) (carry ?o - ball ?g - gripper))
  (:action move :parameters (?from ?to - room)
    :precondition (at-robby ?from)
    :effect (and (at-robby ?to) (not (at-robby ?from))))
  (:action pick :parameters (?obj - ball ?room - room ?gripper - gripper)
    :precondition (and (at ?obj ?room) (at-robby ?room) (free ?gripper))
    :effect (and (carry ?obj ?gripper) (not (at ?obj ?room)) (not (free ?gripper))))
  (:action drop :parameters (?obj - ball ?room - room ?gripper - gripper)
    :precondition (and (carry ?obj ?gripper) (at-robby ?room))
    :effect (and (at ?obj ?room) (free ?gripper) (not (carry ?obj ?gripper)))))
"""
PROBLEM = """\
(define (problem two) (:domain gripper-strips)
  (:objects rooma roomb - room ball1 ball2 - ball left right - gripper)
  (:init (at-robby rooma) (free left) (free right) (at ball1 rooma) (at ball2 rooma))
  (:goal (and (at ball1 roomb) (at ball2 roomb))))
"""

#: Pieces goals are made of: names of the scenario, operators, brackets, stray characters.
GOAL_PIECES = st.sampled_from(
    [
        "On_Coffee_Table1", "On(Coffee,Table1)", "Exists_Coffee", "IsClean_Table1", "RobotNear_Bar", "On",
        "Coffee", "&", "|", "~", "(", ")", ",", " ", "and", "or", "not", "(and", "(or", "(not", "imply", "_",
        "Nope_Thing", "\u00e9", "\x00", "\t", "\n", "@", "#", "1", "On_Coffee", "RobotNear(Bar,Bar)",
    ]
)  # fmt: skip
PDDL_NOISE = st.sampled_from(
    ["(", ")", "?", "-", " ", "\n", "\x00", "\u00ff", ":", ";", "and", "not", "either", "object", "=", "ball1", "x"]
)


def _ok(code: int, err: str) -> None:
    event(f"exit code {code}")  # (--hypothesis-show-statistics shows how the cases ended)
    assert code != EXIT_INTERNAL, err
    assert "Traceback" not in err
    errors = [line for line in err.splitlines() if line.startswith("hbtp: error:")]
    assert len(errors) <= 1, err
    if code == 2:
        assert len(errors) == 1, err
        assert len([line for line in err.splitlines() if line.strip()]) == 1, err


@FUZZ
@given(pieces=st.lists(GOAL_PIECES, min_size=1, max_size=12))
def test_any_goal_text_gets_a_result_or_one_line(pieces: list[str], capsys: pytest.CaptureFixture[str]) -> None:
    code = main(["plan", "-s", "robowaiter", "-g", "".join(pieces), "-t", "2"])
    _ok(code, capsys.readouterr().err)


@FUZZ
@given(
    edits=st.lists(
        st.tuples(st.sampled_from(["domain", "problem"]), st.integers(0, 10_000), st.integers(0, 3), PDDL_NOISE),
        min_size=1,
        max_size=4,
    )
)
def test_any_pddl_gets_a_result_or_one_line(
    edits: list[tuple[str, int, int, str]], tmp_path_factory: pytest.TempPathFactory, capsys: pytest.CaptureFixture[str]
) -> None:
    texts = {"domain": DOMAIN, "problem": PROBLEM}
    for which, at, remove, insert in edits:  # replace `remove` characters at a position by a piece
        text = texts[which]
        position = at % (len(text) + 1)
        texts[which] = text[:position] + insert + text[position + remove :]
    folder = tmp_path_factory.mktemp("pddl")
    for which, text in texts.items():
        (folder / f"{which}.pddl").write_text(text, encoding="utf-8")
    pddl = [str(folder / "domain.pddl"), str(folder / "problem.pddl")]
    _ok(main(["ground", "--pddl", *pddl, "-t", "2"]), capsys.readouterr().err)
    _ok(main(["plan", "--pddl", *pddl, "-t", "2"]), capsys.readouterr().err)


@pytest.fixture(scope="module")
def tree_document(tmp_path_factory: pytest.TempPathFactory) -> dict[str, object]:
    path = tmp_path_factory.mktemp("tree") / "tree.json"
    assert main(["plan", "-s", "robowaiter", "-g", "On_Coffee_Table1", "--tree", "path", "-o", str(path)]) == 0
    document: dict[str, object] = json.loads(path.read_text(encoding="utf-8"))
    return document


JSON_VALUES = st.recursive(
    st.none() | st.booleans() | st.integers(-3, 3) | st.sampled_from(["", "Condition", "Action", "MakeCoffee(Coffee)"]),
    lambda inner: st.lists(inner, max_size=3) | st.dictionaries(st.sampled_from(["type", "children", "x"]), inner),
    max_leaves=6,
)


@FUZZ
@given(key=st.sampled_from(["root", "goal", "scenario", "complete", "pddl", "format", "version"]), value=JSON_VALUES)
def test_any_tree_file_gets_a_verdict_or_one_line(
    key: str,
    value: object,
    tree_document: dict[str, object],
    tmp_path_factory: pytest.TempPathFactory,
    capsys: pytest.CaptureFixture[str],
) -> None:
    path: Path = tmp_path_factory.mktemp("bad") / "tree.json"
    path.write_text(json.dumps({**tree_document, key: value}), encoding="utf-8")
    for command in ("verify", "run"):
        _ok(main([command, str(path)]), capsys.readouterr().err)
