"""``hbtp export`` end to end (in-process, through ``main``) and the ``write_export`` helper."""

from __future__ import annotations

import json
import shutil
from pathlib import Path

import click
import click.testing
import pytest

import hbtp.cli
from hbtp.bt import Node, tree_of
from hbtp.bt.btcpp import tree_from_btcpp
from hbtp.bt.export import FORMATS, export_tree, format_from_extension, read_tree, write_export
from hbtp.bt.jsonio import tree_from_json
from hbtp.cli import EXIT_INPUT, EXIT_OK, main
from hbtp.cli.export_command import export_command, export_options
from hbtp.domains import load_scenario
from hbtp.errors import InputError
from hbtp.logic.task import GroundTask
from hbtp.planning import plan

GOAL = "IsIn_apple_fridge & IsClose_fridge"


@pytest.fixture(autouse=True)
def registered(monkeypatch: pytest.MonkeyPatch) -> None:
    """``main`` with ``export`` registered on a fresh group (hbtp.cli itself is left as it is)."""
    group = click.Group(
        name="hbtp",
        commands={**hbtp.cli.cli.loaded_commands(), "export": export_command},
        params=hbtp.cli.cli.params,
        callback=hbtp.cli.cli.callback,
        context_settings=hbtp.cli.cli.context_settings,
    )
    monkeypatch.setattr(hbtp.cli, "cli", group)


@pytest.fixture(scope="module")
def tree_json(tmp_path_factory: pytest.TempPathFactory) -> Path:
    path = tmp_path_factory.mktemp("plan") / "tree.json"
    code = main(["plan", "-s", "robothow-small", "-g", GOAL, "-p", "obtea", "--tree", "path", "-o", str(path)])
    assert code == EXIT_OK
    assert path.exists()
    return path


def _error_line(capsys: pytest.CaptureFixture[str]) -> str:
    err = capsys.readouterr().err.strip()
    assert "\n" not in err
    assert "Traceback" not in err
    return err


@pytest.mark.parametrize(
    "name",
    ["tree.xml", "tree.py", "tree.dot", "tree.gv", "tree.svg", "tree.png", "tree.mmd", "tree.mermaid", "tree.txt"],
)
def test_export_by_extension(tmp_path: Path, tree_json: Path, name: str, capsys: pytest.CaptureFixture[str]) -> None:
    fmt = format_from_extension(name)
    if fmt in ("svg", "png") and shutil.which("dot") is None:
        pytest.skip("Graphviz's dot is not installed (apt-get install graphviz)")
    out = tmp_path / name
    assert main(["export", str(tree_json), "--scenario", "robothow-small", "--out", str(out)]) == EXIT_OK
    assert f"wrote {out} ({fmt})" in capsys.readouterr().out
    data = out.read_bytes()
    starts = {
        "btcpp": b'<?xml version="1.0" encoding="UTF-8"?>\n<root BTCPP_format="4"',
        "pytrees": b'"""A behavior tree planned by hbtp',
        "dot": b'digraph "behavior_tree" {',
        "svg": b"<?xml",
        "png": b"\x89PNG",
        "mermaid": b"flowchart TD\n",
        "text": b"# scenario: robothow-small\n# goal: IsIn(apple,fridge) & IsClose(fridge)\n? Fallback",
    }
    assert data.startswith(starts[fmt])
    assert [p.name for p in tmp_path.iterdir()] == [name]


def test_json_to_xml_to_json_is_the_same_document(tmp_path: Path, tree_json: Path) -> None:
    xml = tmp_path / "tree.xml"
    back = tmp_path / "back.json"
    assert main(["export", str(tree_json), "-s", "robothow-small", "-o", str(xml)]) == EXIT_OK
    assert main(["export", str(xml), "-s", "robothow-small", "-o", str(back)]) == EXIT_OK
    original = json.loads(tree_json.read_text(encoding="utf-8"))
    again = json.loads(back.read_text(encoding="utf-8"))
    assert again["root"] == original["root"]
    assert again["scenario"] == "robothow-small"


def test_scenario_comes_from_the_json_tree(tree_json: Path, capsys: pytest.CaptureFixture[str]) -> None:
    assert main(["export", str(tree_json), "--format", "mermaid"]) == EXIT_OK
    assert capsys.readouterr().out.startswith("flowchart TD\n  n0[")


def test_format_overrides_the_extension(tmp_path: Path, tree_json: Path) -> None:
    out = tmp_path / "tree.txt"
    assert main(["export", str(tree_json), "-s", "robothow-small", "-f", "btcpp", "-o", str(out)]) == EXIT_OK
    task = load_scenario("robothow-small").task
    expected, _ = tree_from_json(tree_json.read_text(encoding="utf-8"), task)
    assert tree_from_btcpp(out.read_text(encoding="utf-8"), task) == expected


def _write(tmp_path: Path, name: str, text: str) -> Path:
    path = tmp_path / name
    path.write_text(text, encoding="utf-8")
    return path


def _json_tree(root: object) -> str:
    return json.dumps({"format": "hbtp-tree", "version": 1, "scenario": "robothow-small", "goal": "", "root": root})


BAD_INPUTS = {
    "garbage.txt": ("hello, I am not a tree", "not a tree file"),
    "broken.json": ('{"format": "hbtp-tree",', "not valid JSON"),
    "broken.xml": ("<root BTCPP_format='4'><BehaviorTree>", "not valid XML"),
    "node.json": (_json_tree({"type": "Parallel", "children": []}), "unknown node type 'Parallel'"),
    "action.json": (_json_tree({"type": "Action", "action": "Fly(fridge)"}), "Fly(fridge) is not a grounded action"),
    "literal.json": (_json_tree({"type": "Condition", "literals": ["IsIn(unicorn,fridge)"]}), "unicorn"),
    "v3.xml": (
        '<root main_tree_to_execute="M"><BehaviorTree ID="M"><IsOpen arg1="fridge"/></BehaviorTree></root>',
        "v3",
    ),
    "node.xml": (
        '<root BTCPP_format="4"><BehaviorTree ID="M"><Teleport arg1="fridge"/></BehaviorTree></root>',
        "unknown node ID 'Teleport'",
    ),
}


@pytest.mark.parametrize("name", sorted(BAD_INPUTS))
def test_bad_input_is_one_line_exit_2_nothing_written(
    tmp_path: Path, name: str, capsys: pytest.CaptureFixture[str]
) -> None:
    text, message = BAD_INPUTS[name]
    source = _write(tmp_path, name, text)
    out = tmp_path / "out.xml"
    assert main(["export", str(source), "-s", "robothow-small", "-o", str(out)]) == EXIT_INPUT
    error = _error_line(capsys)
    assert error.startswith("hbtp: error: ")
    assert message in error
    assert not out.exists()


def test_tree_of_another_scenario_is_rejected(
    tmp_path: Path, tree_json: Path, capsys: pytest.CaptureFixture[str]
) -> None:
    out = tmp_path / "out.xml"
    assert main(["export", str(tree_json), "-s", "robowaiter", "-o", str(out)]) == EXIT_INPUT
    assert "hbtp: error: " in _error_line(capsys)
    assert not out.exists()


def test_missing_dot_binary(
    tmp_path: Path, tree_json: Path, monkeypatch: pytest.MonkeyPatch, capsys: pytest.CaptureFixture[str]
) -> None:
    monkeypatch.setenv("PATH", str(tmp_path / "no-bin"))
    out = tmp_path / "tree.svg"
    assert main(["export", str(tree_json), "-s", "robothow-small", "-o", str(out)]) == EXIT_INPUT
    assert "install graphviz (apt-get install graphviz" in _error_line(capsys)
    assert not out.exists()


@pytest.mark.parametrize(
    ("args", "message"),
    [
        (["-o", "tree.unknown"], "cannot tell the format from the extension '.unknown'"),
        ([], "give --format or an --out file"),
        (["-f", "png"], "png is a binary format: give --out FILE"),
    ],
)
def test_output_choice_errors(
    tmp_path: Path, tree_json: Path, args: list[str], message: str, capsys: pytest.CaptureFixture[str]
) -> None:
    args = [str(tmp_path / a) if a.startswith("tree.") else a for a in args]
    assert main(["export", str(tree_json), "-s", "robothow-small", *args]) == EXIT_INPUT
    assert message in _error_line(capsys)
    assert not list(tmp_path.iterdir())


def test_missing_tree_file(tmp_path: Path, capsys: pytest.CaptureFixture[str]) -> None:
    assert main(["export", str(tmp_path / "none.json"), "-s", "robothow-small", "-f", "text"]) == EXIT_INPUT
    assert "cannot read the tree" in _error_line(capsys)


# ------------------------------------------------------------------------------------- library helpers


@pytest.fixture(scope="module")
def planned_tree() -> tuple[GroundTask, Node]:
    loaded = load_scenario("robothow-small")
    result = plan(loaded.task, GOAL, "obtea", mutexes=loaded.mutexes, heuristic="lm")
    return loaded.task, tree_of(result, "full")


def test_write_export_and_read_tree(tmp_path: Path, planned_tree: tuple[GroundTask, Node]) -> None:
    task, tree = planned_tree
    (tmp_path / "sub").mkdir()
    for name in ("a.json", "b.xml"):
        path = tmp_path / "sub" / name
        write_export(tree, task, path, scenario="robothow-small", goal=GOAL)
        assert read_tree(path, task) == tree
    xml_text = (tmp_path / "sub" / "b.xml").read_text(encoding="utf-8")
    sniffed = _write(tmp_path, "tree.btcpp", xml_text)
    assert read_tree(sniffed, task) == tree
    write_export(tree, task, tmp_path / "c.out", "mermaid", scenario="s", goal="g")
    assert (tmp_path / "c.out").read_text(encoding="utf-8").startswith("flowchart TD")
    with pytest.raises(InputError, match="cannot tell the format"):
        write_export(tree, task, tmp_path / "d.bin", scenario="s", goal="g")
    with pytest.raises(InputError, match="unknown export format"):
        write_export(tree, task, tmp_path / "e.xml", "yaml", scenario="s", goal="g")
    assert sorted(p.name for p in tmp_path.iterdir()) == ["c.out", "sub", "tree.btcpp"]
    assert sorted(p.name for p in (tmp_path / "sub").iterdir()) == ["a.json", "b.xml"]


def test_registry_formats_and_extensions(planned_tree: tuple[GroundTask, Node]) -> None:
    task, tree = planned_tree
    assert list(FORMATS) == ["btcpp", "btcpp-named", "pytrees", "dot", "svg", "png", "mermaid", "json", "text"]
    assert {ext: format_from_extension(f"x{ext}") for fmt in FORMATS.values() for ext in fmt.extensions} == {
        ".xml": "btcpp",
        ".py": "pytrees",
        ".dot": "dot",
        ".gv": "dot",
        ".svg": "svg",
        ".png": "png",
        ".mmd": "mermaid",
        ".mermaid": "mermaid",
        ".json": "json",
        ".txt": "text",
    }
    assert format_from_extension("TREE.XML") == "btcpp"
    for fmt in ("btcpp", "btcpp-named", "pytrees", "dot", "mermaid", "json", "text"):
        first = export_tree(tree, task, fmt, scenario="robothow-small", goal=GOAL)
        assert isinstance(first, str)
        assert first
        assert first == export_tree(tree, task, fmt, scenario="robothow-small", goal=GOAL)


def test_export_options_decorator() -> None:
    @click.command()
    @export_options
    def command(export_file: str | None, export_format: str | None) -> None:
        click.echo(f"{export_file} {export_format}")

    result = click.testing.CliRunner().invoke(command, ["--export", "t.xml", "--format", "btcpp"])
    assert result.exit_code == 0
    assert result.output == "t.xml btcpp\n"
