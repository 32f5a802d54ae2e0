"""Check dataset records against a scenario's grounded task.

For each record: the goal resolves to literals of the task; each optimal action is a grounded
action; the actions execute from s0 and reach the goal; a declared ``cost`` equals the plan's cost;
the vital predicates are action predicates and the vital objects are symbols of the task. A goal
that already holds in s0 is a warning. A bad record never raises: every finding is an
:class:`Issue` in the :class:`ValidationReport`.

Optimality of a valid plan needs a planner; pass ``optimal_cost`` (record -> optimal cost, or
``None`` when unknown) to get ``not-optimal`` warnings.
"""

from __future__ import annotations

import logging
from collections.abc import Callable, Iterable, Sequence
from dataclasses import dataclass
from enum import StrEnum
from typing import Any

from hbtp.datasets.records import Record
from hbtp.datasets.shipped import DATASET_SCENARIO, load_dataset
from hbtp.domains import load_scenario
from hbtp.errors import InputError
from hbtp.logic.execution import apply_actions
from hbtp.logic.task import GroundAction, GroundTask

log = logging.getLogger(__name__)

#: Environments a record may name: the scenarios have a single initial state, ``Environment:1``.
ENVIRONMENTS = frozenset({"1"})


class Severity(StrEnum):
    """How bad an issue is: an ``error`` makes the record unusable, a ``warning`` does not."""

    ERROR = "error"
    WARNING = "warning"


@dataclass(frozen=True, slots=True)
class Issue:
    """One finding about one record.

    ``code`` is a short slug: ``unknown-literal``, ``unreachable-literal``, ``unknown-action``,
    ``not-applicable``, ``goal-not-reached``, ``cost-mismatch``, ``unknown-predicate``,
    ``unknown-object`` (errors); ``goal-true-in-s0``, ``unknown-environment``, ``not-optimal``
    (warnings).
    """

    record_id: str
    severity: Severity
    code: str
    message: str

    def to_dict(self) -> dict[str, str]:
        return {
            "record_id": self.record_id,
            "severity": str(self.severity),
            "code": self.code,
            "message": self.message,
        }


@dataclass(frozen=True, slots=True)
class ValidationReport:
    """The issues found in a dataset (in record order) checked against one scenario."""

    dataset: str
    scenario: str
    records: int
    issues: tuple[Issue, ...]

    @property
    def errors(self) -> tuple[Issue, ...]:
        return tuple(issue for issue in self.issues if issue.severity is Severity.ERROR)

    @property
    def warnings(self) -> tuple[Issue, ...]:
        return tuple(issue for issue in self.issues if issue.severity is Severity.WARNING)

    @property
    def invalid_ids(self) -> tuple[str, ...]:
        """Ids of the records with at least one error, in file order."""
        return tuple(dict.fromkeys(issue.record_id for issue in self.errors))

    @property
    def warning_ids(self) -> tuple[str, ...]:
        """Ids of the records with at least one warning, in file order."""
        return tuple(dict.fromkeys(issue.record_id for issue in self.warnings))

    @property
    def valid(self) -> bool:
        """No record has an error (warnings allowed)."""
        return not self.errors

    def summary(self) -> str:
        """One line: ``table1_robothow_100 vs robothow: 100 records, 2 invalid, 0 with warnings``."""
        name = self.dataset or "<records>"
        return (
            f"{name} vs {self.scenario}: {self.records} records, {len(self.invalid_ids)} invalid, "
            f"{len(self.warning_ids)} with warnings"
        )

    def to_dict(self) -> dict[str, Any]:
        return {
            "dataset": self.dataset,
            "scenario": self.scenario,
            "records": self.records,
            "valid": self.valid,
            "invalid_ids": list(self.invalid_ids),
            "warning_ids": list(self.warning_ids),
            "issues": [issue.to_dict() for issue in self.issues],
        }


OptimalCost = Callable[[Record], int | None]


def validate_records(
    records: Iterable[Record],
    task: GroundTask,
    dataset: str = "",
    *,
    optimal_cost: OptimalCost | None = None,
) -> ValidationReport:
    """Validate every record against ``task``; never raises on a bad record.

    ``optimal_cost``, when given, is asked for the optimal cost of each record whose plan is valid;
    a plan that costs more than that is reported as a ``not-optimal`` warning.
    """
    issues: list[Issue] = []
    count = 0
    for record in records:
        count += 1
        issues.extend(_RecordCheck(record, task).run(optimal_cost))
    report = ValidationReport(dataset, task.name, count, tuple(issues))
    log.info("%s", report.summary())
    for issue in report.issues:
        log.debug("record %s: %s %s: %s", issue.record_id, issue.severity, issue.code, issue.message)
    return report


class _RecordCheck:
    """The checks of one record, collecting issues instead of raising."""

    def __init__(self, record: Record, task: GroundTask) -> None:
        self.record = record
        self.task = task
        self.issues: list[Issue] = []

    def error(self, code: str, message: str) -> None:
        self.issues.append(Issue(self.record.id, Severity.ERROR, code, message))

    def warning(self, code: str, message: str) -> None:
        self.issues.append(Issue(self.record.id, Severity.WARNING, code, message))

    def run(self, optimal_cost: OptimalCost | None) -> list[Issue]:
        record = self.record
        if record.environment not in ENVIRONMENTS:
            self.warning(
                "unknown-environment",
                f"Environment:{record.environment}; the scenario has one initial state (Environment:1)",
            )
        goal = self.goal()
        actions = self.actions()
        self.vitals()
        if actions is None:
            return self.issues
        plan_cost = sum(action.cost for action in actions)
        if record.cost is not None and record.cost != plan_cost:
            self.error("cost-mismatch", f"declared cost {record.cost}, the optimal actions cost {plan_cost}")
        if goal is not None and goal <= self.task.initial_state:
            self.warning("goal-true-in-s0", "goal already holds in s0")
        if self.executes(actions, goal) and goal is not None and optimal_cost is not None:
            optimum = optimal_cost(record)
            if optimum is not None and plan_cost > optimum:
                self.warning("not-optimal", f"the optimal actions cost {plan_cost}, the optimum is {optimum}")
        return self.issues

    def goal(self) -> frozenset[int] | None:
        """The goal's atom ids, or ``None`` (with an issue) when it does not resolve."""
        try:
            goal = self.task.resolve_goal(self.record.goal)
        except InputError as error:
            self.error("unknown-literal", f"goal {self.record.goal.strip()!r}: {error}")
            return None
        if goal.unreachable:
            names = ", ".join(str(atom) for atom in goal.unreachable)
            self.error("unreachable-literal", f"no action achieves goal literal(s) {names} and s0 lacks them")
            return None
        return goal.ids

    def actions(self) -> list[GroundAction] | None:
        """The grounded optimal actions, or ``None`` when some are unknown (each reported)."""
        actions: list[GroundAction] = []
        known = True
        for position, name in enumerate(self.record.optimal_actions, start=1):
            try:
                actions.append(self.task.action(name))
            except InputError as error:
                self.error("unknown-action", f"action {position} {name!r}: {error}")
                known = False
        return actions if known else None

    def executes(self, actions: Sequence[GroundAction], goal: frozenset[int] | None) -> bool:
        """Whether the actions execute from s0 and reach the goal (else an issue).

        With ``goal=None`` (a goal that did not resolve) only applicability is checked.
        """
        state, applied = apply_actions(self.task, actions)
        if applied < len(actions):
            action = actions[applied]
            missing = ", ".join(self.task.names(action.pre - state))
            self.error(
                "not-applicable",
                f"action {applied + 1} {action.name} is not applicable: it needs {missing}",
            )
            return False
        if goal is not None and not goal <= state:
            missing = ", ".join(self.task.names(goal - state))
            self.error("goal-not-reached", f"after the optimal actions the goal still lacks {missing}")
            return False
        return True

    def vitals(self) -> None:
        known_predicates = set(self.task.action_predicates)
        for predicate in self.record.vital_predicates:
            if predicate not in known_predicates:
                self.error("unknown-predicate", f"vital predicate {predicate!r} is not an action predicate of the task")
        for name in self.record.vital_objects:
            if name not in self.task.symbols:
                self.error("unknown-object", f"vital object {name!r} is not an object of the task")


def validate_dataset(
    name: str,
    scenario: str | None = None,
    *,
    optimal_cost: OptimalCost | None = None,
) -> ValidationReport:
    """Validate a shipped dataset against ``scenario`` (default: its own, from ``DATASET_SCENARIO``)."""
    records = load_dataset(name)
    if scenario is None:
        if name not in DATASET_SCENARIO:
            raise InputError(f"dataset {name!r} has no default scenario; name one")
        scenario = DATASET_SCENARIO[name]
    task = load_scenario(scenario).task
    return validate_records(records, task, name, optimal_cost=optimal_cost)
