"""``hbtp bench all``: every table and figure of the paper into one folder, with one report.

Layout of ``out``: ``table1/`` (three settings: pruned space with oracle hints, full space with
oracle hints, full space without hints and with the landmark heuristic), ``table2/<scenario>/``,
``fig3/none``, ``fig3/lm`` and ``fig3/pruned`` (the full space without a heuristic as in the paper,
with the landmark heuristic, and the pruned spaces), ``fig4/``,
``robustness/``; each with results.jsonl, summary.json, report.md and PNG plots; and at the top
``report.md`` (every section, plus the machine and the settings) and ``summary.json``.
``quick`` runs a few tasks per cell with shorter limits (a few minutes on two cores). Every part
resumes from its results.jsonl, so an interrupted run picks up where it stopped.

``seconds.json`` keeps the wall time each part has taken over every run into ``out`` (an
interrupted part included), so the report of a resumed run gives the whole time, not just the
resume's; a part whose folder is missing when the run starts (never run, or deleted to redo it)
starts again from zero.
"""

from __future__ import annotations

import logging
import os
import platform
import time
from collections.abc import Callable, Sequence
from dataclasses import dataclass, replace
from pathlib import Path
from typing import Any

from hbtp import __version__
from hbtp.bench.fig3 import Fig3Config, run_fig3
from hbtp.bench.fig4 import Fig4Config, run_fig4
from hbtp.bench.report import (
    fig3_section,
    fig4_section,
    robustness_section,
    table1_section,
    table2_section,
    write_report,
)
from hbtp.bench.results import read_json, write_json
from hbtp.bench.robustness import SCENARIOS, RobustnessConfig, run_robustness
from hbtp.bench.runner import DEFAULT_EXECUTION, Execution
from hbtp.bench.table1 import Table1Config, run_table1, setting_label, write_table1_report
from hbtp.bench.table2 import BackendRecipe, Table2Config, run_table2, write_table2_report
from hbtp.errors import InputError
from hbtp.pipeline import LoopOptions
from hbtp.planning.heuristic_names import HeuristicName
from hbtp.planning.planners import Space

log = logging.getLogger(__name__)

PARTS = ("table1", "table2", "fig3", "fig4", "robustness")
#: The file, in the suite's folder, with each part's wall time summed over every run.
SECONDS_FILE = "seconds.json"
#: The wall clock of the part timings (tests replace it).
clock: Callable[[], float] = time.perf_counter


@dataclass(frozen=True)
class SuiteConfig:
    quick: bool = False
    parts: tuple[str, ...] = PARTS
    runs: int = 1

    def __post_init__(self) -> None:
        unknown = [p for p in self.parts if p not in PARTS]
        if unknown or not self.parts:
            raise InputError(f"unknown part(s) {', '.join(unknown) or '(none)'}; choose from {', '.join(PARTS)}")


def table1_settings(quick: bool) -> list[tuple[str, Table1Config]]:
    """(folder, setting): the paper's two settings, and OBTEA with the landmark heuristic."""
    limit, full_limit, seconds = (10, 5, 2.0) if quick else (None, None, 5.0)
    return [
        ("pruned", Table1Config(space=Space.PRUNED, hints="oracle", time_limit=5.0, limit=limit)),
        ("full", Table1Config(space=Space.FULL, hints="oracle", time_limit=seconds, limit=full_limit)),
        (
            "full-lm",
            Table1Config(
                space=Space.FULL,
                planners=("obtea",),
                hints="none",
                heuristic=HeuristicName.LM,
                time_limit=5.0,
                limit=limit,
            ),
        ),
    ]


def fig3_settings(quick: bool) -> list[tuple[str, Fig3Config]]:
    if quick:
        base = Fig3Config(scales=(1.0, 2.0), time_limit=2.0, limit=3)
    else:
        base = Fig3Config(scales=(1.0, 1.5, 2.0, 2.5, 3.0), time_limit=5.0, limit=20)
    return [
        ("none", base),
        ("lm", replace(base, heuristic=HeuristicName.LM)),
        ("pruned", replace(base, space=Space.PRUNED)),
    ]


def fig4_setting(quick: bool) -> Fig4Config:
    return Fig4Config(seeds=1, limit=5) if quick else Fig4Config()


Part = Callable[[SuiteConfig, BackendRecipe, Path, Execution], tuple[Any, list[str]]]


def _table1(config: SuiteConfig, recipe: BackendRecipe, out: Path, execution: Execution) -> tuple[Any, list[str]]:
    table1 = {
        setting_label(setting): run_table1(setting, out / "table1" / folder, execution)
        for folder, setting in table1_settings(config.quick)
    }
    write_table1_report(out / "table1", table1)
    return table1, [_relink(table1_section(table1), "table1")]


def _table2(config: SuiteConfig, recipe: BackendRecipe, out: Path, execution: Execution) -> tuple[Any, list[str]]:
    loop = LoopOptions()  # the prompt style is the backend's own
    rows = []
    for name in SCENARIOS:
        table2 = Table2Config(
            scenario=name,
            backend=str(recipe.llm) if recipe.llm else "recorded",
            runs=config.runs,
            limit=3 if config.quick else None,
            loop=loop,
            b_time_limit=1.0 if config.quick else 10.0,
        )
        rows.append(run_table2(table2, recipe, out / "table2" / name, execution))
    write_table2_report(out / "table2", rows)
    return rows, [_relink(table2_section(rows), "table2")]


def _fig3(config: SuiteConfig, recipe: BackendRecipe, out: Path, execution: Execution) -> tuple[Any, list[str]]:
    results = {
        label: run_fig3(figure, out / "fig3" / label, execution) for label, figure in fig3_settings(config.quick)
    }
    return results, [_relink(fig3_section(result), f"fig3/{label}") for label, result in results.items()]


def _fig4(config: SuiteConfig, recipe: BackendRecipe, out: Path, execution: Execution) -> tuple[Any, list[str]]:
    result = run_fig4(fig4_setting(config.quick), out / "fig4", execution)
    return result, [_relink(fig4_section(result), "fig4")]


def _robustness(config: SuiteConfig, recipe: BackendRecipe, out: Path, execution: Execution) -> tuple[Any, list[str]]:
    setting = RobustnessConfig(runs=5, limit=3) if config.quick else RobustnessConfig()
    result = run_robustness(setting, out / "robustness", execution)
    return result, [_relink(robustness_section(result), "robustness")]


#: Each part: run (or resume) it into the suite's folder; its summary and report sections.
PART_RUNS: dict[str, Part] = {
    "table1": _table1,
    "table2": _table2,
    "fig3": _fig3,
    "fig4": _fig4,
    "robustness": _robustness,
}


def run_suite(
    config: SuiteConfig, recipe: BackendRecipe, out: Path, execution: Execution = DEFAULT_EXECUTION
) -> dict[str, Any]:
    """Run (or resume) every selected part into ``out``; write the report; return the summary.

    Each part's time in the report and the summary is its time over every run into ``out``
    (``seconds.json``), so resuming adds to what the earlier runs took.
    """
    sections: list[str] = []
    summary: dict[str, Any] = {"quick": config.quick, "parts": list(config.parts)}
    recorded = _recorded_seconds(out)
    this_run: dict[str, float] = {}
    for part in PARTS:
        if part not in config.parts:
            continue
        began = clock()
        try:
            summary[part], part_sections = PART_RUNS[part](config, recipe, out, execution)
        finally:
            # Also when the part is interrupted: a resume then adds to the time it had taken.
            this_run[part] = round(clock() - began, 1)
            recorded[part] = round(recorded.get(part, 0.0) + this_run[part], 1)
            write_json(out / SECONDS_FILE, recorded)
        sections.extend(part_sections)
        log.info("bench all: %s done in %.1f s (%.1f s in all runs)", part, this_run[part], recorded[part])
    timings = {part: recorded[part] for part in this_run}
    summary["seconds"] = timings
    summary["seconds_this_run"] = this_run
    summary["machine"] = machine()
    write_json(out / "summary.json", summary)
    intro = _intro(config, recipe, execution, timings, this_run)
    write_report(out / "report.md", "hbtp benchmarks" + (" (quick)" if config.quick else ""), [intro, *sections])
    return summary


def _recorded_seconds(out: Path) -> dict[str, float]:
    """The parts' times from ``seconds.json``, without the parts whose folder is gone (to be redone)."""
    path = out / SECONDS_FILE
    if not path.exists():
        return {}
    data = read_json(path)
    if not isinstance(data, dict):
        raise InputError(f"{path}: expected a JSON object of seconds per part")
    recorded: dict[str, float] = {}
    for part, seconds in data.items():
        if part not in PARTS or isinstance(seconds, bool) or not isinstance(seconds, int | float) or seconds < 0:
            raise InputError(f"{path}: bad entry {part!r}: {seconds!r} (expected a part and its seconds)")
        if (out / part).is_dir():
            recorded[part] = float(seconds)
    return recorded


def _relink(section: str, folder: str) -> str:
    """Point a section's pictures into its sub-folder."""
    return section.replace("](", f"]({folder}/")


def machine() -> dict[str, Any]:
    """The CPU, core count, OS and Python of this machine (for the report)."""
    cpu = platform.processor() or platform.machine()
    try:
        for line in Path("/proc/cpuinfo").read_text(encoding="utf-8").splitlines():
            if line.startswith("model name"):
                cpu = line.split(":", 1)[1].strip()
                break
    except OSError:
        pass
    return {
        "cpu": cpu,
        "cores": os.cpu_count(),
        "system": f"{platform.system()} {platform.release()}",
        "python": platform.python_version(),
        "hbtp": __version__,
    }


def _intro(
    config: SuiteConfig,
    recipe: BackendRecipe,
    execution: Execution,
    timings: dict[str, float],
    this_run: dict[str, float],
) -> str:
    info = machine()
    parts = ", ".join(f"{part} {value:.0f} s" for part, value in timings.items())
    wall = f"Wall time {sum(timings.values()):.0f} s ({parts})"
    if timings != this_run:
        wall += f", over several runs into this folder (this one {sum(this_run.values()):.0f} s)"
    lines: Sequence[str] = [
        f"Machine: {info['cpu']}, {info['cores']} cores, {info['system']}, Python {info['python']}, "
        f"hbtp {info['hbtp']}.",
        f"Settings: {'quick' if config.quick else 'full'}; LLM `{recipe.llm}`, {config.runs} run(s); executor "
        f"`{execution.executor}` with {execution.jobs} job(s). {wall}.",
        "Paper: Table I, Table II and Figures 3-4 of Cai et al., HBTP. Reference: the public reference "
        "implementation run on a 2-vCPU machine (reference_results.md). Timings depend on the machine "
        "and the load; everything else is deterministic.",
    ]
    return "\n\n".join(lines)


__all__ = ["PARTS", "SuiteConfig", "machine", "run_suite"]
