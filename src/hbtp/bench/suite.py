"""``hbtp bench all``: every table and figure of the paper into one folder, with one report.

Layout of ``out``: ``table1/`` (three settings: pruned space with oracle hints, full space with
oracle hints, full space without hints and with the landmark heuristic), ``table2/<scenario>/``,
``fig3/none``, ``fig3/lm`` and ``fig3/pruned`` (the full space without a heuristic as in the paper,
with the landmark heuristic, and the pruned spaces), ``fig4/``,
``robustness/``; each with results.jsonl, summary.json, report.md and PNG plots; and at the top
``report.md`` (every section, plus the machine and the settings) and ``summary.json``.
``quick`` runs a few tasks per cell with shorter limits (a few minutes on two cores). Every part
resumes from its results.jsonl, so an interrupted run picks up where it stopped.
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
from hbtp.bench.results import write_json
from hbtp.bench.robustness import SCENARIOS, run_robustness
from hbtp.bench.runner import DEFAULT_EXECUTION, Execution
from hbtp.bench.table1 import Table1Config, run_table1, setting_label, write_table1_report
from hbtp.bench.table2 import BackendRecipe, Table2Config, run_table2, write_table2_report
from hbtp.errors import InputError
from hbtp.llm.prompt import PromptOptions
from hbtp.pipeline import LoopOptions

log = logging.getLogger(__name__)

PARTS = ("table1", "table2", "fig3", "fig4", "robustness")


@dataclass(frozen=True)
class SuiteConfig:
    quick: bool = False
    parts: tuple[str, ...] = PARTS
    llm: str = "local"
    runs: int = 1

    def __post_init__(self) -> None:
        unknown = [p for p in self.parts if p not in PARTS]
        if unknown or not self.parts:
            raise InputError(f"unknown part(s) {', '.join(unknown) or '(none)'}; choose from {', '.join(PARTS)}")


def table1_settings(quick: bool) -> list[tuple[str, Table1Config]]:
    """(folder, setting): the paper's two settings, and OBTEA with the landmark heuristic."""
    limit, full_limit, seconds = (10, 5, 2.0) if quick else (None, None, 5.0)
    return [
        ("pruned", Table1Config(space="pruned", hints="oracle", time_limit=5.0, limit=limit)),
        ("full", Table1Config(space="full", hints="oracle", time_limit=seconds, limit=full_limit)),
        (
            "full-lm",
            Table1Config(space="full", planners=("obtea",), hints="none", heuristic="lm", time_limit=5.0, limit=limit),
        ),
    ]


def fig3_settings(quick: bool) -> list[tuple[str, Fig3Config]]:
    if quick:
        base = Fig3Config(scales=(1.0, 2.0), time_limit=2.0, limit=3)
    else:
        base = Fig3Config(scales=(1.0, 1.5, 2.0, 2.5, 3.0), time_limit=5.0, limit=20)
    return [("none", base), ("lm", replace(base, heuristic="lm")), ("pruned", replace(base, space="pruned"))]


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
    loop = LoopOptions(prompt=PromptOptions(style="completion" if recipe.llm == "local" else "chat"))
    rows = []
    for name in SCENARIOS:
        table2 = Table2Config(
            scenario=name,
            backend=recipe.llm or "recorded",
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
    quick: dict[str, Any] = {"runs": 5, "limit": 3} if config.quick else {}
    result = run_robustness(out / "robustness", execution=execution, **quick)
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
    """Run (or resume) every selected part into ``out``; write the report; return the summary."""
    started = time.perf_counter()
    sections: list[str] = []
    summary: dict[str, Any] = {"quick": config.quick, "parts": list(config.parts)}
    timings: dict[str, float] = {}
    for part in PARTS:
        if part not in config.parts:
            continue
        began = time.perf_counter()
        summary[part], part_sections = PART_RUNS[part](config, recipe, out, execution)
        sections.extend(part_sections)
        timings[part] = round(time.perf_counter() - began, 1)
        log.info("bench all: %s done in %.1f s", part, timings[part])
    summary["seconds"] = timings
    summary["machine"] = machine()
    write_json(out / "summary.json", summary)
    intro = _intro(config, recipe, execution, timings, time.perf_counter() - started)
    write_report(out / "report.md", "hbtp benchmarks" + (" (quick)" if config.quick else ""), [intro, *sections])
    return summary


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
    config: SuiteConfig, recipe: BackendRecipe, execution: Execution, timings: dict[str, float], seconds: float
) -> str:
    info = machine()
    parts = ", ".join(f"{part} {value:.0f} s" for part, value in timings.items())
    lines: Sequence[str] = [
        f"Machine: {info['cpu']}, {info['cores']} cores, {info['system']}, Python {info['python']}, "
        f"hbtp {info['hbtp']}.",
        f"Settings: {'quick' if config.quick else 'full'}; LLM `{recipe.llm}`, {config.runs} run(s); executor "
        f"`{execution.executor}` with {execution.jobs} job(s). Wall time {seconds:.0f} s ({parts}).",
        "Paper: Table I, Table II and Figures 3-4 of Chen et al., HBTP. Reference: the public reference "
        "implementation run on a 2-vCPU machine (reference_results.md). Timings depend on the machine "
        "and the load; everything else is deterministic.",
    ]
    return "\n\n".join(lines)


__all__ = ["PARTS", "SuiteConfig", "machine", "run_suite"]
