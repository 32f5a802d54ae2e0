"""``hbtp run``, ``hbtp verify`` and ``hbtp bench robustness``, invoked as click commands."""

from __future__ import annotations

import json
from pathlib import Path

import pytest
from click.testing import CliRunner

from hbtp.bt import Action, Condition, Fallback, Node, Sequence, tree_of
from hbtp.bt.jsonio import tree_to_json
from hbtp.cli import EXIT_OK, main
from hbtp.cli.robustness_command import robustness
from hbtp.cli.run_command import run_command, verify_command
from hbtp.cli.view_command import view_command
from hbtp.domains import Scenario
from hbtp.planning import plan

GOAL = "IsIn_apple_fridge & IsClose_fridge"


@pytest.fixture(scope="module")
def planned(robothow_small: Scenario) -> Node:
    result = plan(robothow_small.task, GOAL, "obtea", mutexes=robothow_small.mutexes, heuristic="lm")
    assert result.solved
    return tree_of(result)


def _write(path: Path, tree: Node, scenario: Scenario, goal: str = GOAL) -> str:
    path.write_text(tree_to_json(tree, scenario.task, scenario=scenario.name, goal=goal), encoding="utf-8")
    return str(path)


def test_run_reaches_the_goal(tmp_path: Path, planned: Node, robothow_small: Scenario) -> None:
    file = _write(tmp_path / "tree.json", planned, robothow_small)
    result = CliRunner().invoke(run_command, [file, "--scenario", "robothow-small"])
    assert result.exit_code == 0, result.output
    assert result.output.startswith("goal reached: 8 tick(s), cost 59, 7 action(s)")
    assert "executes: Walk(apple) -> " in result.output
    result = CliRunner().invoke(run_command, [file, "-s", "robothow-small", "--json"])
    assert result.exit_code == 0
    data = json.loads(result.output)
    assert data["reached"] is True
    assert data["status"] == "success"
    assert data["ticks"] == 8
    assert data["cost"] == 59
    assert data["executed"][-1] == "Close(fridge)"
    assert data["goal"] == "IsIn(apple,fridge) & IsClose(fridge)"


def test_run_with_perturbations_and_a_trace(tmp_path: Path, planned: Node, robothow_small: Scenario) -> None:
    file = _write(tmp_path / "tree.json", planned, robothow_small)
    trace = tmp_path / "trace.jsonl"
    args = [file, "-s", "robothow-small", "--perturb", "0.3", "--runs", "6", "--seed", "2", "--json"]
    result = CliRunner().invoke(run_command, [*args, "--trace", str(trace)])
    data = json.loads(result.output)
    assert result.exit_code == (0 if data["reached"] else 1)
    assert data["runs"] == 6
    assert len(data["results"]) == 6
    assert data["reached"] == (data["successes"] == 6)
    assert data["base"]["cost"] == 59
    lines = [json.loads(line) for line in trace.read_text(encoding="utf-8").splitlines()]
    assert {line["run"] for line in lines} == set(range(6))
    assert sum("end" in line for line in lines) == 6
    assert any(line.get("disturbance") for line in lines)
    again = CliRunner().invoke(run_command, args)
    assert json.loads(again.output) == data  # seeded: the same runs again
    text = CliRunner().invoke(run_command, [file, "-s", "robothow-small", "--perturb", "0.3", "--runs", "6"])
    assert "perturbed run(s) reached the goal (p=0.3, seed 0)" in text.output
    assert "undisturbed: goal reached: 8 tick(s)" in text.output


def test_run_exits_1_when_the_goal_is_not_reached(tmp_path: Path, robothow_small: Scenario) -> None:
    task = robothow_small.task
    goal = task.resolve_goal(GOAL).ids
    walk = task.action("Walk(apple)").index
    tree = Fallback((Condition(goal), Sequence((Condition(frozenset()), Action(walk)))))
    file = _write(tmp_path / "tree.json", tree, robothow_small)
    result = CliRunner().invoke(run_command, [file, "-s", "robothow-small", "--max-ticks", "5"])
    assert result.exit_code == 1
    assert result.output.startswith("tick limit: 5 tick(s), cost 75, 5 action(s)")  # it walks forever
    file = _write(tmp_path / "goal-only.json", Condition(goal), robothow_small)
    result = CliRunner().invoke(run_command, [file, "-s", "robothow-small"])
    assert result.exit_code == 1
    assert result.output.startswith("failure, goal not reached: 1 tick(s), cost 0")


@pytest.mark.parametrize(
    ("content", "message"),
    [
        ("not json at all", "not valid JSON"),
        ('{"format": "hbtp-tree", "version": 1, "root": {"type": "Parallel", "children": []}}', "unknown node type"),
        (
            '{"format": "hbtp-tree", "version": 1, "root": {"type": "Condition", "literals": ["IsFlying(self)"]}}',
            "IsFlying",
        ),
        ('{"format": "hbtp-tree", "version": 1, "root": {"type": "Action", "action": "Fly(apple)"}}', "Fly(apple)"),
        ('{"format": "something-else"}', "not an hbtp tree"),
    ],
)
def test_bad_trees_exit_2(tmp_path: Path, content: str, message: str) -> None:
    file = tmp_path / "bad.json"
    file.write_text(content, encoding="utf-8")
    for command in (run_command, verify_command):
        result = CliRunner().invoke(command, [str(file), "-s", "robothow-small", "--goal", GOAL])
        assert result.exit_code == 2, result.output
        assert message in result.output


def test_bad_options_exit_2(tmp_path: Path, planned: Node, robothow_small: Scenario) -> None:
    file = _write(tmp_path / "tree.json", planned, robothow_small)
    for extra in (["--perturb", "1.5"], ["--perturb", "-0.1"], ["--runs", "0"], ["--max-ticks", "0"]):
        result = CliRunner().invoke(run_command, [file, "-s", "robothow-small", *extra])
        assert result.exit_code == 2, (extra, result.output)
    assert "[0, 1]" in CliRunner().invoke(run_command, [file, "-s", "robothow-small", "--perturb", "2"]).output
    missing = CliRunner().invoke(run_command, [str(tmp_path / "nope.json"), "-s", "robothow-small"])
    assert missing.exit_code == 2
    assert "cannot read" in missing.output
    unknown = CliRunner().invoke(run_command, [file, "-s", "no-such-scenario"])
    assert unknown.exit_code == 2
    bad_goal = CliRunner().invoke(run_command, [file, "-s", "robothow-small", "--goal", "IsFlying_self"])
    assert bad_goal.exit_code == 2


def test_verify(tmp_path: Path, planned: Node, robothow_small: Scenario) -> None:
    file = _write(tmp_path / "tree.json", planned, robothow_small)
    result = CliRunner().invoke(verify_command, [file, "-s", "robothow-small"])
    assert result.exit_code == 0, result.output
    assert result.output.startswith("ok; goal reaching proved")
    data = json.loads(CliRunner().invoke(verify_command, [file, "-s", "robothow-small", "--json"]).output)
    assert data["ok"] is True
    assert data["proved_goal_reaching"] is True
    assert data["reaches_goal_from_initial_state"] is True
    # Break it: drop the goal check; then a branch after it no longer leads anywhere.
    assert isinstance(planned, Fallback)
    broken = _write(tmp_path / "broken.json", Fallback(planned.children[1:]), robothow_small)
    result = CliRunner().invoke(verify_command, [broken, "-s", "robothow-small"])
    assert result.exit_code == 1
    assert "problem: root.children[0].children[1]: the tree does not check the goal first" in result.output
    data = json.loads(CliRunner().invoke(verify_command, [broken, "-s", "robothow-small", "--json"]).output)
    assert data["ok"] is False
    assert data["problems"][0]["path"] == "root.children[0].children[1]"


def test_verify_needs_a_goal(tmp_path: Path, planned: Node, robothow_small: Scenario) -> None:
    file = _write(tmp_path / "tree.json", planned, robothow_small, goal="")
    result = CliRunner().invoke(verify_command, [file, "-s", "robothow-small"])
    assert result.exit_code == 2
    assert "--goal" in result.output
    assert CliRunner().invoke(verify_command, [file, "-s", "robothow-small", "-g", GOAL]).exit_code == 0
    # Without a goal, ``run`` counts the root's SUCCESS.
    assert CliRunner().invoke(run_command, [file, "-s", "robothow-small"]).exit_code == 0


def test_bench_robustness(tmp_path: Path) -> None:
    out = tmp_path / "robustness"
    args = ["-o", str(out), "--scenarios", "robowaiter", "--limit", "2", "--runs", "3", "--no-progress"]
    result = CliRunner().invoke(robustness, args)
    assert result.exit_code == 0, result.output
    assert "robowaiter" in result.output
    rows = [json.loads(line) for line in (out / "results.jsonl").read_text(encoding="utf-8").splitlines()]
    assert len(rows) == 2 * 2 * 2  # tasks x p x trees
    assert {(r["p"], r["tree"]) for r in rows} == {(0.1, "full"), (0.1, "path"), (0.2, "full"), (0.2, "path")}
    assert all(r["planned_with"] == "hbtp-s/pruned" and r["runs"] == 3 for r in rows)
    summary = json.loads((out / "summary.json").read_text(encoding="utf-8"))
    block = summary["scenarios"]["robowaiter"]
    assert block["tasks"] == 2
    assert block["p"]["0.1"]["full"]["tasks"] == 2
    assert summary["config"]["runs"] == 3
    again = CliRunner().invoke(robustness, args)  # resumes: nothing new to run
    assert again.exit_code == 0
    assert len((out / "results.jsonl").read_text(encoding="utf-8").splitlines()) == 8
    assert CliRunner().invoke(robustness, ["-o", str(out), "--scenarios", "mars"]).exit_code == 2
    assert CliRunner().invoke(robustness, ["-o", str(out), "--p", "0.1,7"]).exit_code == 2


@pytest.fixture(scope="module")
def path_tree(robothow_small: Scenario) -> Node:
    return tree_of(plan(robothow_small.task, GOAL, "obtea", mutexes=robothow_small.mutexes, heuristic="lm"), "path")


@pytest.mark.parametrize("engine", ["pytrees", "btcpp"])
def test_run_with_another_engine_replans_like_hbtp(
    tmp_path: Path, path_tree: Node, robothow_small: Scenario, engine: str
) -> None:
    """``hbtp run --engine pytrees --replan 3 --perturb 0.2 --runs 5``: the same runs and re-plans as
    hbtp's engine, and a trace with a line for each tree a re-plan swapped in."""
    pytest.importorskip("py_trees.parsers.behaviour_tree_xml" if engine == "pytrees" else "behaviortreepy")
    file = _write(tmp_path / "tree.json", path_tree, robothow_small)
    args = [file, "--replan", "3", "--perturb", "0.2", "--runs", "5", "--json"]
    ours = json.loads(CliRunner().invoke(run_command, args).output)
    trace = tmp_path / "trace.jsonl"
    result = CliRunner().invoke(run_command, [*args, "--engine", engine, "--trace", str(trace)])
    assert result.exit_code == 0, result.output
    theirs = json.loads(result.output)
    assert (ours["engine"], theirs["engine"]) == ("hbtp", engine)
    assert theirs["successes"] == 5
    assert theirs["replans"] == ours["replans"] == 1  # seed 0: one run needs a new tree
    strip = [{k: v for k, v in row.items() if k != "replans"} for row in ours["results"]]
    assert [{k: v for k, v in row.items() if k != "replans"} for row in theirs["results"]] == strip
    lines = [json.loads(line) for line in trace.read_text(encoding="utf-8").splitlines()]
    (position,) = [i for i, line in enumerate(lines) if "replan" in line]
    replan, after = lines[position], lines[position + 1]
    assert replan["run"] == after["run"]
    assert replan["replan"]["tick"] == after["tick"]
    assert replan["replan"]["tree"]["type"] == "Fallback"
    view = CliRunner().invoke(view_command, [file, "--trace", str(trace), "-o", str(tmp_path / "view.html")])
    assert view.exit_code == 0, view.output  # hbtp view checks every tick against the tree in use
    text = CliRunner().invoke(run_command, [*args[:-1], "--engine", engine])
    assert text.output.splitlines()[0] == ("py_trees:" if engine == "pytrees" else "BehaviorTree.CPP:")
    assert "re-plans: 1 in all" in text.output


def test_run_with_py_trees_and_a_trace(tmp_path: Path, planned: Node, robothow_small: Scenario) -> None:
    pytest.importorskip("py_trees.parsers.behaviour_tree_xml")
    file = _write(tmp_path / "tree.json", planned, robothow_small)
    trace = tmp_path / "trace.jsonl"
    result = CliRunner().invoke(run_command, [file, "--engine", "pytrees", "--trace", str(trace)])
    assert result.exit_code == 0, result.output
    assert result.output.startswith("py_trees: goal reached: 8 tick(s), cost 59, 7 action(s)")
    ours = CliRunner().invoke(run_command, [file, "--trace", str(tmp_path / "ours.jsonl")])
    assert ours.exit_code == 0
    assert trace.read_text(encoding="utf-8") == (tmp_path / "ours.jsonl").read_text(encoding="utf-8")
    watched = CliRunner().invoke(run_command, [file, "--engine", "pytrees", "--btlog", str(tmp_path / "x.btlog")])
    assert watched.exit_code == 2
    assert "give --engine btcpp" in watched.output


def test_the_runs_of_one_command_share_one_kept_search(
    tmp_path: Path, path_tree: Node, robothow_small: Scenario, monkeypatch: pytest.MonkeyPatch
) -> None:
    """``hbtp run --replan N --runs R``: a re-plan continues the search the runs before it kept (as
    ``replanning_runs`` does), so the command makes one kept search, not one per run."""
    from hbtp.cli import run_command as module
    from hbtp.replanning import KeptSearch

    made: list[KeptSearch] = []

    class Counted(KeptSearch):
        def __init__(self) -> None:
            super().__init__()
            made.append(self)

    monkeypatch.setattr(module, "KeptSearch", Counted)
    file = _write(tmp_path / "tree.json", path_tree, robothow_small)
    result = CliRunner().invoke(run_command, [file, "--replan", "3", "--perturb", "0.5", "--runs", "6", "--json"])
    assert result.exit_code == 0, result.output
    record = json.loads(result.output)
    assert record["successes"] == 6
    assert record["replans"] >= 2
    assert len(made) == 1
    assert made[0].search is not None  # the last re-plan's search, kept for the next one


def test_a_tree_planned_with_hints_records_them_and_re_plans_in_their_space(tmp_path: Path) -> None:
    """``hbtp plan --llm oracle -o tree.json`` records the hints whose space the tree was planned in;
    ``hbtp run --replan`` re-plans there first (most re-plans of these runs find a tree there; the
    others in the full space), every run reaching the goal; ``--replan-full-space`` re-plans in the
    full space only; a "hints" record of the wrong shape is a one-line error."""
    file = tmp_path / "tree.json"
    argv = ["plan", "-s", "robothow-small", "-g", GOAL, "--llm", "oracle", "--tree", "path", "-o", str(file)]
    assert main(argv) == EXIT_OK
    document = json.loads(file.read_text(encoding="utf-8"))
    assert "Walk(apple)" in document["hints"]["path"]
    assert set(document["hints"]) == {"path", "predicates", "objects"}
    args = [str(file), "--replan", "5", "--perturb", "0.5", "--runs", "12", "--json"]
    spaces = {}
    for name, extra in (("hints", []), ("full", ["--replan-full-space"])):
        result = CliRunner().invoke(run_command, [*args, *extra])
        assert result.exit_code == 0, result.output
        record = json.loads(result.output)
        assert record["successes"] == 12
        spaces[name] = [replan["space"] for row in record["results"] for replan in row["replans"]]
    assert spaces["hints"].count("pruned") > spaces["hints"].count("full")
    assert spaces["full"]
    assert set(spaces["full"]) == {"full"}
    document["hints"] = {"path": "Walk(apple)"}
    file.write_text(json.dumps(document), encoding="utf-8")
    result = CliRunner().invoke(run_command, [str(file), "--replan", "1"])
    assert result.exit_code == 2
    assert result.output.strip().endswith('"hints" must hold the lists "path", "predicates" and "objects" of names')
