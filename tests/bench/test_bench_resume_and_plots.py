"""``hbtp bench all`` resumed: each part keeps its earlier wall time; progress bars name the
sub-part; the report credits the paper's authors."""

from __future__ import annotations

import json
from dataclasses import dataclass
from pathlib import Path
from typing import Any

import pytest

from hbtp.bench import suite
from hbtp.bench.results import ResultsFile, Row
from hbtp.bench.runner import Execution, Work, run_work
from hbtp.bench.suite import SuiteConfig, run_suite
from hbtp.bench.table1 import Table1Config, run_table1
from hbtp.bench.table2 import BackendRecipe
from hbtp.errors import InputError
from hbtp.llm.backends.registry import LlmSpec


class FakeClock:
    def __init__(self) -> None:
        self.now = 1000.0

    def __call__(self) -> float:
        return self.now


def _fake_part(clock: FakeClock, seconds: float, interrupt: bool = False) -> suite.Part:
    def part(config: SuiteConfig, recipe: BackendRecipe, out: Path, execution: Execution) -> tuple[Any, list[str]]:
        name = next(n for n, f in suite.PART_RUNS.items() if f is part)
        (out / name).mkdir(parents=True, exist_ok=True)
        clock.now += seconds
        if interrupt:
            raise KeyboardInterrupt
        return {}, []

    return part


def _run(out: Path, parts: tuple[str, ...] = ("table1", "fig4")) -> dict[str, Any]:
    return run_suite(SuiteConfig(parts=parts), BackendRecipe(LlmSpec.parse("oracle")), out, Execution("inline"))


def test_a_resumed_run_adds_its_time_to_each_part_s_earlier_time(
    tmp_path: Path, monkeypatch: pytest.MonkeyPatch
) -> None:
    clock = FakeClock()
    monkeypatch.setattr(suite, "clock", clock)
    # First run: table1 takes 600 s, then fig4 is interrupted after 35 s.
    monkeypatch.setitem(suite.PART_RUNS, "table1", _fake_part(clock, 600.0))
    monkeypatch.setitem(suite.PART_RUNS, "fig4", _fake_part(clock, 35.0, interrupt=True))
    with pytest.raises(KeyboardInterrupt):
        _run(tmp_path)
    assert json.loads((tmp_path / "seconds.json").read_text(encoding="utf-8")) == {"table1": 600.0, "fig4": 35.0}
    # The resume: table1 only reloads its rows (2 s), fig4 finishes (10 s).
    monkeypatch.setitem(suite.PART_RUNS, "table1", _fake_part(clock, 2.0))
    monkeypatch.setitem(suite.PART_RUNS, "fig4", _fake_part(clock, 10.0))
    summary = _run(tmp_path)
    assert summary["seconds"] == {"table1": 602.0, "fig4": 45.0}
    assert summary["seconds_this_run"] == {"table1": 2.0, "fig4": 10.0}
    report = (tmp_path / "report.md").read_text(encoding="utf-8")
    assert "Wall time 647 s (table1 602 s, fig4 45 s), over several runs into this folder (this one 12 s)." in report
    # A part whose folder was deleted (to redo it) starts again from zero.
    (tmp_path / "fig4").rmdir()
    summary = _run(tmp_path)
    assert summary["seconds"] == {"table1": 604.0, "fig4": 10.0}


def test_a_fresh_run_reports_its_own_time(tmp_path: Path, monkeypatch: pytest.MonkeyPatch) -> None:
    clock = FakeClock()
    monkeypatch.setattr(suite, "clock", clock)
    monkeypatch.setitem(suite.PART_RUNS, "table1", _fake_part(clock, 7.0))
    _run(tmp_path, ("table1",))
    report = (tmp_path / "report.md").read_text(encoding="utf-8")
    assert "Wall time 7 s (table1 7 s)." in report
    # The paper's first author is Yishuai Cai.
    assert "of Cai et al., HBTP" in report
    assert "Chen et al." not in report


@pytest.mark.parametrize("content", ["[1, 2]", '{"table1": "soon"}', '{"nope": 3}', "{not json"])
def test_a_broken_seconds_file_is_an_input_error(tmp_path: Path, monkeypatch: pytest.MonkeyPatch, content: str) -> None:
    monkeypatch.setitem(suite.PART_RUNS, "table1", _fake_part(FakeClock(), 1.0))
    (tmp_path / "table1").mkdir()
    (tmp_path / "seconds.json").write_text(content, encoding="utf-8")
    with pytest.raises(InputError, match=r"seconds\.json"):
        _run(tmp_path, ("table1",))


@dataclass(frozen=True, kw_only=True)
class Double(Row):
    KEY = ("n",)

    n: int
    twice: int


def _double(spec: int) -> Double:
    return Double(n=spec, twice=2 * spec)


def test_the_progress_bar_names_the_stage(tmp_path: Path, capsys: pytest.CaptureFixture[str]) -> None:
    results = ResultsFile(tmp_path / "results.jsonl", Double)
    work = [Work((n,), n, {"n": n}, stage="first" if n < 2 else "second") for n in range(4)]
    run_work(_double, work, results, Execution("inline", progress=True), kill_after=10.0, description="demo")
    err = capsys.readouterr().err
    assert "demo first:" in err
    assert "demo second:" in err


def test_table1_progress_names_the_setting_and_the_planner(tmp_path: Path, capsys: pytest.CaptureFixture[str]) -> None:
    config = Table1Config(planners=("obtea", "hbtp-s"), limit=2)
    run_table1(config, tmp_path, Execution("inline", progress=True))
    err = capsys.readouterr().err
    assert "table1 pruned obtea:" in err
    assert "table1 pruned hbtp-s:" in err
    lm = Table1Config(space="full", planners=("obtea",), hints="none", heuristic="lm", limit=1)
    run_table1(lm, tmp_path / "lm", Execution("inline", progress=True))
    assert "table1 full no-hints lm obtea:" in capsys.readouterr().err


# ------------------------------------------------------------------ plots
def _capture(monkeypatch: pytest.MonkeyPatch) -> list[Any]:
    """Keep the figures the plot functions would save."""
    from hbtp.bench import plots

    figures: list[Any] = []

    def keep(plt: Any, figure: Any, path: Path) -> bool:
        figure.tight_layout()
        figure.canvas.draw()
        figures.append(figure)
        return True

    monkeypatch.setattr(plots, "_save", keep)
    return figures


def test_identical_series_are_drawn_once_and_labelled_together() -> None:
    from hbtp.bench.plots import Series, merge_identical

    same = (1.0, 2.0)
    lines = [
        Series("HBTP-O ER=", "0", (0.0, 1.0), same),
        Series("HBTP-O ER=", "0.5", (0.0, 1.0), same),
        Series("HBTP-S ER=", "0", (0.0, 1.0), (1.0, 3.0)),
        Series("HBTP-S ER=", "1", (0.0, 1.0), same),
    ]
    assert [(index, label) for index, label, _ in merge_identical(lines)] == [
        (0, "HBTP-O ER=0/0.5\n= HBTP-S ER=1 (identical)"),
        (2, "HBTP-S ER=0"),
    ]


def _fig4_summary() -> dict[str, Any]:
    cells = []
    for planner in ("hbtp-o", "hbtp-s"):
        for error in (0.0, 0.5, 1.0):
            for correct in (0.0, 1.0):
                explored = 20.0 - 10 * correct if planner == "hbtp-s" else 20.0 - correct - error
                cost = 57.38 if planner == "hbtp-o" else 57.5 + error
                cells.append(
                    {
                        "planner": planner,
                        "error": error,
                        "correct": correct,
                        "mean_explored": explored,
                        "mean_cost": cost,
                    }
                )
    config = {"error_rates": [0.0, 0.5, 1.0], "planners": ["hbtp-o", "hbtp-s"]}
    return {"cells": cells, "config": config}


def test_fig4_shows_every_series(tmp_path: Path, monkeypatch: pytest.MonkeyPatch) -> None:
    from hbtp.bench.plots import plot_fig4

    figures = _capture(monkeypatch)
    assert plot_fig4(_fig4_summary(), tmp_path / "fig4.png")
    left, middle, right = figures[0].axes
    # HBTP-S's |S⁻| is the same at every error rate: one line that says so, not three on top of each other.
    assert [t.get_text() for t in middle.get_legend().get_texts()] == ["ER=0/0.5/1 (identical)"]
    # HBTP-O's D(T) is the optimum at every error rate; HBTP-S's differ and keep their own lines.
    assert [t.get_text() for t in right.get_legend().get_texts()] == [
        "HBTP-O ER=0/0.5/1 (identical)",
        "HBTP-S ER=0",
        "HBTP-S ER=0.5",
        "HBTP-S ER=1",
    ]
    # Distinct lines differ in marker and line style, so overlapping ones stay visible.
    styles = [(line.get_marker(), line.get_linestyle()) for line in left.get_lines()]
    assert len(styles) == 3
    assert len(set(styles)) == 3


def _fig3_summary(space: str, heuristic: str) -> dict[str, Any]:
    planners = ["bte", "obtea", "hbtp-o", "hbtp-s"]
    by_size = [
        {"planner": p, "actions": a, "mean_time_s": 0.01 * (i + 1)} for i, p in enumerate(planners) for a in (10, 20)
    ]
    by_length = [{"planner": p, "p_star": 2, "mean_time_s": 0.01} for p in planners]
    config = {"planners": planners, "space": space, "heuristic": heuristic}
    return {"config": config, "by_action_space": by_size, "by_path_length": by_length}


@pytest.mark.parametrize(
    ("space", "heuristic", "title"),
    [
        ("full", "none", "Figure 3: full space, no heuristic"),
        ("full", "lm", "Figure 3: full space, landmark heuristic (lm)"),
        ("pruned", "none", "Figure 3: pruned spaces (the records'), no heuristic"),
    ],
)
def test_fig3_titles_name_the_space_and_the_heuristic(
    tmp_path: Path, monkeypatch: pytest.MonkeyPatch, space: str, heuristic: str, title: str
) -> None:
    from hbtp.bench.plots import plot_fig3

    figures = _capture(monkeypatch)
    assert plot_fig3(_fig3_summary(space, heuristic), tmp_path / "fig3.png")
    figure = figures[0]
    assert figure.get_suptitle() == title
    # (b) has all four planners at the same point: merged into one labelled line.
    labels = [t.get_text() for t in figure.axes[1].get_legend().get_texts()]
    assert labels == ["BT Expansion/OBTEA/HBTP-O/HBTP-S (identical)"]


def test_the_robustness_legend_covers_no_bar(tmp_path: Path, monkeypatch: pytest.MonkeyPatch) -> None:
    from hbtp.bench.plots import plot_robustness

    figures = _capture(monkeypatch)
    rates = {"full": {"success_rate": 1.0}, "path": {"success_rate": 0.97}}
    summary = {"scenarios": {name: {"p": {"0.1": rates}} for name in ("a", "b", "all")}, "config": {"p_values": [0.1]}}
    assert plot_robustness(summary, tmp_path / "robustness.png")
    axis = figures[0].axes[0]
    renderer = figures[0].canvas.get_renderer()
    legend = axis.get_legend().get_window_extent(renderer)
    for bar in axis.patches:
        assert not legend.overlaps(bar.get_window_extent(renderer))
