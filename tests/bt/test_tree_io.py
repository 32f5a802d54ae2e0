"""Reading tree files (one reader for ``run``, ``verify`` and ``export``), their limits, their metadata,
and what ``hbtp plan`` writes: goals stored as literals, recorded PDDL files, partial trees, atomic
outputs."""

from __future__ import annotations

import json
import time
import tracemalloc
from pathlib import Path

import pytest

from hbtp.bt import Action, Condition, Fallback, Node, Sequence, size, tree_of
from hbtp.bt.btcpp import tree_from_btcpp, tree_to_btcpp
from hbtp.bt.export import FORMATS, export_tree
from hbtp.bt.jsonio import tree_to_json
from hbtp.bt.nodes import MAX_TREE_DEPTH, MAX_TREE_NODES
from hbtp.bt.treefile import read_tree_file
from hbtp.cli import EXIT_INPUT, EXIT_NOT_SOLVED, EXIT_OK, main
from hbtp.domains import Scenario
from hbtp.errors import InputError
from hbtp.planning import plan

GOAL = "IsIn_apple_fridge & IsClose_fridge"


def _run(capsys: pytest.CaptureFixture[str], *argv: str) -> tuple[int, str, str]:
    code = main(list(argv))
    captured = capsys.readouterr()
    return code, captured.out, captured.err


def _one_error_line(err: str) -> str:
    lines = [line for line in err.splitlines() if line.strip()]
    assert len(lines) == 1, err
    assert lines[0].startswith("hbtp: error: "), err
    assert "Traceback" not in err
    assert "internal error" not in err
    return lines[0]


@pytest.fixture(scope="module")
def planned(robothow_small: Scenario) -> Node:
    result = plan(robothow_small.task, GOAL, "obtea", mutexes=robothow_small.mutexes, heuristic="lm")
    assert result.solved
    return tree_of(result)


# ----------------------------------------------------------------------------- depth and size limits
def _deep_json(levels: int) -> str:
    leaf = '{"type": "Condition", "literals": ["IsClose(fridge)"]}'
    root = '{"type": "Sequence", "children": [' * levels + leaf + "]}" * levels
    return (
        '{"format": "hbtp-tree", "version": 1, "scenario": "robothow-small", "goal": ["IsClose(fridge)"], '
        f'"root": {root}}}'
    )


@pytest.mark.parametrize("levels", [MAX_TREE_DEPTH, 500, 100_000])
def test_too_deep_json_is_bad_input_for_every_command(
    tmp_path: Path, levels: int, capsys: pytest.CaptureFixture[str]
) -> None:
    path = tmp_path / "deep.json"
    path.write_text(_deep_json(levels), encoding="utf-8")  # levels Sequences + a leaf: one level too many
    for command in (["run"], ["verify"], ["export", "-f", "text"]):
        code, _, err = _run(capsys, *command, str(path))
        assert code == EXIT_INPUT, (command, err)
        assert f"nested more than {MAX_TREE_DEPTH} levels deep" in _one_error_line(err)


def test_too_deep_xml_is_bad_input(tmp_path: Path, capsys: pytest.CaptureFixture[str]) -> None:
    levels = 10_000
    path = tmp_path / "deep.xml"
    body = "<Sequence>" * levels + '<IsClose arg1="fridge"/>' + "</Sequence>" * levels
    path.write_text(f'<root BTCPP_format="4"><BehaviorTree ID="M">{body}</BehaviorTree></root>', encoding="utf-8")
    for command in (["run"], ["verify", "-g", "IsClose_fridge"], ["export", "-f", "text"]):
        code, _, err = _run(capsys, *command, str(path), "-s", "robothow-small")
        assert code == EXIT_INPUT, (command, err)
        assert f"nested more than {MAX_TREE_DEPTH} levels deep" in _one_error_line(err)


def _chain(depth: int, inner: Node) -> Node:
    node = inner
    for _ in range(depth - 1):
        node = Sequence((node,))
    return node


def test_a_tree_at_the_depth_limit_works_everywhere(
    tmp_path: Path, robothow_small: Scenario, capsys: pytest.CaptureFixture[str]
) -> None:
    task = robothow_small.task
    goal = task.resolve_goal("IsOpen_fridge")
    walk = task.action("Walk(fridge)").index
    open_ = task.action("Open(fridge)").index
    near = Condition(frozenset(task.actions[open_].pre))
    branch = _chain(MAX_TREE_DEPTH - 2, Sequence((near, Action(open_))))
    walk_guard = task.actions[walk].pre | (task.actions[open_].pre - task.actions[walk].add)
    tree = Fallback((Condition(goal.ids), branch, Sequence((Condition(walk_guard), Action(walk)))))
    assert size(tree).depth == MAX_TREE_DEPTH
    path = tmp_path / "deep.json"
    path.write_text(tree_to_json(tree, task, scenario="robothow-small", goal=goal), encoding="utf-8")
    assert main(["run", str(path)]) == EXIT_OK
    assert main(["verify", str(path)]) == EXIT_OK
    for name, fmt in FORMATS.items():
        if fmt.binary or name == "svg":
            continue
        code, out, err = _run(capsys, "export", str(path), "-f", name)
        assert code == EXIT_OK, (name, err)
        if name == "pytrees":
            compile(out, "tree.py", "exec")  # within the parser's nesting limit
    xml = tmp_path / "deep.xml"
    assert main(["export", str(path), "-o", str(xml)]) == EXIT_OK
    assert tree_from_btcpp(xml.read_text(encoding="utf-8"), task) == tree
    assert main(["verify", str(xml)]) == EXIT_OK


def _fan_out(levels: int, copies: int) -> str:
    lines = [f'<root BTCPP_format="4" main_tree_to_execute="T{levels}">']
    lines.append('<BehaviorTree ID="T0"><IsClose arg1="fridge"/></BehaviorTree>')
    for level in range(1, levels + 1):
        references = f'<SubTree ID="T{level - 1}"/>' * copies
        lines.append(f'<BehaviorTree ID="T{level}"><Sequence>{references}</Sequence></BehaviorTree>')
    return "\n".join([*lines, "</root>"])


def test_subtree_fan_out_fails_fast_without_memory(robothow_small: Scenario) -> None:
    text = _fan_out(11, 4)  # 4**11 leaves once expanded, from 1.5 KB
    assert len(text) < 2000
    tracemalloc.start()
    started = time.perf_counter()
    try:
        with pytest.raises(InputError, match=f"more than {MAX_TREE_NODES:,} nodes once its SubTrees are expanded"):
            tree_from_btcpp(text, robothow_small.task, "fan11.xml")
        elapsed = time.perf_counter() - started
        peak = tracemalloc.get_traced_memory()[1]
    finally:
        tracemalloc.stop()
    assert elapsed < 1.0
    assert peak < 20_000_000


def test_identical_subtrees_are_read_once_and_shared(robothow_small: Scenario) -> None:
    tree = tree_from_btcpp(_fan_out(3, 2), robothow_small.task)
    assert (size(tree).nodes, size(tree).depth) == (15, 4)
    assert isinstance(tree, Sequence)
    first, second = tree.children
    assert first is second
    assert first == second


def test_fan_out_through_the_cli_is_one_line_exit_2(tmp_path: Path, capsys: pytest.CaptureFixture[str]) -> None:
    path = tmp_path / "fan11.xml"
    path.write_text(_fan_out(11, 4), encoding="utf-8")
    code, _, err = _run(capsys, "export", str(path), "-s", "robothow-small", "-f", "text")
    assert code == EXIT_INPUT
    assert f"{MAX_TREE_NODES:,} nodes" in _one_error_line(err)


# --------------------------------------------------------------------------------- one reader, BOM
def test_utf8_byte_order_mark_is_read(
    tmp_path: Path, planned: Node, robothow_small: Scenario, capsys: pytest.CaptureFixture[str]
) -> None:
    task = robothow_small.task
    goal = task.resolve_goal(GOAL)
    documents = {
        "bom.json": tree_to_json(planned, task, scenario="robothow-small", goal=goal),
        "bom.xml": tree_to_btcpp(planned, task, scenario="robothow-small", goal="IsIn(apple,fridge) & IsClose(fridge)"),
    }
    for name, text in documents.items():
        path = tmp_path / name
        path.write_bytes(b"\xef\xbb\xbf" + text.encode("utf-8"))
        assert read_tree_file(path).tree(task) == planned
        for command in (["run"], ["verify"], ["export", "-f", "mermaid"]):
            code, _, err = _run(capsys, *command, str(path))
            assert code == EXIT_OK, (name, command, err)


def test_format_is_told_by_content(tmp_path: Path, planned: Node, robothow_small: Scenario) -> None:
    task = robothow_small.task
    json_named_xml = tmp_path / "tree.xml"
    json_named_xml.write_text(tree_to_json(planned, task, goal=GOAL), encoding="utf-8")
    xml_named_json = tmp_path / "tree.json"
    xml_named_json.write_text(tree_to_btcpp(planned, task), encoding="utf-8")
    assert read_tree_file(json_named_xml).kind == "json"
    assert read_tree_file(xml_named_json).kind == "btcpp"
    assert read_tree_file(xml_named_json).tree(task) == planned


def test_run_and_verify_read_bt_cpp_xml_with_its_recorded_scenario_and_goal(
    tmp_path: Path, capsys: pytest.CaptureFixture[str]
) -> None:
    xml = tmp_path / "tree.xml"
    code, _, err = _run(capsys, "plan", "-s", "robothow-small", "-g", GOAL, "-p", "obtea", "--export", str(xml))
    assert code == EXIT_OK, err
    assert "goal IsIn(apple,fridge) & IsClose(fridge)" in xml.read_text(encoding="utf-8")
    code, out, err = _run(capsys, "verify", str(xml))
    assert code == EXIT_OK, err
    assert out.startswith("ok; goal reaching proved")
    code, out, err = _run(capsys, "run", str(xml), "--json")
    assert code == EXIT_OK, err
    assert json.loads(out)["scenario"] == "robothow-small"
    assert json.loads(out)["goal"] == "IsIn(apple,fridge) & IsClose(fridge)"


def test_run_and_verify_use_the_scenario_recorded_in_json(
    tmp_path: Path, planned: Node, robothow_small: Scenario, capsys: pytest.CaptureFixture[str]
) -> None:
    path = tmp_path / "tree.json"
    path.write_text(tree_to_json(planned, robothow_small.task, scenario="robothow-small", goal=GOAL), "utf-8")
    for command in ("run", "verify"):
        code, _, err = _run(capsys, command, str(path))
        assert code == EXIT_OK, (command, err)


def test_a_scenario_that_is_neither_shipped_nor_recorded_as_pddl(
    tmp_path: Path, planned: Node, robothow_small: Scenario, capsys: pytest.CaptureFixture[str]
) -> None:
    path = tmp_path / "tree.json"
    path.write_text(tree_to_json(planned, robothow_small.task, scenario="my-own", goal=GOAL), "utf-8")
    code, _, err = _run(capsys, "verify", str(path))
    assert code == EXIT_INPUT
    assert "give --scenario or --pddl" in _one_error_line(err)
    assert main(["verify", str(path), "-s", "robothow-small"]) == EXIT_OK


# ---------------------------------------------------------------- goals and names with underscores
DOMAIN = """\
(define (domain sat_lite)
  (:requirements :strips)
  (:predicates (power_on ?i) (have_image ?d ?m) (pointing ?d))
  (:action switch_on :parameters (?i) :precondition (and) :effect (power_on ?i))
  (:action take_image :parameters (?d ?i ?m)
    :precondition (and (power_on ?i) (pointing ?d))
    :effect (have_image ?d ?m)))
"""
PROBLEM = """\
(define (problem sat_lite_p1)
  (:domain sat_lite)
  (:objects star_1 cam_1 thermo_graph)
  (:init (pointing star_1))
  (:goal (and (have_image star_1 thermo_graph))))
"""


@pytest.fixture
def pddl_files(tmp_path: Path) -> tuple[Path, Path]:
    folder = tmp_path / "pddl"
    folder.mkdir()
    (folder / "domain.pddl").write_text(DOMAIN, encoding="utf-8")
    (folder / "problem.pddl").write_text(PROBLEM, encoding="utf-8")
    return folder / "domain.pddl", folder / "problem.pddl"


def test_goals_with_underscores_and_recorded_pddl_files_read_back(
    tmp_path: Path, pddl_files: tuple[Path, Path], capsys: pytest.CaptureFixture[str], caplog: pytest.LogCaptureFixture
) -> None:
    domain, problem = pddl_files
    out = tmp_path / "trees" / "tree.json"
    out.parent.mkdir()
    goal = "have_image(star_1,thermo_graph)"
    code, _, err = _run(capsys, "plan", "--pddl", str(domain), str(problem), "-g", goal, "-o", str(out))
    assert code == EXIT_OK, err
    assert "records PDDL files outside its folder" in caplog.text  # reading it back will need --pddl
    document = json.loads(out.read_text(encoding="utf-8"))
    assert document["goal"] == ["have_image(star_1,thermo_graph)"]
    assert document["pddl"] == {"domain": "../pddl/domain.pddl", "problem": "../pddl/problem.pddl"}
    # Files outside the tree's folder are not opened unless --pddl names them.
    for command in ("run", "verify"):
        code, out_text, err = _run(capsys, command, str(out))
        assert code == EXIT_INPUT, (command, err)
        assert "outside the tree file's folder" in _one_error_line(err)
        code, out_text, err = _run(capsys, command, str(out), "--pddl", str(domain), str(problem))
        assert code == EXIT_OK, (command, err)
    code, out_text, err = _run(capsys, "export", str(out), "-f", "text", "--pddl", str(domain), str(problem))
    assert code == EXIT_OK, err
    assert "# goal: have_image(star_1,thermo_graph)" in out_text
    # Files written before goals were stored as lists: the underscored string is matched to the task.
    document["goal"] = "have_image_star_1_thermo_graph"
    document["pddl"] = {"domain": "pddl/domain.pddl", "problem": "pddl/problem.pddl"}
    old = tmp_path / "old.json"
    old.write_text(json.dumps(document), encoding="utf-8")
    code, out_text, err = _run(capsys, "verify", str(old), "--json")
    assert code == EXIT_OK, err
    assert json.loads(out_text)["goal"] == "have_image(star_1,thermo_graph)"
    # Exported to JSON again, the PDDL files stay recorded, relative to the new file.
    again = tmp_path / "again.json"
    assert main(["export", str(old), "-o", str(again)]) == EXIT_OK
    assert json.loads(again.read_text(encoding="utf-8"))["pddl"]["domain"] == "pddl/domain.pddl"
    assert main(["verify", str(again)]) == EXIT_OK


def test_a_recorded_goal_that_does_not_fit_is_one_line(
    tmp_path: Path, planned: Node, robothow_small: Scenario, capsys: pytest.CaptureFixture[str]
) -> None:
    path = tmp_path / "tree.json"
    document = json.loads(tree_to_json(planned, robothow_small.task, scenario="robothow-small", goal=GOAL))
    for goal, message in ((["IsFlying(self)"], "IsFlying"), ([3], "list of literals"), (7, "list of literals")):
        document["goal"] = goal
        path.write_text(json.dumps(document), encoding="utf-8")
        code, _, err = _run(capsys, "verify", str(path))
        assert code == EXIT_INPUT
        assert message in _one_error_line(err)


# ---------------------------------------------------------------------------------- partial trees
UNSOLVED = ["plan", "-s", "robothow-small", "-g", GOAL, "-p", "obtea", "--max-expansions", "2"]


def test_an_unsolved_plan_writes_no_tree_without_partial(
    tmp_path: Path, capsys: pytest.CaptureFixture[str], caplog: pytest.LogCaptureFixture
) -> None:
    out, xml = tmp_path / "tree.json", tmp_path / "tree.xml"
    code, _, _ = _run(capsys, *UNSOLVED, "-o", str(out), "--export", str(xml))
    assert code == EXIT_NOT_SOLVED
    assert "nothing written" in caplog.text
    assert "--partial" in caplog.text
    assert not out.exists()
    assert not xml.exists()


def test_a_partial_tree_is_marked_and_fails_verification(
    tmp_path: Path, capsys: pytest.CaptureFixture[str], caplog: pytest.LogCaptureFixture
) -> None:
    out = tmp_path / "tree.json"
    code, _, _ = _run(capsys, *UNSOLVED, "-o", str(out), "--partial")
    assert code == EXIT_NOT_SOLVED
    assert "partial tree" in caplog.text
    caplog.clear()
    document = json.loads(out.read_text(encoding="utf-8"))
    assert document["complete"] is False
    code, text, _ = _run(capsys, "verify", str(out), "--json")
    assert code == EXIT_NOT_SOLVED
    result = json.loads(text)
    assert result["ok"] is False
    assert result["covers_initial_state"] is False
    assert result["problems"][-1]["kind"] == "initial-state"
    assert "holds a partial tree" in caplog.text
    code, _, _ = _run(capsys, "run", str(out))
    assert code == EXIT_NOT_SOLVED


def test_a_solved_tree_is_complete(tmp_path: Path, capsys: pytest.CaptureFixture[str]) -> None:
    out = tmp_path / "tree.json"
    assert _run(capsys, "plan", "-s", "robothow-small", "-g", GOAL, "-o", str(out))[0] == EXIT_OK
    assert json.loads(out.read_text(encoding="utf-8"))["complete"] is True


# ----------------------------------------------------------------------------------- atomic output
def test_plan_writes_its_json_and_export_together_or_not_at_all(
    tmp_path: Path, capsys: pytest.CaptureFixture[str]
) -> None:
    blocker = tmp_path / "ro"
    blocker.write_text("a file where a folder should be", encoding="utf-8")
    xml = tmp_path / "t.xml"
    args = ["plan", "-s", "robothow-small", "-g", GOAL, "-o", str(blocker / "t.json"), "--export", str(xml)]
    code, _, err = _run(capsys, *args)
    assert code == EXIT_INPUT
    assert not xml.exists()
    assert sorted(p.name for p in tmp_path.iterdir()) == ["ro"]
    assert "ro/t.json" in _one_error_line(err)


def test_a_write_error_names_the_target_not_the_temporary_file(
    tmp_path: Path, monkeypatch: pytest.MonkeyPatch, capsys: pytest.CaptureFixture[str]
) -> None:
    def refuse(name: str, mode: int) -> None:
        raise PermissionError(13, "Permission denied", name)

    monkeypatch.setattr("hbtp.files.os.chmod", refuse)
    out = tmp_path / "tree.json"
    code, _, err = _run(capsys, "plan", "-s", "robothow-small", "-g", GOAL, "-o", str(out))
    assert code == EXIT_INPUT
    line = _one_error_line(err)
    assert line == f"hbtp: error: cannot write {out}: Permission denied"
    assert list(tmp_path.iterdir()) == []


def test_export_to_a_folder_is_bad_input(
    tmp_path: Path, planned: Node, robothow_small: Scenario, capsys: pytest.CaptureFixture[str]
) -> None:
    path = tmp_path / "tree.json"
    path.write_text(tree_to_json(planned, robothow_small.task, scenario="robothow-small", goal=GOAL), "utf-8")
    blocker = tmp_path / "file"
    blocker.write_text("a file where a folder should be", encoding="utf-8")
    code, _, err = _run(capsys, "export", str(path), "-o", str(blocker / "out.txt"))
    assert code == EXIT_INPUT
    assert f"cannot write {blocker / 'out.txt'}" in _one_error_line(err)
    folder = tmp_path / "out.txt"
    folder.mkdir()
    code, _, err = _run(capsys, "export", str(path), "-o", str(folder))  # a usage error: one line too
    assert code == EXIT_INPUT
    assert _one_error_line(err).startswith("hbtp: error: Invalid value for '-o' / '--out'")


def test_export_tree_keeps_its_goal_text(planned: Node, robothow_small: Scenario) -> None:
    text = export_tree(planned, robothow_small.task, "json", scenario="robothow-small", goal="IsClose(fridge)")
    assert isinstance(text, str)
    assert json.loads(text)["goal"] == ["IsClose(fridge)"]
