"""``hbtp bench payoff`` in process: rows for every configuration, each tree verified, the summary,
the report, resuming, and one-line errors for bad options."""

from __future__ import annotations

import json
from pathlib import Path
from typing import Any

import pytest

from hbtp.bench.payoff import BEST_FREE, PayoffConfig, crossings
from hbtp.cli import EXIT_OK, main
from hbtp.errors import InputError

ARGV = [
    "bench",
    "payoff",
    "--llm",
    "oracle",
    "--sets",
    "robowaiter",
    "--levels",
    "easy",
    "--scales",
    "1.05",
    "--tasks",
    "2",
]
INLINE = ["--executor", "inline", "--no-progress"]


def rows(path: Path) -> list[dict[str, Any]]:
    return [json.loads(line) for line in path.read_text(encoding="utf-8").splitlines() if line.strip()]


def test_payoff_runs_verifies_summarises_and_resumes(capsys: pytest.CaptureFixture[str], tmp_path: Path) -> None:
    out = tmp_path / "payoff"
    assert main([*ARGV, *INLINE, "-o", str(out)]) == EXIT_OK
    printed = capsys.readouterr().out
    results = rows(out / "results.jsonl")
    # 3 cells x 2 tasks x 3 configurations (obtea+lm, hbtp-s+lm, hbtp:oracle)
    assert len(results) == 18
    assert {r["config"] for r in results} == {"obtea+lm", "hbtp-s+lm", "hbtp:oracle"}
    assert all(r["verified"] and r["solved"] for r in results)
    for row in results:
        assert row["total_s"] == pytest.approx(row["load_s"] + row["solve_s"], abs=1e-5)
        assert row["solve_s"] == pytest.approx(row["model_s"] + row["planning_s"] + row["verify_s"], abs=1e-5)
    guided = [r for r in results if r["config"] == "hbtp:oracle"]
    assert all(r["model_s"] == 0.0 and r["outcome"] == "NF" for r in guided)  # the oracle is no model
    scaled = [r for r in results if r["axis"] == "size"]
    assert {r["load_kind"] for r in scaled} == {"scaled (built)"}
    assert all(r["actions"] > 7329 for r in scaled)
    summary = json.loads((out / "summary.json").read_text(encoding="utf-8"))
    assert [c["cell"] for c in summary["cells"]] == ["robowaiter", "easy", "x1.05"]
    assert summary["cells"][0]["configs"][BEST_FREE]["verified"] == 2
    assert set(summary["crossings"]["size"]["hbtp:oracle"]) == {"total_s", "solve_s"}
    assert all(2 <= r["p_star"] <= 4 for r in results if r["axis"] == "level")  # generated easy tasks
    assert all(r["peak_mb"] >= r["resident_mb"] > 0 for r in results)  # the process's peak, in MB
    assert summary["cells"][0]["configs"]["hbtp:oracle"]["max_peak_mb"] > 0
    assert "When does the LLM pay?" in (out / "report.md").read_text(encoding="utf-8")
    assert "best LLM-free" in printed
    before = (out / "results.jsonl").read_text(encoding="utf-8")
    assert main([*ARGV, *INLINE, "-o", str(out)]) == EXIT_OK  # resumes: nothing runs again
    assert (out / "results.jsonl").read_text(encoding="utf-8") == before


@pytest.mark.parametrize(
    ("extra", "message"),
    [
        (["--llm", "gpt-9"], "unknown backend(s) gpt-9"),
        (["--scales", "0.5"], "every scale must be at least 1"),
        (["--sets", "mars"], "unknown scenario(s) mars"),
        (["--sets", "none", "--levels", "none", "--scales", "none"], "nothing to run"),
        (["--levels", "impossible"], "unknown level(s) impossible"),
        (["-t", "0"], "positive number of seconds"),
        (["--tasks", "0"], "0 is not in the range"),
    ],
)
def test_payoff_bad_options_give_one_line(
    capsys: pytest.CaptureFixture[str], tmp_path: Path, extra: list[str], message: str
) -> None:
    code = main(["bench", "payoff", *extra, "-o", str(tmp_path / "x"), *INLINE])
    err = capsys.readouterr().err
    assert code == 2
    lines = [line for line in err.splitlines() if line.strip()]
    assert len(lines) == 1
    assert message in lines[0]
    assert "Traceback" not in err
    assert not (tmp_path / "x").exists()


def test_crossings_name_the_cells_where_the_order_flips() -> None:
    def cell(name: str, guided: float, free: float) -> dict[str, Any]:
        return {"cell": name, "configs": {"hbtp:x": {"median_total_s": guided}, BEST_FREE: {"median_total_s": free}}}

    cells = [cell("x1", 2.0, 1.0), cell("x2", 2.0, 2.5), cell("x4", 3.0, 9.0)]
    assert crossings(cells, "hbtp:x", "total_s") == {"faster_in": ["x2", "x4"], "crosses": ["x1 → x2"]}


def test_payoff_config_checks_its_values() -> None:
    with pytest.raises(InputError, match="at least one LLM backend"):
        PayoffConfig(backends=())
