"""``hbtp bench instructions``: how well an LLM turns the instruction dataset into goals, and whether
the trees planned for them do what was asked.

For every record of the shipped instruction dataset (:mod:`hbtp.datasets.instructions`) and each of
its phrasings, the goal is asked of the backend (:func:`hbtp.pipeline.instruct.goal_from_instruction`)
with the demonstrations drawn from the *other* records of the scenario (leave one record out: none of
the record's phrasings is shown). A row records:

- ``exact``: the produced goal has the same disjuncts as the intended one (each a set of literals);
  an instruction whose intended goal already holds at the start is exact when it is refused for
  that goal (there is nothing to do);
- ``equivalent``: the same after replacing ``~p`` by ``q`` where the proved mutexes make exactly one
  of ``p`` and ``q`` hold in every reachable state (``~IsOpen_fridge`` and ``IsClose_fridge``);
- ``well_formed``, ``rejected``: a goal was produced (every proposal refused: ``rejected``, with the
  reasons in ``message``);
- ``rounds`` and ``llm_s``: answers asked for and the model's time;
- ``reached``: the full tree OBTEA plans for the produced goal (landmark heuristic), run from s0,
  ends in a state where the *intended* goal holds (the end-to-end success).

With ``lacking`` (the default), each record also gives one instruction about a thing the world
lacks, kind ``lacking``: its goal with one object swapped for a thing of the words file the world
does not have, said by the verbaliser (:func:`hbtp.train.verbalise.lacking_instruction`, seeded by
the record's id), "put the sofa in the fridge". It is exact (and reached) only when it is refused
for that thing; its intended answer is written ``Unknown: sofa``. These rows are not in ``all``.
"""

from __future__ import annotations

import logging
import random
import time
from collections.abc import Iterable, Sequence
from dataclasses import dataclass, replace
from pathlib import Path
from typing import Any

from hbtp.bench.paper import paper_scenario
from hbtp.bench.results import ResultsFile, Row, mean, median, write_json
from hbtp.bt import full_tree
from hbtp.bt.disturb import exactly_one_groups
from hbtp.bt.simulate import simulate
from hbtp.datasets.instructions import InstructionRecord, load_instructions
from hbtp.domains import Scenario
from hbtp.domains.words import words_for
from hbtp.errors import HbtpError
from hbtp.files import write_atomically
from hbtp.llm.backend import Backend
from hbtp.logic.atoms import Atom
from hbtp.logic.goals import parse_goal
from hbtp.logic.task import GroundTask
from hbtp.pipeline.instruct import InstructOptions, goal_from_instruction, instruction_pool
from hbtp.planning import Limits, plan
from hbtp.planning.heuristic_names import HeuristicName
from hbtp.train.verbalise import lacking_instruction

log = logging.getLogger(__name__)

Normal = frozenset[frozenset[str]]


@dataclass(frozen=True)
class InstructionsBench:
    """What to run: scenarios, records per scenario (``None``: all), phrasings per record."""

    scenarios: tuple[str, ...]
    backend_name: str
    limit: int | None = None
    phrasings: int = 2
    rounds: int = 3
    plan_time_limit: float = 30.0
    lacking: bool = True


def kind_of(record: InstructionRecord) -> str:
    """``test-set`` for a Table II goal, else ``negative``, ``disjunctive`` or ``written``."""
    if record.task is not None:
        return "test-set"
    terms = parse_goal(record.goal)
    if any(atom.negated for term in terms for atom in term):
        return "negative"
    return "disjunctive" if len(terms) > 1 else "written"


LACKING = "lacking"


def normal_form(scenario: Scenario, terms: Sequence[Sequence[Atom]], mutexes: bool) -> Normal:
    """The goal as a set of disjuncts of literal names; with ``mutexes``, ``~p`` written as the
    ``q`` that exactly-one mutex groups of two make equivalent."""
    task = scenario.task
    twin = _complements(scenario) if mutexes else {}
    normal: set[frozenset[str]] = set()
    for term in terms:
        literals = set()
        for atom in term:
            spelled = task.spelled(atom)
            literals.add(twin.get(spelled, spelled.underscored))
        normal.add(frozenset(literals))
    return frozenset(normal)


def _complements(scenario: Scenario) -> dict[Atom, str]:
    """``~p`` -> ``q`` for every exactly-one group ``{p, q}`` of the proved mutexes."""
    task = scenario.task
    table: dict[Atom, str] = {}
    for group in exactly_one_groups(task, scenario.mutexes.proved_only()):
        if len(group) == 2:
            first, second = (task.atoms[i] for i in sorted(group))
            table[first.negate()] = second.underscored
            table[second.negate()] = first.underscored
    return table


def holds_by_name(task: GroundTask, terms: Sequence[Sequence[Atom]], state: frozenset[int]) -> bool:
    """Whether the goal ``terms`` holds in ``state`` of ``task``, read by names (``~p``: ``p`` absent)."""
    present = {task.atoms[i] for i in state if not task.atoms[i].negated}
    return any(all((task.spelled(a).positive in present) != a.negated for a in term) for term in terms)


@dataclass(frozen=True, kw_only=True)
class InstructionRow(Row):
    """One phrasing of one instruction: the goal produced, how it compares with the intended one,
    and whether the tree planned for it reached the intended goal (see the module's documentation)."""

    KEY = ("scenario", "id", "phrasing")

    scenario: str
    id: str
    phrasing: int
    kind: str
    instruction: str
    intended: str
    produced: str | None
    well_formed: bool
    rejected: bool
    exact: bool
    equivalent: bool
    reached: bool
    rounds: int
    llm_s: float
    message: str
    seconds: float


def run_row(
    scenario: Scenario, record: InstructionRecord, phrasing: int, backend: Backend, bench: InstructionsBench
) -> InstructionRow:
    """One instruction: its goal, compared with the intended one, and the planned tree's outcome."""
    started = time.perf_counter()
    asked = _asked(scenario, record.id, phrasing, kind_of(record), record.instructions[phrasing], record.goal)
    row = _answered(scenario, record, backend, bench, asked)
    return replace(row, seconds=round(time.perf_counter() - started, 6))


def _asked(
    scenario: Scenario, row_id: str, phrasing: int, kind: str, instruction: str, intended: str
) -> InstructionRow:
    """The row of an instruction asked, before any answer: nothing produced, nothing right."""
    return InstructionRow(
        scenario=scenario.name,
        id=row_id,
        phrasing=phrasing,
        kind=kind,
        instruction=instruction,
        intended=intended,
        produced=None,
        well_formed=False,
        rejected=True,
        exact=False,
        equivalent=False,
        reached=False,
        rounds=0,
        llm_s=0.0,
        message="",
        seconds=0.0,
    )


def _answered(
    scenario: Scenario, record: InstructionRecord, backend: Backend, bench: InstructionsBench, row: InstructionRow
) -> InstructionRow:
    """``row`` (nothing produced yet) with the backend's goal and its judgement; a backend that
    fails gives its message."""
    pool = instruction_pool(scenario, frozenset({record.id}))
    try:
        choice = goal_from_instruction(scenario, row.instruction, backend, pool, InstructOptions(rounds=bench.rounds))
    except HbtpError as error:
        return replace(row, message=str(error))
    intended = parse_goal(record.goal)
    row = replace(row, produced=choice.goal, rounds=len(choice.attempts), llm_s=round(choice.llm_seconds, 6))
    row = replace(row, well_formed=choice.goal is not None, rejected=choice.goal is None, message=choice.message)
    if choice.goal is None:
        # Refusing a goal that already holds is the right answer when that goal is the intended one.
        right = choice.holding is not None and _same(scenario, parse_goal(choice.holding), intended, False)
        same = choice.holding is not None and _same(scenario, parse_goal(choice.holding), intended, True)
        return replace(row, exact=right, equivalent=same, reached=right)
    produced = parse_goal(choice.goal)
    return replace(
        row,
        exact=_same(scenario, produced, intended, False),
        equivalent=_same(scenario, produced, intended, True),
        reached=_reached(scenario, choice.goal, intended, bench.plan_time_limit),
    )


def lacking_row(
    scenario: Scenario, record: InstructionRecord, backend: Backend, bench: InstructionsBench
) -> InstructionRow | None:
    """The instruction about a thing the world lacks built on ``record`` (see the module's
    documentation) and whether it was refused for that thing; ``None`` when none can be said."""
    words = words_for(scenario)
    rng = random.Random(f"lacking|{record.id}")
    said = lacking_instruction(record.goal, scenario.task.constants, words.foreign(), words, rng)
    if said is None:
        return None
    started = time.perf_counter()
    row = _asked(scenario, f"{record.id}/{LACKING}", 0, LACKING, said.instruction, f"Unknown: {said.thing}")
    try:
        choice = goal_from_instruction(
            scenario,
            row.instruction,
            backend,
            instruction_pool(scenario, frozenset({record.id})),  # the record left out, as for its own rows
            InstructOptions(rounds=bench.rounds),
        )
    except HbtpError as error:
        return replace(row, message=str(error), seconds=round(time.perf_counter() - started, 6))
    refused = choice.goal is None and choice.lacking is not None and said.thing.split()[-1] in choice.lacking
    return replace(
        row,
        produced=choice.goal,
        well_formed=choice.goal is not None,
        rejected=choice.goal is None,
        exact=refused,
        equivalent=refused,
        reached=refused,
        rounds=len(choice.attempts),
        llm_s=round(choice.llm_seconds, 6),
        message=choice.message,
        seconds=round(time.perf_counter() - started, 6),
    )


def _same(scenario: Scenario, left: Sequence[Sequence[Atom]], right: Sequence[Sequence[Atom]], mutexes: bool) -> bool:
    return normal_form(scenario, left, mutexes) == normal_form(scenario, right, mutexes)


def _reached(scenario: Scenario, produced: str, intended: Sequence[Sequence[Atom]], seconds: float) -> bool:
    extended, goal = scenario.resolve_goal(produced)
    result = plan(
        extended.task,
        goal,
        "obtea",
        mutexes=extended.mutexes,
        heuristic=HeuristicName.LM,
        limits=Limits(time_s=seconds),
    )
    if not result.solved:
        return False
    run = simulate(full_tree(result.expansions), extended.task)
    return run.succeeded and holds_by_name(extended.task, intended, run.final_state)


def run_instructions(bench: InstructionsBench, make: Any, out: Path) -> dict[str, Any]:
    """Run the benchmark (rows already in ``out/results.jsonl`` are kept) and write the summary."""
    results = ResultsFile(out / "results.jsonl", InstructionRow)
    keys: list[tuple[Any, ...]] = []
    for name in bench.scenarios:
        scenario = paper_scenario(name)
        backend: Backend | None = None
        try:
            for record in load_instructions(name)[: bench.limit]:
                for phrasing in range(min(bench.phrasings, len(record.instructions))):
                    key = (name, record.id, phrasing)
                    keys.append(key)
                    if key in results:
                        continue
                    backend = backend or make(scenario)
                    results.append(run_row(scenario, record, phrasing, backend, bench))
                key = (name, f"{record.id}/{LACKING}", 0)
                if bench.lacking and key not in results:
                    backend = backend or make(scenario)
                    row = lacking_row(scenario, record, backend, bench)
                    if row is not None:
                        results.append(row)
                if bench.lacking and key in results:
                    keys.append(key)
        finally:
            if backend is not None:
                backend.close()
    rows = list(results.ordered(keys))
    summary = {"backend": bench.backend_name, "scenarios": summarise(rows)}
    write_json(out / "summary.json", summary)
    write_atomically(out / "report.md", report(summary), create_folders=True)
    return summary


KINDS = ("test-set", "disjunctive", "negative", "written", LACKING)


def summarise(rows: Sequence[InstructionRow]) -> dict[str, dict[str, Any]]:
    """Per scenario and per kind: the shares of exact, equivalent, well-formed and reached rows
    (``all``: the dataset's instructions, not the ``lacking`` ones)."""
    table: dict[str, dict[str, Any]] = {}
    for name in dict.fromkeys(r.scenario for r in rows):
        mine = [r for r in rows if r.scenario == name]
        asked = [r for r in mine if r.kind != LACKING]
        table[name] = {"all": _figures(asked)} if asked else {}
        for kind in KINDS:
            chosen = [r for r in mine if r.kind == kind]
            if chosen:
                table[name][kind] = _figures(chosen)
    return table


def _figures(rows: Sequence[InstructionRow]) -> dict[str, Any]:
    def share(flags: Iterable[bool]) -> float:
        return round(100 * sum(flags) / len(rows), 1)

    return {
        "instructions": len(rows),
        "exact_pct": share(r.exact for r in rows),
        "equivalent_pct": share(r.equivalent for r in rows),
        "well_formed_pct": share(r.well_formed for r in rows),
        "rejected_pct": share(r.rejected for r in rows),
        "reached_pct": share(r.reached for r in rows),
        "mean_rounds": mean(r.rounds for r in rows),
        "median_llm_s": median(r.llm_s for r in rows),
    }


def report(summary: dict[str, Any]) -> str:
    """The summary as a Markdown table."""
    lines = [
        f"# Instructions to goals: {summary['backend']}",
        "",
        "| scenario | kind | instructions | exact | equivalent | well-formed | rejected | reached | rounds "
        "| median LLM s |",
        "|---|---|---|---|---|---|---|---|---|---|",
    ]
    for name, kinds in summary["scenarios"].items():
        for kind, f in kinds.items():
            lines.append(
                f"| {name} | {kind} | {f['instructions']} | {f['exact_pct']}% | {f['equivalent_pct']}% | "
                f"{f['well_formed_pct']}% | {f['rejected_pct']}% | {f['reached_pct']}% | {f['mean_rounds']} | "
                f"{f['median_llm_s']} |"
            )
    return "\n".join(lines) + "\n"


__all__ = [
    "LACKING",
    "InstructionRow",
    "InstructionsBench",
    "holds_by_name",
    "kind_of",
    "lacking_row",
    "normal_form",
    "run_instructions",
    "run_row",
]
