"""Graphviz DOT (and SVG/PNG through dot) and Mermaid pictures of a tree."""

from __future__ import annotations

import re
import shutil
import struct
import xml.etree.ElementTree as ET
from pathlib import Path

import pytest

from hbtp.bt import Action, Condition, Fallback, Node, Sequence, size, tree_of
from hbtp.bt.export import write_export
from hbtp.bt.graphviz import find_dot, render_bytes, tree_to_dot
from hbtp.bt.mermaid import escape_label, tree_to_mermaid
from hbtp.domains import DomainBuilder, Scenario, load_scenario
from hbtp.errors import InputError
from hbtp.logic.task import GroundTask
from hbtp.planning import plan

needs_dot = pytest.mark.skipif(
    shutil.which("dot") is None, reason="Graphviz's dot is not installed (apt-get install graphviz)"
)


@pytest.fixture(scope="module")
def small() -> tuple[GroundTask, Node]:
    loaded = load_scenario("robothow-small")
    result = plan(loaded.task, "IsIn_apple_fridge & IsClose_fridge", "obtea", mutexes=loaded.mutexes, heuristic="lm")
    return loaded.task, tree_of(result, "path")


@pytest.fixture(scope="module")
def tiny() -> tuple[GroundTask, Node]:
    task = DomainBuilder("tiny").action("Go(a)", add=["At(a)"]).action("Rest()", add=["Rested()"]).initial([]).build()
    at, rested = task.atom_id("At(a)"), task.atom_id("Rested()")
    tree = Fallback(
        (
            Condition(frozenset({at, rested})),
            Sequence((Condition(frozenset()), Action(task.action("Go(a)").index))),
            Sequence((Condition(frozenset({at})), Action(task.action("Rest()").index))),
        )
    )
    return task, tree


# -------------------------------------------------------------------------------------------------- DOT


def test_dot_text_is_deterministic_and_complete(small: tuple[GroundTask, Node]) -> None:
    task, tree = small
    dot = tree_to_dot(tree, task)
    assert dot == tree_to_dot(tree, task)
    assert dot.startswith('digraph "behavior_tree" {')
    assert dot.endswith("}\n")
    nodes = size(tree).nodes
    declared = re.findall(r"^  (n\d+) \[", dot, flags=re.MULTILINE)
    assert declared == [f"n{i}" for i in range(nodes)]
    assert len(re.findall(r"^  n\d+ -> n\d+;$", dot, flags=re.MULTILINE)) == nodes - 1
    assert 'label="?"' in dot
    assert 'label="→"' in dot
    assert 'shape=ellipse, style=filled, fillcolor="#e8f4e8", label="IsClose(fridge)\\nIsIn(apple,fridge)"' in dot
    assert 'shape=box, style=filled, fillcolor="#ffe9c7", label="Walk(apple)"' in dot


def test_dot_shapes_and_repeated_subtrees(tiny: tuple[GroundTask, Node]) -> None:
    task, tree = tiny
    twice = Sequence((tree, tree))  # the same objects twice: still two drawings
    dot = tree_to_dot(twice, task, name='my "tree"')
    assert dot.startswith('digraph "my \\"tree\\"" {')
    assert dot.count('label="Go(a)"') == 2
    assert 'label="true"' in dot  # the empty condition
    assert "n0 -> n1;" in dot
    assert "n0 -> n9;" in dot


@needs_dot
def test_svg_and_png_render(tmp_path: Path, small: tuple[GroundTask, Node]) -> None:
    task, tree = small
    dot = tree_to_dot(tree, task)
    svg = render_bytes(dot, "svg")
    root = ET.fromstring(svg)
    assert root.tag.endswith("svg")
    assert b"RightPutIn(apple,fridge)" in svg
    target = tmp_path / "tree.png"
    write_export(tree, task, target, "png")
    assert target.read_bytes().startswith(b"\x89PNG\r\n\x1a\n")
    assert [p.name for p in target.parent.iterdir()] == ["tree.png"]  # no temporary file left


@needs_dot
def test_dot_errors_are_input_errors(tmp_path: Path) -> None:
    with pytest.raises(InputError, match="dot failed"):
        render_bytes("digraph { this is not dot", "svg")
    with pytest.raises(InputError, match="unknown image format"):
        render_bytes("digraph {}", "pdf")  # type: ignore[arg-type]
    assert not list(tmp_path.iterdir())


def test_missing_dot_gives_a_clear_one_line_error(
    tmp_path: Path, monkeypatch: pytest.MonkeyPatch, tiny: tuple[GroundTask, Node]
) -> None:
    monkeypatch.setenv("PATH", str(tmp_path / "empty"))
    task, tree = tiny
    with pytest.raises(InputError, match=r"install graphviz \(apt-get install graphviz") as error:
        find_dot()
    assert "\n" not in str(error.value)
    target = tmp_path / "tree.svg"
    with pytest.raises(InputError):
        write_export(tree, task, target)
    assert not target.exists()


# ---------------------------------------------------------------------------------------------- Mermaid


def test_mermaid_flowchart(small: tuple[GroundTask, Node]) -> None:
    task, tree = small
    text = tree_to_mermaid(tree, task)
    assert text == tree_to_mermaid(tree, task)
    lines = text.splitlines()
    assert lines[0] == "flowchart TD"
    assert lines[1] == '  n0["?"]:::fallback'
    assert '  n1(["IsClose(fridge)<br/>IsIn(apple,fridge)"]):::condition' in lines
    assert '  n2["→"]:::sequence' in lines
    assert any(line.endswith('["Walk(apple)"]:::action') for line in lines)
    nodes = size(tree).nodes
    assert sum(1 for line in lines if re.fullmatch(r"  n\d+ --> n\d+", line)) == nodes - 1
    assert "  n0 --> n1" in lines
    assert "  n0 --> n2" in lines


def test_mermaid_escapes_labels(tiny: tuple[GroundTask, Node]) -> None:
    assert escape_label('a "b" <c> & #d') == "a #quot;b#quot; #lt;c#gt; #amp; #35;d"
    task, tree = tiny
    text = tree_to_mermaid(tree, task)
    assert '(["true"]):::condition' in text
    assert '(["At(a)<br/>Rested()"]):::condition' in text


@needs_dot
def test_a_path_tree_is_drawn_readable_at_full_size(robothow: Scenario) -> None:
    # Left to right, the branches stacked: the README's 7-action tree was 3,192 x 370 px top-down,
    # far too wide to read at 100 %.
    from hbtp.bt import tree_of
    from hbtp.planning import plan

    result = plan(robothow.task, "IsIn_milk_fridge & IsClose_fridge", "obtea", mutexes=robothow.mutexes)
    picture = render_bytes(tree_to_dot(tree_of(result, "path"), robothow.task), "png")
    width, height = struct.unpack(">II", picture[16:24])
    assert width <= 800, (width, height)
    assert height > width
