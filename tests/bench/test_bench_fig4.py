"""Figure 4 (error tolerance): deterministic, resumable, and HBTP-O stays optimal however wrong p̂ is."""

from __future__ import annotations

import json
from pathlib import Path

from hbtp.bench.fig4 import Fig4Config, run_fig4
from hbtp.bench.runner import INLINE
from hbtp.cli import main


def test_fig4_small_run(tmp_path: Path) -> None:
    config = Fig4Config(correct_rates=(0.0, 1.0), error_rates=(0.0, 1.0), seeds=2, limit=4)
    summary = run_fig4(config, tmp_path / "a", INLINE)
    cells = {(c["planner"], c["error"], c["correct"]): c for c in summary["cells"]}
    assert all(c["solved"] == c["runs"] == 8 for c in cells.values())
    # with a p̂ that holds no wrong action, HBTP-O is optimal; with none at all it is OBTEA
    optimum = cells["hbtp-o", 0.0, 0.0]["mean_cost"]
    assert all(cells["hbtp-o", e, c]["mean_cost"] == optimum for e in (0.0, 1.0) for c in (0.0, 1.0))
    assert all(cells["hbtp-s", e, c]["mean_cost"] >= optimum for e in (0.0, 1.0) for c in (0.0, 1.0))
    # a perfect p̂ lets HBTP-S expand fewer conditions than no p̂
    assert cells["hbtp-s", 0.0, 1.0]["mean_explored"] < cells["hbtp-s", 0.0, 0.0]["mean_explored"]
    again = run_fig4(config, tmp_path / "b", INLINE)
    untimed = [{k: v for k, v in c.items() if k != "mean_time_s"} for c in summary["cells"]]
    assert [{k: v for k, v in c.items() if k != "mean_time_s"} for c in again["cells"]] == untimed
    rows = (tmp_path / "a" / "results.jsonl").read_text(encoding="utf-8")
    run_fig4(config, tmp_path / "a", INLINE)  # resumes: nothing new is appended
    assert (tmp_path / "a" / "results.jsonl").read_text(encoding="utf-8") == rows


def test_fig4_cli_rejects_bad_rates(tmp_path: Path) -> None:
    assert main(["bench", "fig4", "--correct-rates", "0,2", "-o", str(tmp_path)]) == 2
    assert main(["bench", "fig4", "--error-rates", "x", "-o", str(tmp_path)]) == 2
    assert main(["bench", "fig4", "--limit", "2", "--seeds", "1", "--no-progress", "-o", str(tmp_path)]) == 0
    assert json.loads((tmp_path / "summary.json").read_text(encoding="utf-8"))["cells"]
