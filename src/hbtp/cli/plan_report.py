"""What ``hbtp plan`` did, written, shown and judged: one :class:`PlanOutcome` in, the exit code out.

The terminal text says what happened in words (``solved: cost 59, 7 actions; explored 9
conditions ...``); ``--json`` keeps the field names of the search's record (``cost``, ``explored``,
...), which scripts read.
"""

from __future__ import annotations

import logging
from dataclasses import dataclass
from pathlib import Path
from typing import Any

import click

from hbtp.bt import Node, render_text, size, tree_of
from hbtp.bt.compact import compact
from hbtp.bt.export import export_tree, format_from_extension
from hbtp.bt.jsonio import goal_text, tree_to_json
from hbtp.bt.treefile import pddl_record
from hbtp.cli.exit_codes import plan_exit_code
from hbtp.cli.options import echo_json
from hbtp.cli.plan_command import PlanRequest
from hbtp.cli.tree_input import pddl_files
from hbtp.domains import Scenario
from hbtp.files import write_all_atomically
from hbtp.logic.task import Goal
from hbtp.pipeline import AutoResult, LoopResult
from hbtp.pipeline.instruct import GoalChoice
from hbtp.planning.hints import Hints
from hbtp.planning.result import PlanResult, Status

log = logging.getLogger(__name__)


@dataclass(frozen=True)
class PlanOutcome:
    """What one ``hbtp plan`` found: the result in its scenario, and how it came about."""

    scenario: Scenario
    goal: Goal
    result: PlanResult
    #: Where the hints came from: ``none``, ``oracle``, ``file`` or ``llm``.
    hints: str
    loop: LoopResult | None = None
    auto: AutoResult | None = None
    #: How a world pruned before grounding was grounded (``None``: grounded whole first).
    grounding: dict[str, Any] | None = None
    #: What the LLM made of ``--instruction``.
    chosen: GoalChoice | None = None

    #: The hints of an LLM-free plan in their pruned space (``--hints``).
    plain_hints: Hints | None = None

    @property
    def space_hints(self) -> Hints | None:
        """The hints whose pruned space the tree was planned in (``None``: the full space); the tree
        file keeps them, and re-plans of ``hbtp run --replan`` search that space first."""
        return self.loop.space_hints if self.loop is not None else self.plain_hints


@dataclass(frozen=True)
class PlanReport:
    """Writes, shows and judges one :class:`PlanOutcome`."""

    request: PlanRequest
    outcome: PlanOutcome

    def finish(self) -> int:
        """Write the files, print the result, and return the exit code."""
        result = self.outcome.result
        tree = self._tree()
        self._write(tree)
        if self.request.outputs.as_json:
            self._print_json(tree)
        else:
            self._print_text(tree)
        return int(plan_exit_code(result.status))

    def _tree(self) -> Node | None:
        """The tree to show and write: none for an unsolved search unless the full tree was asked for."""
        outputs, result = self.request.outputs, self.outcome.result
        if not result.expansions or not (result.solved or outputs.tree_kind == "full"):
            return None
        tree = tree_of(result, outputs.tree_kind)
        return compact(tree) if outputs.compact else tree

    def _write(self, tree: Node | None) -> None:
        """The -o and --export files, all together or none; an unsolved run's tree only with --partial."""
        outputs, result = self.request.outputs, self.outcome.result
        targets = [name for name in (outputs.out_file, outputs.export_file) if name]
        if not targets:
            return
        if not result.solved and (tree is None or not outputs.partial):
            hint = " (give --partial to write the partial tree)" if tree is not None else ""
            log.warning("not solved: nothing written to %s%s", ", ".join(targets), hint)
            return
        if tree is None:
            return
        if not result.solved:
            log.warning(
                "not solved: writing the partial tree to %s; it does not reach the goal from the initial state",
                ", ".join(targets),
            )
        write_all_atomically(self._files(tree))

    def _files(self, tree: Node) -> dict[Path, str | bytes]:
        outputs, scenario, goal = self.request.outputs, self.outcome.scenario, self.outcome.goal
        task, name = scenario.task, scenario.name
        files: dict[Path, str | bytes] = {}
        if outputs.export_file:
            chosen = outputs.export_format or format_from_extension(outputs.export_file)
            files[Path(outputs.export_file)] = export_tree(tree, task, chosen, scenario=name, goal=goal_text(goal))
        if outputs.out_file:
            # the PDDL files are recorded so that run/verify can reload the scenario
            pddl = pddl_record(pddl_files(self.request.source), outputs.out_file, warn=True)
            files[Path(outputs.out_file)] = tree_to_json(
                tree, task, scenario=name, goal=goal, complete=self.outcome.result.solved, pddl=pddl,
                hints=self.outcome.space_hints,
            )  # fmt: skip
        return files

    def _print_json(self, tree: Node | None) -> None:
        outcome = self.outcome
        record = outcome.result.to_dict(outcome.scenario.task)
        record["scenario"] = outcome.scenario.name
        record["hints"] = outcome.hints
        if tree is not None:
            shape = size(tree)
            record["tree"] = {"kind": self.request.outputs.tree_kind, "nodes": shape.nodes, "depth": shape.depth}
        if outcome.loop is not None:
            record["llm"] = outcome.loop.to_dict()
        if outcome.auto is not None:
            record["auto"] = outcome.auto.to_dict()
        if outcome.grounding is not None:
            record["grounding"] = outcome.grounding
        if outcome.chosen is not None:
            record["instruction"] = outcome.chosen.to_dict()
        echo_json(record)

    def _print_text(self, tree: Node | None) -> None:
        outcome = self.outcome
        task, result = outcome.scenario.task, outcome.result
        if outcome.auto is not None:
            click.echo(auto_summary(outcome.auto))
        if outcome.grounding is not None:
            click.echo(grounding_summary(outcome.grounding))
        if outcome.loop is not None:
            click.echo(loop_summary(outcome.loop))
        click.echo(result_summary(result))
        if result.solved:
            click.echo("executes: " + (" -> ".join(task.actions[i].name for i in result.executed) or "(nothing)"))
        if tree is not None:
            click.echo(render_text(tree, task, max_children=self.request.outputs.max_branches))


def result_summary(result: PlanResult) -> str:
    """The search's outcome in words: the tree's cost (D(T) in the paper) and length, the conditions
    it explored (|S⁻|) and generated, its time, and the size of the action space it searched (|A|)."""
    stats = result.stats
    if result.solved:
        steps = len(result.executed)
        head = f"solved: cost {result.cost}, a plan of {steps} action{'s' if steps != 1 else ''}"
    else:
        head = f"{result.status.value}: no tree reaches the goal from the start"
    line = (
        f"{head}; explored {stats.explored} condition{'s' if stats.explored != 1 else ''} "
        f"({stats.generated} generated) in {stats.time_s * 1000:.1f} ms; "
        f"{stats.action_space} actions in the search space"
    )
    return line + (f" ({result.message})" if result.message else "")


def grounding_summary(grounding: dict[str, Any]) -> str:
    """How a world pruned before grounding was grounded."""
    if grounding["whole_grounded"]:
        whole = "the whole world was grounded (for the fallback or the demonstrations)"
    else:
        whole = "the whole world was not grounded"
    return (
        f"grounding: pruned: the tree's space has {grounding['grounded_actions']} of {grounding['actions']} "
        f"actions (names listed in {grounding['listed_s']:.2f} s); {whole}"
    )


def auto_summary(auto: AutoResult) -> str:
    """Which path of ``--llm auto`` produced the result."""
    status, budget = auto.probe.status.value, auto.probe_budget_s
    probe = f"auto: LLM-free planning {status} in {auto.probe_s * 1000:.1f} ms (budget {budget:g} s)"
    if auto.asked_llm:
        return probe + "; asked the LLM"
    if auto.probe.status in (Status.SOLVED, Status.UNSOLVABLE):
        return probe + "; the LLM was not asked"
    return probe + "; no time left to ask the LLM"


def loop_summary(loop: LoopResult) -> str:
    """The LLM loop's outcome in words, then one line per round."""
    label = loop.outcome.label
    if label == "NF":
        how = "solved with the LLM's first answer (NF)"
    elif loop.outcome.feedback_rounds is not None:
        how = f"solved after {loop.outcome.feedback_rounds} round(s) of feedback ({label})"
    else:
        how = f"{label}: no LLM round solved it"
    lines = [f"LLM: {how}; the model took {loop.llm_seconds:.2f} s, planning {loop.planning_seconds * 1000:.1f} ms"]
    lines += [
        f"  round {r.round}: {r.status} in a space of {r.action_space} actions" + (f", {r.error}" if r.error else "")
        for r in loop.rounds
    ]
    return "\n".join(lines)


__all__ = ["PlanOutcome", "PlanReport", "auto_summary", "grounding_summary", "loop_summary", "result_summary"]
