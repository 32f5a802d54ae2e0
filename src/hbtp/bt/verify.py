"""Static verification of behavior trees: what a tree guarantees, proved without running it.

Two families of checks, both on the tree alone (no state is ever ticked):

**Guarded actions (any tree).** Walking every Sequence from left to right, the literals *known*
to hold when a child is ticked are the literals of the Conditions before it (and, for an Action
before it, its progression ``(known - del) | add``, as in engines where a finished action returns
SUCCESS). Every Action's precondition must be part of what is known where it is ticked; a
Fallback passes what is known at its entry to each of its children (a failed child tells nothing
positive). An Action with a precondition that no Condition establishes is reported with the
missing literals.

**Goal reaching (first-match form).** Most trees, and every tree hbtp builds or compacts, are
equivalent to an ordered list of *branches* ``(guard, action)`` where ``guard`` is the union of
the Conditions on the way to the action: a tick runs the action of the first branch whose
condition ``guard | pre(action)`` holds, or succeeds at the first *success branch* (a Condition
reached with no action after it), or fails (see :func:`flatten`). For that form the verifier
proves:

* the root succeeds exactly when the goal holds: the first branches are success branches whose
  guards are the goal's disjuncts (one for a conjunctive goal; each disjunct holds a guard of them),
  and no success branch can hold without some disjunct;
* *progress*: for every action branch ``i`` with condition ``c_i``, the state ``(c_i - del) | add``
  that its action leads to satisfies the condition of some *earlier* branch ``j < i``.

Together they prove termination at the goal: from any state satisfying some branch condition, the
index of the first matching branch strictly decreases at every tick (the state after the action
contains ``(c_i - del) | add``, which satisfies ``c_j``), so the goal branch is reached after at most
one tick per branch. A tree planned by backward search has this property by construction (each
expanded condition was regressed from its parent, expanded earlier); the check makes it a
certificate that does not trust the planner, and it covers trees read from files.

**From the initial state** (``from_initial_state=True``, what ``hbtp verify`` asks): the tree must
also reach the goal from s0. With a first-match form that is proved when goal reaching is and some
branch condition holds in s0; otherwise the tree is ticked from s0 without disturbance (ticking is
a pure function of the state, so that run is the tree's only behaviour from s0) until it succeeds
with the goal, fails, or comes back to a state it has seen. A partial tree (written after an
unsolved search) covers no branch of s0 and fails this check with an ``initial-state`` problem.

Problems name the node (``root.children[3].children[1]``) and the literals by name.
"""

from __future__ import annotations

import logging
from collections.abc import Iterable, Sequence
from dataclasses import dataclass
from typing import Any

from hbtp.bt.nodes import Action, Condition, Fallback, Node, NodeStatus, tick
from hbtp.bt.nodes import Sequence as SequenceNode
from hbtp.logic.subsets import SubsetIndex
from hbtp.logic.task import GoalIds, GroundTask, disjuncts_of

log = logging.getLogger(__name__)

Path = tuple[int, ...]
Goal = tuple[frozenset[int], ...]  # the goal's disjuncts


def path_text(path: Iterable[int]) -> str:
    """``root.children[3].children[1]`` for the path ``(3, 1)``."""
    return "root" + "".join(f".children[{i}]" for i in path)


# ====================================================================== first-match form
@dataclass(frozen=True, slots=True)
class Branch:
    """One entry of a tree's first-match form.

    ``guard`` holds the literals of the Conditions on the way; ``action`` is the Action ticked
    after them, or ``None`` for a *success branch* (the tree returns SUCCESS when the guard holds).
    ``path`` is the position of the Action (or of the node that succeeds) in the tree.
    """

    guard: frozenset[int]
    action: int | None
    path: Path

    def condition(self, task: GroundTask) -> frozenset[int]:
        """When the branch matches: its guard, plus the action's precondition (an Action whose
        precondition does not hold fails, and the tick goes on to the next branch)."""
        if self.action is None:
            return self.guard
        return self.guard | task.actions[self.action].pre


def flatten(node: Node) -> tuple[Branch, ...] | None:
    """The first-match form of ``node``, or ``None`` when its shape has none.

    Ticking ``node`` in a state returns exactly what ticking the branches in order does: RUNNING
    with the action of the first branch whose :meth:`Branch.condition` holds, SUCCESS when that
    first match is a success branch, FAILURE when no branch matches. The form exists for every
    tree built from Conditions, Actions, Fallbacks (their branches are concatenated) and Sequences
    made of Conditions with at most one other child that may succeed, last or followed only by
    Conditions and nodes of the same kind. Children after an Action (which never returns SUCCESS)
    are never ticked and do not appear. A Sequence with a Fallback that can succeed in several
    ways in the middle has no such form.
    """
    branches = _flat(node, frozenset(), ())
    return None if branches is None else tuple(branches)


def _flat(node: Node, guard: frozenset[int], path: Path) -> list[Branch] | None:
    if isinstance(node, Condition):
        return [Branch(guard | node.literals, None, path)]
    if isinstance(node, Action):
        return [Branch(guard, node.action, path)]
    if isinstance(node, Fallback):
        result: list[Branch] = []
        for index, child in enumerate(node.children):
            sub = _flat(child, guard, (*path, index))
            if sub is None:
                return None
            result.extend(sub)
        return result
    out: list[Branch] = []
    known = guard
    last = len(node.children) - 1
    for index, child in enumerate(node.children):
        if isinstance(child, Condition):
            known = known | child.literals
            continue
        sub = _flat(child, known, (*path, index))
        if sub is None:
            return None
        successes = [k for k, branch in enumerate(sub) if branch.action is None]
        if not successes or index == last:
            return out + sub  # the child never succeeds (the rest is never ticked), or it is the last
        if successes != [len(sub) - 1]:
            return None  # the child succeeds in several ways: the Sequence cannot be a list
        out.extend(sub[:-1])
        known = sub[-1].guard
    if node.children and isinstance(node.children[-1], Condition):
        return [*out, Branch(known, None, (*path, last))]
    return [*out, Branch(known, None, path)]


# ============================================================================= results
@dataclass(frozen=True, slots=True)
class Problem:
    """Something the tree does not guarantee, at one node."""

    path: str
    kind: str  # unknown-symbol | precondition | goal-check | success-without-goal | never-succeeds | no-progress
    #            | initial-state
    message: str
    missing: tuple[str, ...] = ()

    def __str__(self) -> str:
        return f"{self.path}: {self.message}"

    def to_dict(self) -> dict[str, Any]:
        return {"path": self.path, "kind": self.kind, "message": self.message, "missing": list(self.missing)}


@dataclass(frozen=True)
class Verification:
    """The verifier's answer.

    ``ok`` when there is no problem. ``proved_goal_reaching`` when the tree has a first-match form
    whose root succeeds exactly when the goal holds and whose every action branch makes progress:
    from any state satisfying one of its ``branches`` conditions, undisturbed ticking reaches the
    goal within ``branches`` ticks. ``covers_initial_state``: some branch condition holds in s0.
    ``warnings`` are harmless oddities (nodes that are never ticked); ``notes`` explain what could
    not be proved.
    """

    problems: tuple[Problem, ...]
    proved_goal_reaching: bool
    covers_initial_state: bool
    branches: int | None
    warnings: tuple[Problem, ...] = ()
    notes: tuple[str, ...] = ()

    @property
    def ok(self) -> bool:
        return not self.problems

    @property
    def first(self) -> Problem | None:
        """The first problem in depth-first order of the tree."""
        return self.problems[0] if self.problems else None

    @property
    def reaches_goal_from_initial_state(self) -> bool:
        return self.proved_goal_reaching and self.covers_initial_state

    def to_dict(self) -> dict[str, Any]:
        return {
            "ok": self.ok,
            "proved_goal_reaching": self.proved_goal_reaching,
            "covers_initial_state": self.covers_initial_state,
            "reaches_goal_from_initial_state": self.reaches_goal_from_initial_state,
            "branches": self.branches,
            "problems": [p.to_dict() for p in self.problems],
            "warnings": [w.to_dict() for w in self.warnings],
            "notes": list(self.notes),
        }

    def summary(self) -> str:
        """A few readable lines."""
        lines = [
            ("ok" if self.ok else f"{len(self.problems)} problem(s)")
            + f"; goal reaching {'proved' if self.proved_goal_reaching else 'not proved'}"
            + (f" ({self.branches} branches)" if self.branches is not None else "")
            + f"; s0 {'is' if self.covers_initial_state else 'is not'} covered by a branch"
        ]
        lines.extend(f"problem: {p}" for p in self.problems)
        lines.extend(f"warning: {w}" for w in self.warnings)
        lines.extend(f"note: {n}" for n in self.notes)
        return "\n".join(lines)


# ============================================================================ verifier
class _Collector:
    def __init__(self, task: GroundTask) -> None:
        self.task = task
        self.problems: list[tuple[Path, int, Problem]] = []
        self.warnings: list[tuple[Path, Problem]] = []

    def problem(self, path: Path, kind: str, message: str, missing: Iterable[int] = ()) -> None:
        names = tuple(self.task.names(missing))
        self.problems.append((path, len(self.problems), Problem(path_text(path), kind, message, names)))

    def warn(self, path: Path, kind: str, message: str) -> None:
        self.warnings.append((path, Problem(path_text(path), kind, message)))

    def literals(self, ids: Iterable[int]) -> str:
        return ", ".join(self.task.names(ids)) or "(nothing)"


def verify(tree: Node, task: GroundTask, goal: GoalIds, *, from_initial_state: bool = False) -> Verification:
    """Check ``tree`` against ``task`` and the goal (a :class:`Goal`, or the atom ids of a
    conjunction); see the module docstring.

    ``from_initial_state``: also report an ``initial-state`` problem unless the tree reaches the
    goal from s0 (without it, a tree that is correct wherever it acts passes even if s0 is outside
    it, as the truncated trees of a search stopped by a limit are)."""
    disjuncts = disjuncts_of(goal)
    found = _Collector(task)
    if not _check_symbols(tree, task, (), found):
        return _result(found, proved=False, covers=False, branches=None, notes=("unknown ids: nothing else checked",))
    _check_guards(tree, frozenset(), (), found)
    notes: list[str] = []
    branches = flatten(tree)
    proved = False
    covers = False
    if branches is None:
        notes.append(
            "the tree has no first-match form (a Sequence continues after a node that can succeed in "
            "several ways): goal reaching is not proved"
        )
        _check_success_implies_goal(tree, disjuncts, found)
    else:
        proved = _check_goal_branches(branches, disjuncts, found)
        proved = _check_progress(branches, task, found) and proved
        s0 = task.initial_state
        covers = any(branch.condition(task) <= s0 for branch in branches)
    if from_initial_state:
        if branches is not None and not covers:
            found.problem(
                (),
                "initial-state",
                "no branch's condition holds in the initial state, so the tree fails there "
                "(a partial tree, written after an unsolved search?)",
            )
        elif branches is None:
            outcome = _run_from_initial_state(tree, task, disjuncts)
            if outcome:
                found.problem((), "initial-state", outcome)
            else:
                notes.append("an undisturbed run from the initial state reaches the goal")
    return _result(
        found, proved=proved, covers=covers, branches=None if branches is None else len(branches), notes=tuple(notes)
    )


_MAX_RUN = 100_000  # actions of the run from s0 for a tree without first-match form


def _run_from_initial_state(tree: Node, task: GroundTask, goal: Goal) -> str:
    """Tick ``tree`` from s0 until it stops or repeats a state: ``""`` when it ends in SUCCESS with
    the goal, else what goes wrong."""
    state = task.initial_state
    seen = {state}
    actions = 0
    while True:
        status, running = tick(tree, state, task)
        if status is NodeStatus.SUCCESS:
            if any(d <= state for d in goal):
                return ""
            missing = ", ".join(task.names(_closest_missing(state, goal)))
            return (
                f"from the initial state the tree succeeds after {actions} action(s) without the goal: "
                f"missing {missing}"
            )
        if status is NodeStatus.FAILURE:
            return f"from the initial state the tree fails after {actions} action(s) without reaching the goal"
        assert running is not None
        state = task.actions[running].progress(state)
        actions += 1
        if state in seen:
            return (
                f"from the initial state the tree comes back to a state it was in after {actions} action(s): "
                "it never reaches the goal"
            )
        seen.add(state)
        if actions >= _MAX_RUN:
            return f"from the initial state the tree does not reach the goal within {_MAX_RUN:,} actions"


def _result(
    found: _Collector, *, proved: bool, covers: bool, branches: int | None, notes: tuple[str, ...]
) -> Verification:
    problems = tuple(p for _, _, p in sorted(found.problems, key=lambda item: (item[0], item[1])))
    warnings = tuple(w for _, w in sorted(found.warnings, key=lambda item: item[0]))
    for problem in problems:
        log.debug("verify: %s", problem)
    return Verification(problems, proved, covers, branches, warnings, notes)


def _check_symbols(node: Node, task: GroundTask, path: Path, found: _Collector) -> bool:
    if isinstance(node, Condition):
        bad = sorted(i for i in node.literals if not 0 <= i < len(task.atoms))
        if bad:
            found.problems.append(
                (path, len(found.problems), Problem(path_text(path), "unknown-symbol", f"unknown literal ids {bad}"))
            )
            return False
        return True
    if isinstance(node, Action):
        if not 0 <= node.action < len(task.actions):
            message = f"unknown action id {node.action}"
            found.problems.append((path, len(found.problems), Problem(path_text(path), "unknown-symbol", message)))
            return False
        return True
    results = [_check_symbols(child, task, (*path, i), found) for i, child in enumerate(node.children)]
    return all(results)


def _can_succeed(node: Node) -> bool:
    """Whether ``node`` can ever return SUCCESS under hbtp's ticks (an Action never does)."""
    if isinstance(node, Condition):
        return True
    if isinstance(node, Action):
        return False
    if isinstance(node, SequenceNode):
        return all(_can_succeed(child) for child in node.children)
    return any(_can_succeed(child) for child in node.children)


def _check_guards(node: Node, known: frozenset[int], path: Path, found: _Collector) -> frozenset[int]:
    """Report Actions whose precondition is not known where they are ticked; returns what is known
    after ``node`` succeeded (an Action counts as succeeding with its effects, see the module doc)."""
    task = found.task
    if isinstance(node, Condition):
        return known | node.literals
    if isinstance(node, Action):
        action = task.actions[node.action]
        missing = action.pre - known
        if missing:
            found.problem(
                path,
                "precondition",
                f"action {action.name} runs without its precondition being checked before it: "
                f"missing {found.literals(missing)}",
                missing,
            )
        return (known - action.delete) | action.add
    if isinstance(node, SequenceNode):
        current = known
        blocked: int | None = None
        for index, child in enumerate(node.children):
            if blocked is not None and index == blocked + 1:
                found.warn(
                    (*path, index),
                    "never-ticked",
                    f"never ticked: child {blocked} of this Sequence never returns SUCCESS "
                    "(hbtp actions return RUNNING or FAILURE)",
                )
            current = _check_guards(child, current, (*path, index), found)
            if blocked is None and not _can_succeed(child):
                blocked = index
        return current
    posts = [_check_guards(child, known, (*path, index), found) for index, child in enumerate(node.children)]
    if not posts:
        return known
    result = posts[0]
    for post in posts[1:]:
        result = result & post
    return result


def _success_post(node: Node, known: frozenset[int]) -> frozenset[int] | None:
    """Literals certain when ``node`` returns SUCCESS under hbtp's ticks; ``None``: it never does."""
    if isinstance(node, Condition):
        return known | node.literals
    if isinstance(node, Action):
        return None
    if isinstance(node, SequenceNode):
        current: frozenset[int] | None = known
        for child in node.children:
            assert current is not None
            current = _success_post(child, current)
            if current is None:
                return None
        return current
    posts = [p for p in (_success_post(child, known) for child in node.children) if p is not None]
    if not posts:
        return None
    result = posts[0]
    for post in posts[1:]:
        result = result & post
    return result


def _closest_missing(guard: frozenset[int], goal: Goal) -> frozenset[int]:
    """The literals ``guard`` lacks of the goal's disjunct it is closest to (fewest missing)."""
    return min((d - guard for d in goal), key=lambda m: (len(m), sorted(m)), default=frozenset())


def _check_success_implies_goal(tree: Node, goal: Goal, found: _Collector) -> None:
    post = _success_post(tree, frozenset())
    if post is None:
        found.problem((), "never-succeeds", "the root can never return SUCCESS")
    elif not any(d <= post for d in goal):
        missing = _closest_missing(post, goal)
        found.problem(
            (),
            "success-without-goal",
            f"the root can return SUCCESS without the goal: missing {found.literals(missing)}",
            missing,
        )


def _check_goal_branches(branches: Sequence[Branch], goal: Goal, found: _Collector) -> bool:
    """The root succeeds exactly when the goal holds: the first branches are success branches that
    check the goal (some check each disjunct, asking for nothing more), and every success branch
    holds a disjunct."""
    if not branches:
        found.problem((), "never-succeeds", "the tree always fails: it has no branch at all")
        return False
    ok = True
    lead: list[Branch] = []
    for branch in branches:
        if branch.action is not None:
            break
        lead.append(branch)
    for branch in branches:
        if branch.action is None and not any(d <= branch.guard for d in goal):
            ok = False
            missing = _closest_missing(branch.guard, goal)
            first = branch is branches[0]
            found.problem(
                branch.path,
                "success-without-goal",
                f"{'the first branch succeeds' if first else 'this branch makes the root succeed'} without the goal: "
                f"missing {found.literals(missing)}",
                missing,
            )
    for disjunct in goal:
        if any(branch.guard <= disjunct for branch in lead):
            continue
        ok = False
        if not lead:
            action = branches[0].action
            assert action is not None
            found.problem(
                branches[0].path,
                "goal-check",
                f"the tree does not check the goal first: it can run {found.task.actions[action].name} "
                "while the goal holds",
            )
            break
        extra = min((branch.guard - disjunct for branch in lead), key=lambda e: (len(e), sorted(e)))
        found.problem(
            lead[0].path,
            "goal-check",
            f"the first branch asks for more than the goal, so the tree may act when the goal holds: "
            f"extra {found.literals(extra)}",
            extra,
        )
    return ok


def _check_progress(branches: Sequence[Branch], task: GroundTask, found: _Collector) -> bool:
    """Every action branch leads to the condition of an earlier branch (see the module docstring)."""
    conditions = [branch.condition(task) for branch in branches]
    earlier = SubsetIndex()
    ok = True
    for position, (branch, condition) in enumerate(zip(branches, conditions, strict=True)):
        if branch.action is not None:
            after = task.actions[branch.action].progress(condition)
            if not earlier.has_subset(after):
                ok = False
                _report_no_progress(position, branch, after, conditions, branches, found)
        earlier.add(condition)
    return ok


def _report_no_progress(
    position: int,
    branch: Branch,
    after: frozenset[int],
    conditions: Sequence[frozenset[int]],
    branches: Sequence[Branch],
    found: _Collector,
) -> None:
    assert branch.action is not None
    name = found.task.actions[branch.action].name
    if position == 0:
        found.problem(branch.path, "no-progress", f"after {name} no earlier branch exists to lead to")
        return
    closest = min(range(position), key=lambda j: (len(conditions[j] - after), j))
    missing = conditions[closest] - after
    found.problem(
        branch.path,
        "no-progress",
        f"branch leads nowhere: after {name} from its condition, no earlier branch's condition holds; the "
        f"closest, {path_text(branches[closest].path)}, misses {found.literals(missing)}",
        missing,
    )


__all__ = ["Branch", "Problem", "Verification", "flatten", "path_text", "verify"]
