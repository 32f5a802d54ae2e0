"""The tree file of ``hbtp run``, ``verify`` and ``export``: read once, with its scenario and goal.

Which scenario: ``--scenario`` or ``--pddl`` when given, else the PDDL files recorded in the tree
file (a tree planned from ``--pddl``), else the shipped scenario it records. Which goal: ``--goal``
when given, else the recorded one.
"""

from __future__ import annotations

import logging
from dataclasses import dataclass, replace
from pathlib import Path

from hbtp.bt.nodes import Node
from hbtp.bt.treefile import PddlFiles, TreeFile, read_tree_file
from hbtp.cli.options import ScenarioSource
from hbtp.domains import Scenario, scenario_names
from hbtp.errors import InputError
from hbtp.logic.task import Goal

log = logging.getLogger(__name__)


@dataclass(frozen=True)
class TreeInput:
    """A tree file resolved against its scenario."""

    file: TreeFile
    scenario: Scenario
    tree: Node
    goal: Goal | None


def pddl_files(source: ScenarioSource) -> PddlFiles | None:
    """The PDDL files and options of ``--pddl`` (``None`` without it), as a JSON tree records them."""
    if source.pddl is None:
        return None
    domain, problem = source.pddl
    mutex = Path(source.mutex_file) if source.mutex_file else None
    return PddlFiles(
        Path(domain), Path(problem), source.object_categories, source.keep_fluent, mutex, irreflexive=source.irreflexive
    )


def scenario_for(file: TreeFile, source: ScenarioSource) -> Scenario:
    """The scenario a tree file is read with (see the module docstring)."""
    if not source.given and file.pddl is not None:
        pddl = file.pddl.confined(file.path)
        source = replace(
            source,
            pddl=(str(pddl.domain), str(pddl.problem)),
            object_categories=source.object_categories or pddl.objects,
            keep_fluent=source.keep_fluent or pddl.keep_fluent,
            mutex_file=source.mutex_file or (str(pddl.mutex) if pddl.mutex is not None else None),
            irreflexive=source.irreflexive or pddl.irreflexive,
        )
    elif not source.given and file.scenario is not None and file.scenario not in scenario_names():
        raise InputError(
            f"{file.path} was written for scenario {file.scenario!r}, which is not a shipped one and records no "
            "PDDL files: give --scenario or --pddl DOMAIN PROBLEM"
        )
    loaded = source.load(default=file.scenario)
    if file.scenario and file.scenario != loaded.name:
        log.warning("%s was written for scenario %r, read with %r", file.path, file.scenario, loaded.name)
    return loaded


def load_tree_input(path: str, source: ScenarioSource, goal_text: str | None = None) -> TreeInput:
    """Read the tree file ``path`` and resolve it and its goal (``goal_text`` overrides the file's)."""
    file = read_tree_file(path)
    loaded, tree, goal = resolve_tree(file, scenario_for(file, source), goal_text)
    if not file.complete:
        log.warning("%s holds a partial tree (its search did not reach the initial state)", path)
    return TreeInput(file, loaded, tree, goal)


def resolve_tree(file: TreeFile, loaded: Scenario, goal_text: str | None = None) -> tuple[Scenario, Node, Goal | None]:
    """The scenario (with the negated twins the goal needs), the file's tree and its goal
    (``goal_text``, else the one the file records, else ``None``), resolved in it."""
    goal = None
    if goal_text:
        loaded, goal = loaded.resolve_goal(goal_text)
    else:
        text = file.goal_text(loaded.task)
        if text:  # a negative goal literal needs its twin in the task before the tree is read
            try:
                loaded, goal = loaded.resolve_goal(text)
            except InputError as error:
                raise InputError(f"{file.path}: the recorded goal: {error}") from None
    return loaded, file.tree(loaded.task), goal


__all__ = ["TreeInput", "load_tree_input", "pddl_files", "resolve_tree", "scenario_for"]
