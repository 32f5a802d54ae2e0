"""``hbtp view``: the HTML page of a tree and its trace (issue 12, item 5).

The unit tests read the data the page embeds (every tick's visited nodes come from hbtp's own
``tick``) and the command's errors; the browser tests load the page in a real headless Chromium
(tests/chromium.py, no extra Python package; skipped when no Chromium is installed) and step it.
"""

from __future__ import annotations

import dataclasses
import json
import logging
import re
import time
from pathlib import Path
from typing import Any

import pytest

from chromium import Chromium, Page, find_chromium
from hbtp.bt import Action, Condition, Fallback, Node, Sequence, tick, tree_of
from hbtp.bt.html_view import ViewHeader, layout, read_trace, render_page, script_json, tree_page, view_data, visit
from hbtp.bt.jsonio import node_to_dict, tree_to_json
from hbtp.bt.nodes import size
from hbtp.bt.simulate import simulate, trace_to_jsonl
from hbtp.cli import EXIT_INPUT, EXIT_OK, main
from hbtp.cli.options import ScenarioSource
from hbtp.cli.tree_input import load_tree_input
from hbtp.domains import Scenario
from hbtp.errors import InputError
from hbtp.logic.execution import Event, Trace, execute
from hbtp.logic.task import State
from hbtp.planning import plan
from hbtp.replanning import Replanner

GOAL = "On(Coffee,Bar2)"
CHROMIUM = find_chromium()
needs_chromium = pytest.mark.skipif(
    CHROMIUM is None, reason="no Chromium to test the page in (apt-get install chromium; or set HBTP_CHROMIUM)"
)
DATA = re.compile(r'<script type="application/json" id="hbtp-data">(.*?)</script>', re.DOTALL)
READY = "document.body && document.body.dataset.ready === '1'"


def _page_data(page: str) -> Any:
    found = DATA.search(page)
    assert found is not None
    return json.loads(found.group(1))


@pytest.fixture(scope="module")
def files(tmp_path_factory: pytest.TempPathFactory, robowaiter: Scenario) -> dict[str, Path]:
    """A RoboWaiter tree and a trace of three disturbed runs written by ``hbtp run``."""
    folder = tmp_path_factory.mktemp("view")
    task = robowaiter.task
    tree = tree_of(plan(task, GOAL, "obtea", mutexes=robowaiter.mutexes, heuristic="lm"))
    tree_file = folder / "tree.json"
    tree_file.write_text(tree_to_json(tree, task, scenario="robowaiter", goal=GOAL), encoding="utf-8")
    trace = folder / "trace.jsonl"
    argv = ["run", str(tree_file), "--perturb", "0.3", "--runs", "3", "--seed", "0", "--trace", str(trace)]
    assert main(argv) in (0, 1)
    page = folder / "tree.html"
    assert main(["view", str(tree_file), "--trace", str(trace), "-o", str(page)]) == EXIT_OK
    return {"tree": tree_file, "trace": trace, "page": page}


# ------------------------------------------------------------------ the page's data
def test_the_page_is_self_contained_and_embeds_every_tick(files: dict[str, Path], robowaiter: Scenario) -> None:
    page = files["page"].read_text(encoding="utf-8")
    assert page.startswith("<!DOCTYPE html>")
    assert not re.search(r"\b(src|href)\s*=", page), "nothing may be loaded from elsewhere"
    assert "http://" not in page
    assert "https://" not in page
    assert "<style>" in page
    assert "hbtpView" in page  # the script is inlined
    data = _page_data(page)
    lines = [json.loads(line) for line in files["trace"].read_text(encoding="utf-8").splitlines()]
    ticks = [line for line in lines if "tick" in line]
    assert [run["run"] for run in data["runs"]] == [0, 1, 2]
    assert sum(len(run["ticks"]) for run in data["runs"]) == len(ticks)
    assert data["scenario"] == "robowaiter"
    assert data["goal"] == GOAL
    (tree,) = data["trees"]
    kinds = {node[0] for node in tree["nodes"]}
    assert kinds == {"F", "S", "C", "A"}
    assert tree["nodes"][0] == ["F", "", -1]
    for run in data["runs"]:
        assert run["label"].startswith(f"run {run['run']}: ")
        for step, line in zip(run["ticks"], [t for t in ticks if t["run"] == run["run"]], strict=True):
            assert [data["names"][i] for i in data["states"][step["state"]]] == line["state"]
            path = data["visits"][step["visit"]]["path"]
            assert path[0] == 0
            leaf = tree["nodes"][path[-1]]
            if line["status"] == "running":  # the active path ends at the running action
                assert leaf == ["A", line["action"], path[-2]]
            for child, parent in zip(path[1:], path[:-1], strict=True):
                assert tree["nodes"][child][2] == parent


def test_each_tick_records_what_hbtp_ticks(files: dict[str, Path], robowaiter: Scenario) -> None:
    """Every node the page marks was ticked by hbtp.bt.tick, with that status (and no other node was)."""
    read = load_tree_input(str(files["tree"]), ScenarioSource())
    task, tree = read.scenario.task, layout(read.tree)
    states = {frozenset(task.atom_id(name) for name in json.loads(line).get("state", [])) for line in
              files["trace"].read_text(encoding="utf-8").splitlines()}  # fmt: skip
    for state in states:
        found = visit(tree, state, task)
        ticked: list[tuple[Node, Any]] = []
        status, action = tick(tree.nodes[0], state, task, lambda node, result, seen=ticked: seen.append((node, result)))
        assert (found.status, found.action) == (status, action)
        assert [(tree.nodes[position], result) for position, result in found.ticked] == ticked
        for position, result in found.ticked:
            assert tick(tree.nodes[position], state, task)[0] is result


def test_the_page_is_deterministic(files: dict[str, Path], tmp_path: Path) -> None:
    again = tmp_path / "again.html"
    assert main(["view", str(files["tree"]), "--trace", str(files["trace"]), "-o", str(again)]) == EXIT_OK
    assert again.read_bytes() == files["page"].read_bytes()


def test_a_bt_cpp_tree_gives_the_same_page_data(files: dict[str, Path], tmp_path: Path) -> None:
    xml = tmp_path / "tree.xml"
    assert main(["export", str(files["tree"]), "-o", str(xml)]) == EXIT_OK
    page = tmp_path / "xml.html"
    assert main(["view", str(xml), "--trace", str(files["trace"]), "-o", str(page)]) == EXIT_OK
    from_xml = _page_data(page.read_text(encoding="utf-8"))
    from_json = _page_data(files["page"].read_text(encoding="utf-8"))
    assert from_xml["trace"] == "trace.jsonl"  # the file's name, not the path given
    for key in ("trees", "states", "visits", "runs", "goal", "scenario"):
        assert from_xml[key] == from_json[key], key


def test_without_a_trace_the_page_shows_the_tree(files: dict[str, Path], tmp_path: Path) -> None:
    page = tmp_path / "tree.html"
    assert main(["view", str(files["tree"]), "-o", str(page)]) == EXIT_OK
    data = _page_data(page.read_text(encoding="utf-8"))
    assert data["runs"] == []
    assert data["trace"] is None
    assert len(data["trees"]) == 1


def test_embedded_json_cannot_end_its_script_element() -> None:
    text = script_json({"label": "</script><!-- <b>", "line": "\u2028"})
    assert "<" not in text
    assert "\u2028" not in text
    assert json.loads(text) == {"label": "</script><!-- <b>", "line": "\u2028"}
    page = render_page({"title": "a </title> b", "trees": [], "runs": [], "x": "</script>"})
    assert "<title>a &lt;/title&gt; b - hbtp view</title>" in page
    assert page.count("</script>") == 2  # the data's and the code's own


def test_a_single_run_trace_without_run_numbers(robowaiter: Scenario) -> None:
    task = robowaiter.task
    tree = tree_of(plan(task, GOAL, "obtea", mutexes=robowaiter.mutexes, heuristic="lm"))
    text = trace_to_jsonl(simulate(tree, task, trace=True), task)
    data = _page_data(tree_page(tree, task, text, ViewHeader(title="t", trace="t.jsonl")))
    (run,) = data["runs"]
    assert run["run"] == 0
    assert [step["tick"] for step in run["ticks"]] == list(range(1, len(run["ticks"]) + 1))
    assert run["ticks"][-1]["status"] == "success"
    assert run["label"].startswith("run 0: success, ")


# ------------------------------------------------------------------ re-plans
def _replanning_trace(scenario: Scenario) -> tuple[Node, str, Replanner]:
    """A path tree, a disturbance that leaves it no condition, and the trace of a run that re-plans
    once, with the re-plan line (and the new tree) written as ``hbtp run --replan`` writes it."""
    task = scenario.task
    goal = task.resolve_goal(GOAL)
    tree = tree_of(plan(task, goal, "obtea", mutexes=scenario.mutexes, heuristic="lm"), "path")
    nothing, chips = task.atom_id("Holding(Nothing)"), task.atom_id("Holding(Chips)")

    def grab_chips(number: int, state: State, last: int | None, before: State | None) -> Event | None:
        return Event("make-true", frozenset({chips}), frozenset({nothing})) if number == 2 else None

    replanner = Replanner(scenario, goal, tree)
    tracer = Trace(task)
    run = execute(replanner, task, None, max_ticks=50, disturbance=grab_chips, observers=(tracer,))
    run = dataclasses.replace(run, trace=tuple(tracer.steps))
    assert [r.status for r in replanner.replans] == ["solved"]
    assert run.reached(goal.ids)
    replan = replanner.replans[0]
    lines = trace_to_jsonl(run, task, run_index=0).splitlines()
    record = {"run": 0, "replan": {**replan.to_dict(), "tree": node_to_dict(replanner.tree, task)}}
    at = next(i for i, line in enumerate(lines) if json.loads(line).get("tick") == replan.tick)
    lines.insert(at, json.dumps(record))
    return tree, "\n".join(lines) + "\n", replanner


def test_a_replan_switches_the_tree_from_its_tick(robowaiter: Scenario) -> None:
    tree, text, replanner = _replanning_trace(robowaiter)
    replanned_at = replanner.replans[0].tick
    data = view_data(tree, robowaiter.task, read_trace(text, "r.jsonl"), ViewHeader(trace="r.jsonl"))
    assert len(data["trees"]) == 2
    assert len(data["trees"][1]["nodes"]) == size(replanner.tree).nodes
    (run,) = data["runs"]
    assert [step["tree"] for step in run["ticks"]] == [int(step["tick"] >= replanned_at) for step in run["ticks"]]
    assert [step["replans"] for step in run["ticks"]] == [
        [0] if s["tick"] == replanned_at else [] for s in run["ticks"]
    ]
    (record,) = run["replans"]
    assert record["tree"] == 1
    assert record["reason"] == "no condition of the tree holds"
    assert record["status"] == "solved"
    assert "1 re-plan(s)" in run["label"]
    # the new tree may also be given as a whole tree file's document
    document = json.loads(tree_to_json(replanner.tree, robowaiter.task))
    lines = [json.loads(line) for line in text.splitlines()]
    text_with_document = "".join(
        json.dumps({**line, "replan": {**line["replan"], "tree": document}} if "replan" in line else line) + "\n"
        for line in lines
    )
    again = view_data(tree, robowaiter.task, read_trace(text_with_document, "r.jsonl"), ViewHeader(trace="r.jsonl"))
    assert again == data
    # without its re-plan line the trace does not match the tree at the re-planning tick
    without = "".join(line + "\n" for line in text.splitlines() if '"replan"' not in line)
    with pytest.raises(InputError, match=rf"^r\.jsonl:\d+: run 0, tick {replanned_at}: the trace says running "):
        view_data(tree, robowaiter.task, read_trace(without, "r.jsonl"), ViewHeader(trace="r.jsonl"))


def test_a_replan_without_a_tree_is_marked_and_keeps_the_tree(files: dict[str, Path], robowaiter: Scenario) -> None:
    lines = files["trace"].read_text(encoding="utf-8").splitlines()
    failed = {"run": 1, "replan": {"tick": 2, "reason": "test", "seconds": 0.5, "status": "timeout", "tree": None}}
    text = "\n".join([json.dumps(failed), *lines]) + "\n"
    read = load_tree_input(str(files["tree"]), ScenarioSource())
    data = view_data(read.tree, read.scenario.task, read_trace(text, "t.jsonl"))
    assert len(data["trees"]) == 1
    run = data["runs"][1]
    assert [step["tick"] for step in run["ticks"] if step["replans"]] == [2]
    assert run["replans"][0]["tree"] is None
    assert {step["tree"] for step in run["ticks"]} == {0}


# ------------------------------------------------------------------ bad input
def _view(files: dict[str, Path], trace_text: str, tmp_path: Path, capsys: pytest.CaptureFixture[str]) -> str:
    trace = tmp_path / "bad.jsonl"
    trace.write_text(trace_text, encoding="utf-8")
    out = tmp_path / "bad.html"
    assert main(["view", str(files["tree"]), "--trace", str(trace), "-o", str(out)]) == EXIT_INPUT
    assert not out.exists(), "nothing is written on bad input"
    error = capsys.readouterr().err
    assert error.count("\n") == 1, error
    assert error.startswith("hbtp: error: ")
    return error


def _with_line(files: dict[str, Path], change: Any) -> str:
    lines = [json.loads(line) for line in files["trace"].read_text(encoding="utf-8").splitlines()]
    return "".join(json.dumps(change(line)) + "\n" for line in lines)


def test_a_trace_of_another_action_is_refused(
    files: dict[str, Path], tmp_path: Path, capsys: pytest.CaptureFixture[str]
) -> None:
    def swap(line: dict[str, Any]) -> dict[str, Any]:
        if line.get("run") == 1 and line.get("tick") == 2:
            return {**line, "action": "MoveTo(Bar2)"}
        return line

    error = _view(files, _with_line(files, swap), tmp_path, capsys)
    assert re.search(r"bad\.jsonl:\d+: run 1, tick 2: the trace says running MoveTo\(Bar2\) but the tree ticks ", error)
    assert error.rstrip().endswith("from that state: the trace does not match the tree")


@pytest.mark.parametrize(
    ("change", "message"),
    [
        (lambda line: {**line, "state": [*line["state"], "Nonsense(x)"]}, "unknown predicate 'Nonsense'"),
        (lambda line: {**line, "action": "Fly(Moon)"}, "Fly(Moon) is not a grounded action"),
        (lambda line: {**line, "status": "done"}, "unknown status 'done'"),
        (lambda line: {**line, "tick": 0}, "the tick number must be an integer above 0"),
    ],
)
def test_bad_trace_lines_are_refused_in_one_line(
    files: dict[str, Path], tmp_path: Path, capsys: pytest.CaptureFixture[str], change: Any, message: str
) -> None:
    def first_tick(line: dict[str, Any]) -> dict[str, Any]:
        return change(line) if line.get("run") == 0 and line.get("tick") == 1 else line

    error = _view(files, _with_line(files, first_tick), tmp_path, capsys)
    assert "bad.jsonl:1: " in error
    assert message in error


@pytest.mark.parametrize(
    ("text", "message"),
    [
        ("not json\n", "bad.jsonl:1: not a JSON object"),
        ('{"run": 0, "end": "success"}\n', "no tick lines"),
        ('{"what": 1}\n', "neither a tick, an end nor a replan line"),
        ("", "no tick lines"),
    ],
)
def test_files_that_are_not_traces_are_refused(
    files: dict[str, Path], tmp_path: Path, capsys: pytest.CaptureFixture[str], text: str, message: str
) -> None:
    assert message in _view(files, text, tmp_path, capsys)


def test_a_trace_of_another_tree_is_refused(
    files: dict[str, Path], tmp_path: Path, capsys: pytest.CaptureFixture[str], robowaiter: Scenario
) -> None:
    other = tree_of(plan(robowaiter.task, "On(Water,Table1)", "obtea", mutexes=robowaiter.mutexes, heuristic="lm"))
    text = trace_to_jsonl(simulate(other, robowaiter.task, trace=True), robowaiter.task)
    error = _view(files, text, tmp_path, capsys)
    assert "bad.jsonl:1: run 0, tick 1: the trace says running " in error
    assert "the trace does not match the tree" in error


def test_a_missing_trace_file_is_refused(
    files: dict[str, Path], tmp_path: Path, capsys: pytest.CaptureFixture[str]
) -> None:
    out = tmp_path / "x.html"
    assert main(["view", str(files["tree"]), "--trace", str(tmp_path / "none.jsonl"), "-o", str(out)]) == EXIT_INPUT
    assert "cannot read the trace" in capsys.readouterr().err
    assert not out.exists()


# ------------------------------------------------------------------ in a real browser
def _state(page: Page) -> dict[str, Any]:
    return page.evaluate(
        """(() => {
          const leaf = document.querySelector('#tree .row.active-leaf');
          const count = (selector) => document.querySelectorAll(selector).length;
          return {
            tick: document.body.dataset.tick, run: document.body.dataset.run,
            counter: document.getElementById('tick-counter').textContent,
            leaf: leaf ? Number(leaf.dataset.id) : null,
            leafText: leaf ? leaf.querySelector('.label').textContent : null,
            active: count('#tree .row.active'), tree: document.getElementById('tree').dataset.tree,
            hash: location.hash, literals: count('#state li:not(.removed)'),
          };
        })()"""
    )


@needs_chromium
def test_the_page_steps_through_the_trace_in_chromium(files: dict[str, Path], tmp_path: Path) -> None:
    assert CHROMIUM is not None
    data = _page_data(files["page"].read_text(encoding="utf-8"))
    first = data["runs"][0]["ticks"]
    with Chromium(CHROMIUM, width=1200, height=800) as browser:
        page = browser.open(files["page"].as_uri())
        page.wait_for(READY)
        assert page.evaluate("document.querySelectorAll('#tree .row').length") == len(data["trees"][0]["nodes"])
        seen = [_state(page)]
        assert seen[0]["tick"] == "1"
        assert seen[0]["counter"] == f"tick 1 / {first[-1]['tick']}"
        assert seen[0]["leafText"] == first[0]["action"]
        for _ in range(3):
            page.evaluate("document.getElementById('next').click()")
            seen.append(_state(page))
        assert [s["tick"] for s in seen] == ["1", "2", "3", "4"]
        assert len({s["leaf"] for s in seen}) > 1, "the highlighted node must change as the run goes on"
        for state, step in zip(seen, first[: len(seen)], strict=True):
            path = data["visits"][step["visit"]]["path"]
            assert state["leaf"] == path[-1]
            assert state["active"] == len(path)
            assert state["literals"] == len(data["states"][step["state"]])
            assert state["hash"].endswith(f"tick={step['tick']}")
        page.press("ArrowLeft")
        assert _state(page)["tick"] == "3"
        page.press("End")
        assert _state(page)["tick"] == str(first[-1]["tick"])
        # another run, chosen in the selector
        page.evaluate(
            "(() => { const s = document.getElementById('run'); s.value = '2'; "
            "s.dispatchEvent(new Event('change')); })()"
        )
        assert _state(page)["run"] == "2"
        # search highlights and expands the matching nodes
        page.evaluate(
            "(() => { const s = document.getElementById('search'); s.value = 'movet'; "
            "s.dispatchEvent(new Event('input')); })()"
        )
        page.wait_for("document.querySelectorAll('#tree .row.match').length > 0")
        matches = sum(1 for node in data["trees"][0]["nodes"] if "movet" in node[1].lower())
        assert page.evaluate("document.querySelectorAll('#tree .row.match').length") == matches
        assert page.evaluate("document.getElementById('search-count').textContent") == f"1 / {matches}"
        picture = page.screenshot()
        assert picture.startswith(b"\x89PNG\r\n\x1a\n")
        assert len(picture) > 10_000
        (tmp_path / "view.png").write_bytes(picture)
        # collapse and zoom
        page.evaluate("document.getElementById('collapse-all').click()")
        assert page.evaluate("document.querySelectorAll('#tree li.node.open').length") == 1
        page.evaluate("document.getElementById('zoom-in').click()")
        assert page.evaluate("getComputedStyle(document.documentElement).getPropertyValue('--zoom')").strip() == "1.2"
        # #run=R&tick=N opens that tick
        page = browser.open(files["page"].as_uri() + "#run=1&tick=3")
        page.wait_for(READY)
        state = _state(page)
        assert (state["run"], state["tick"]) == ("1", "3")
        # without a trace: the tree alone
        bare = tmp_path / "bare.html"
        assert main(["view", str(files["tree"]), "-o", str(bare)]) == EXIT_OK
        page = browser.open(bare.as_uri())
        page.wait_for(READY)
        assert page.evaluate("document.getElementById('no-trace').hidden") is False
        assert page.evaluate("document.getElementById('trace-controls').hidden") is True
        assert page.evaluate("document.querySelectorAll('#tree .row.active').length") == 0
        page.evaluate("document.getElementById('expand-all').click()")
        page.press("ArrowRight")  # nothing to step: no error
        assert browser.errors == []


@needs_chromium
def test_a_replan_shows_the_new_tree_in_chromium(tmp_path: Path, robowaiter: Scenario) -> None:
    assert CHROMIUM is not None
    tree, text, replanner = _replanning_trace(robowaiter)
    header = ViewHeader(title="replan", trace="r.jsonl")
    html_file = tmp_path / "replan.html"
    html_file.write_text(tree_page(tree, robowaiter.task, text, header), encoding="utf-8")
    replanned_at = replanner.replans[0].tick
    with Chromium(CHROMIUM) as browser:
        page = browser.open(html_file.as_uri())
        page.wait_for(READY)
        assert page.evaluate("document.querySelectorAll('#timeline .cell.replan').length") == 1
        assert page.evaluate("document.querySelectorAll('#timeline .cell.dist').length") == 1
        assert _state(page)["tree"] == "0"
        for _ in range(replanned_at - 1):
            page.evaluate("document.getElementById('next').click()")
        state = _state(page)
        assert (state["tick"], state["tree"]) == (str(replanned_at), "1")
        info = page.evaluate("document.getElementById('tick-info').textContent")
        assert f"re-planned at tick {replanned_at}: no condition of the tree holds" in info
        assert "from here on tree #1" in info
        assert "disturbance before this tick: make-true: +Holding(Chips) -Holding(Nothing)" in info
        assert page.evaluate("document.querySelectorAll('#tree .row').length") == size(replanner.tree).nodes
        page.press("Home")
        assert _state(page)["tree"] == "0"
        assert browser.errors == []


def _long_fallback(scenario: Scenario, branches: int) -> Node:
    """A Fallback of ``branches`` branches (one shared object) that fail in s0, then one that runs."""
    task = scenario.task
    failing = Sequence((Condition(frozenset({task.atom_id(GOAL)})), Action(task.action("MoveTo(Bar2)").index)))
    running = Sequence((Condition(frozenset()), Action(task.action("Make(Coffee)").index)))
    return Fallback((*[failing] * branches, running))


@needs_chromium
def test_long_child_lists_are_drawn_in_chunks(tmp_path: Path, robowaiter: Scenario) -> None:
    """A node with 1,000 children draws 400 at a time; the active branch far down is drawn at once."""
    assert CHROMIUM is not None
    task = robowaiter.task
    tree = _long_fallback(robowaiter, 1000)
    text = trace_to_jsonl(simulate(tree, task, max_ticks=2, trace=True), task)
    data = _page_data(tree_page(tree, task, text))
    path = data["visits"][data["runs"][0]["ticks"][0]["visit"]]["path"]
    assert path == [0, 3001, 3003]  # the last branch: its Sequence and Make(Coffee)
    assert data["trees"][0]["nodes"][3002] == ["C", "true", 3001]
    html_file = tmp_path / "long.html"
    html_file.write_text(tree_page(tree, task, text), encoding="utf-8")
    with Chromium(CHROMIUM) as browser:
        page = browser.open(html_file.as_uri())
        page.wait_for(READY)
        assert _state(page)["leaf"] == 3003
        assert page.evaluate("document.querySelectorAll('#tree li.more').length") == 1  # 401-800
        rows = page.evaluate("document.querySelectorAll('#tree .row').length")
        assert rows < len(data["trees"][0]["nodes"])
        page.evaluate("document.querySelector('#tree li.more button').click()")
        assert page.evaluate("document.querySelectorAll('#tree li.more').length") == 0
        assert page.evaluate("document.querySelectorAll('#tree .row').length") > rows
        order = page.evaluate(
            "[...document.querySelectorAll('#tree > ul > li > ul > li > .row')].map(r => +r.dataset.id)"
        )
        assert order == sorted(order)
        assert browser.errors == []


@needs_chromium
def test_a_tree_of_over_500_nodes_opens_and_steps(tmp_path: Path) -> None:
    """The issue's target: a 500-node tree opens and steps in headless Chromium within 2 s (the time
    is logged, not asserted: docs/behavior_trees.md reports it, measured on an idle machine)."""
    assert CHROMIUM is not None
    tree_file, trace, out = tmp_path / "big.json", tmp_path / "big.jsonl", tmp_path / "big.html"
    argv = ["plan", "-s", "robothow", "-g", "IsIn_milk_fridge & IsClose_fridge", "-p", "obtea", "--robust", "200"]
    assert main([*argv, "-o", str(tree_file)]) == EXIT_OK
    assert main(["run", str(tree_file), "--perturb", "0.3", "--runs", "3", "--seed", "1", "--trace", str(trace)]) in (
        0,
        1,
    )
    assert main(["view", str(tree_file), "--trace", str(trace), "-o", str(out)]) == EXIT_OK
    data = _page_data(out.read_text(encoding="utf-8"))
    nodes = len(data["trees"][0]["nodes"])
    assert nodes >= 500
    with Chromium(CHROMIUM) as browser:
        page = browser.open()
        started = time.perf_counter()
        page.goto(out.as_uri(), READY)
        leaves = {_state(page)["leaf"]}
        for _ in range(10):
            page.evaluate("document.getElementById('next').click()")
            leaves.add(_state(page)["leaf"])
        seconds = time.perf_counter() - started
        assert len(leaves) > 1
        assert page.screenshot().startswith(b"\x89PNG")
        assert browser.errors == []
    logging.getLogger(__name__).info(
        "hbtp view: %d-node tree loaded and stepped 10 ticks in %.2f s (Chromium's start excluded)", nodes, seconds
    )
