"""Sampled goals labelled by the optimal planner: generated datasets and demonstrations for any domain.

Where a goal's literals come from is a :class:`Draw`:

* ``WALK`` (datasets, demonstrations): from a state reachable from s0, so the goal is always
  solvable: a random walk of forward progression (``(s - del) | add``) ends in a state s, and the
  goal is 1 to k literals of s ∖ s0 (what the walk made true). A walk step first draws an
  applicable action predicate, then one of its applicable actions, so that a domain with many
  actions of one kind (RobotHow's 130 ``Walk`` actions) does not drown the others. Walks mostly
  change what is near s0: their goals have short plans.
* ``REACHABLE`` (training a model): from every atom the delete relaxation reaches that s0 lacks,
  a predicate first, then one of its atoms; literals proved mutex are not drawn together, and a
  goal the bounded search does not solve is skipped. These goals reach as far from s0 as the
  domain does (an appliance to plug in and open, a tool to fetch), as people's goals do.
Each goal is labelled with a cost-optimal plan p* (OBTEA with the landmark heuristic, pruning with
proved mutexes only) and kept when |p*| and its number of literals fit the :class:`Level`.

Everything is domain-independent: the only parameters are the level's windows and the
:class:`Sampling` bounds. The labelling search is bounded by a number of expansions, not by time,
so that the same seed gives the same goals on any machine and under any load.

This module sits in the planning layer because labelling needs the planner; the few-shot pool
(:mod:`hbtp.llm.demonstrations`) and the commands (``hbtp dataset generate``, ``hbtp examples
generate``) use it.
"""

from __future__ import annotations

import enum
import logging
import random
from collections import Counter, defaultdict
from collections.abc import Iterable, Sequence
from dataclasses import dataclass

from hbtp.datasets.records import Record
from hbtp.domains.mutex import Mutexes
from hbtp.domains.reachability import reachable_actions
from hbtp.errors import InputError
from hbtp.logic.atoms import Atom, parse_atom, parse_conjunction
from hbtp.logic.task import Goal, GroundTask, State
from hbtp.planning.heuristic_names import HeuristicName
from hbtp.planning.hints import Hints
from hbtp.planning.limits import Limits
from hbtp.planning.planners import plan

log = logging.getLogger(__name__)


@dataclass(frozen=True, slots=True)
class Level:
    """A difficulty level: how many goal literals, and the window of the optimal plan's length |p*|
    (``max_length`` ``None``: no upper bound)."""

    name: str
    literals: tuple[int, int]
    min_length: int
    max_length: int | None
    description: str

    @property
    def walk_length(self) -> int:
        """The longest random walk tried: three times the longest plan wanted (the shortest when
        unbounded): walks wander and plans take the short way."""
        return 3 * (self.max_length or self.min_length)

    @property
    def width(self) -> int:
        """How many plan lengths the window holds (1 when unbounded)."""
        return self.max_length - self.min_length + 1 if self.max_length is not None else 1

    def fits(self, literals: int, length: int) -> bool:
        low, high = self.literals
        return low <= literals <= high and self.min_length <= length <= (self.max_length or length)


#: The levels, by name. easy / medium / hard follow the paper's Table IV definitions (one task; one
#: or two tasks; three tasks), with windows on |p*|; ``expert`` goes beyond them; ``any`` is what
#: demonstration pools use.
LEVELS: dict[str, Level] = {
    level.name: level
    for level in (
        Level("easy", (1, 1), 2, 4, "one literal, |p*| 2-4"),
        Level("medium", (1, 2), 3, 6, "one or two literals, |p*| 3-6"),
        Level("hard", (3, 3), 6, 10, "three literals, |p*| 6-10"),
        Level("expert", (4, 6), 15, None, "four to six literals, |p*| >= 15"),
        Level("any", (1, 3), 1, 12, "one to three literals, |p*| 1-12 (demonstration pools)"),
    )
}


class Draw(enum.Enum):
    """Where a sampled goal's literals come from (see the module docstring)."""

    WALK = "walk"
    REACHABLE = "reachable"


@dataclass(frozen=True, slots=True)
class Sampling:
    """The sampling parameters (all domain-independent).

    ``seed``: the random seed; ``max_expansions``: the labelling search's bound per goal (a goal
    whose optimum is not found within it is skipped); ``attempts``: candidate goals drawn per goal
    asked for, before giving up with fewer; ``draw``: where the literals come from.
    """

    seed: int = 0
    max_expansions: int = 20_000
    attempts: int = 40
    draw: Draw = Draw.WALK

    def key(self) -> str:
        drawn = "" if self.draw is Draw.WALK else f",draw={self.draw.value}"
        return f"seed={self.seed},max_expansions={self.max_expansions},attempts={self.attempts}{drawn}"


@dataclass(frozen=True, slots=True)
class LabelledGoal:
    """A sampled goal with the actions and cost of one optimal plan."""

    goal: Goal
    plan: tuple[int, ...]
    cost: int

    def record(self, task: GroundTask, record_id: str) -> Record:
        """The dataset record of this goal (names in the datasets' ``Pred_a_b`` spelling)."""
        hints = Hints.from_plan(task, self.plan)
        return Record(
            id=record_id,
            goal=" & ".join(task.atoms[i].underscored for i in sorted(self.goal.ids)),
            optimal_actions=tuple(task.actions[i].signature.underscored for i in self.plan),
            vital_predicates=hints.predicates,
            vital_objects=hints.objects,
            cost=self.cost,
        )


class _Walker:
    """Random walks from s0, with applicability kept incrementally (a count of missing
    preconditions per action), so a step costs what the changed atoms touch, not |A|."""

    def __init__(self, task: GroundTask) -> None:
        self.task = task
        self.needed_by: list[list[int]] = [[] for _ in task.atoms]
        for action in task.actions:
            for atom in action.pre:
                self.needed_by[atom].append(action.index)
        start = task.initial_state
        self.missing0 = [len(a.pre - start) for a in task.actions]
        self.applicable0 = frozenset(i for i, m in enumerate(self.missing0) if m == 0)
        deleters = Counter(atom for action in task.actions for atom in action.delete)
        #: A goal is a lasting change: an atom is drawn with weight 1 / (1 + the actions deleting it).
        self.weights = [1 / (1 + deleters[atom]) for atom in range(len(task.atoms))]

    def walk(self, rng: random.Random, steps: int) -> State:
        actions = self.task.actions
        state, missing, applicable = self.task.initial_state, list(self.missing0), set(self.applicable0)
        for _ in range(steps):
            if not applicable:
                break
            by_predicate: dict[str, list[int]] = defaultdict(list)
            for index in sorted(applicable):
                by_predicate[actions[index].predicate].append(index)
            chosen = actions[rng.choice(by_predicate[rng.choice(sorted(by_predicate))])]
            after = chosen.progress(state)
            for atom, change in [*((a, 1) for a in state - after), *((a, -1) for a in after - state)]:
                for index in self.needed_by[atom]:
                    missing[index] += change
                    (applicable.add if missing[index] == 0 else applicable.discard)(index)
            state = after
        return state


def _writable(atom: Atom) -> bool:
    """Whether the datasets' ``Pred_a_b`` spelling of ``atom`` reads back as ``atom``."""
    return parse_atom(atom.underscored) == atom


def relaxed_reachable(task: GroundTask) -> frozenset[int]:
    """The atoms the delete relaxation reaches from s0 (a superset of those a plan can make true)."""
    reachable = reachable_actions(task.initial_state, [(action.pre, action.add) for action in task.actions])
    return task.initial_state.union(*(task.actions[index].add for index in reachable))


def _draw_by_predicate(
    rng: random.Random, pool: Sequence[int], task: GroundTask, weights: Sequence[float], count: int
) -> frozenset[int]:
    """``count`` distinct atoms of ``pool``: each a predicate first (uniformly), then one of its
    atoms by weight, so that a predicate with many atoms does not drown the others."""
    by_predicate: dict[str, list[int]] = defaultdict(list)
    for atom in pool:
        by_predicate[task.atoms[atom].predicate].append(atom)
    chosen: set[int] = set()
    for _ in range(4 * count):
        if len(chosen) == count:
            break
        atoms = by_predicate[rng.choice(sorted(by_predicate))]
        chosen.add(atoms[rng.choices(range(len(atoms)), [weights[a] for a in atoms])[0]])
    return frozenset(chosen)


def _draw_literals(rng: random.Random, changed: Sequence[int], weights: Sequence[float], count: int) -> frozenset[int]:
    """``count`` distinct atoms of ``changed``, each drawn with its weight."""
    pool = list(changed)
    chosen: list[int] = []
    while len(chosen) < count and pool:
        position = rng.choices(range(len(pool)), [weights[a] for a in pool])[0]
        chosen.append(pool.pop(position))
    return frozenset(chosen)


def sample_goals(
    task: GroundTask,
    level: Level,
    count: int,
    sampling: Sampling = Sampling(),
    mutexes: Mutexes | None = None,
) -> list[LabelledGoal]:
    """Up to ``count`` distinct goals of ``level``, each with an optimal plan, deterministic for
    ``sampling.seed``.

    Raises :class:`~hbtp.errors.InputError` when the domain is too small to sample from (no action
    applies in s0). Fewer goals than asked (possibly none) come back, with a warning, when the
    candidates run out (``sampling.attempts`` per goal) first: a small domain has few goals.
    """
    walker = _Walker(task)
    if not walker.applicable0:
        raise InputError(f"{task.name}: too small to sample goals from: no action applies in the initial state")
    rng = random.Random(sampling.seed)
    proved = mutexes.proved_only() if mutexes is not None else None
    limits = Limits(max_expansions=sampling.max_expansions)
    seen: set[frozenset[int]] = set()
    found: list[LabelledGoal] = []
    spare: list[LabelledGoal] = []  # beyond a length's quota: used only when the others run out
    lengths: Counter[int] = Counter()
    quota = -(-count // level.width) if level.max_length is not None else count
    attempts = 0
    reachable = sorted(relaxed_reachable(task) - task.initial_state) if sampling.draw is Draw.REACHABLE else []
    reachable = [a for a in reachable if _writable(task.atoms[a])]
    while len(found) < count and attempts < sampling.attempts * count:
        attempts += 1
        if sampling.draw is Draw.REACHABLE:
            literals = _draw_by_predicate(rng, reachable, task, walker.weights, rng.randint(*level.literals))
        else:
            state = walker.walk(rng, rng.randint(1, level.walk_length))
            changed = [a for a in sorted(state - task.initial_state) if _writable(task.atoms[a])]
            literals = _draw_literals(rng, changed, walker.weights, rng.randint(*level.literals))
        if len(literals) < level.literals[0] or literals in seen:
            continue
        if proved is not None and proved.conflict(literals) is not None:
            continue
        seen.add(literals)
        labelled = label_goal(task, literals, proved, limits)
        if labelled is not None and level.fits(len(literals), len(labelled.plan)):
            length = len(labelled.plan)
            (found if lengths[length] < quota else spare).append(labelled)
            lengths[length] += 1
    found.extend(spare[: count - len(found)])
    if len(found) < count:
        log.warning(
            "%s: found %d of %d %s goals after %d candidates (the domain has few such goals)",
            task.name, len(found), count, level.name, attempts,
        )  # fmt: skip
    return found


def label_goal(
    task: GroundTask, literals: frozenset[int], mutexes: Mutexes | None, limits: Limits
) -> LabelledGoal | None:
    """``literals`` with an optimal plan, or ``None`` when the bounded search does not find one or
    a plan's action cannot be written in the datasets' spelling."""
    goal = task.resolve_goal([task.atoms[i] for i in sorted(literals)])
    result = plan(task, goal, "obtea", heuristic=HeuristicName.LM, mutexes=mutexes, limits=limits)
    if not result.solved or not all(_writable(task.actions[i].signature) for i in result.solution):
        log.debug("skipping %s: %s", goal, result.status.value)
        return None
    return LabelledGoal(goal, result.solution, sum(task.actions[i].cost for i in result.solution))


def generate_records(
    task: GroundTask,
    level: Level | str,
    count: int,
    sampling: Sampling = Sampling(),
    mutexes: Mutexes | None = None,
) -> list[Record]:
    """:func:`sample_goals` as dataset records numbered 1..n."""
    chosen = level if isinstance(level, Level) else level_named(level)
    goals = sample_goals(task, chosen, count, sampling, mutexes)
    return [goal.record(task, str(number)) for number, goal in enumerate(goals, 1)]


def level_named(name: str) -> Level:
    try:
        return LEVELS[name]
    except KeyError:
        raise InputError(f"unknown level {name!r}; choose one of: {', '.join(LEVELS)}") from None


def statistics(records: Iterable[Record], predicates: Sequence[str] = ()) -> dict[str, float]:
    """Table IV's figures of ``records``: mean |p*|, mean literals, the share of goals that use a
    tool (an object of the plan the goal does not name) and the share of plans using each action
    predicate (those of ``predicates``, else every one that occurs)."""
    rows = list(records)
    if not rows:
        return {"records": 0}
    uses: Counter[str] = Counter(p for r in rows for p in set(r.vital_predicates))
    tools = sum(1 for r in rows if set(r.vital_objects) - {a for g in _goal_atoms(r) for a in g.args})
    figures = {
        "records": len(rows),
        "mean_length": sum(len(r.optimal_actions) for r in rows) / len(rows),
        "mean_literals": sum(len(_goal_atoms(r)) for r in rows) / len(rows),
        "tool_use": tools / len(rows),
    }
    for predicate in predicates or sorted(uses):
        figures[predicate] = uses[predicate] / len(rows)
    return figures


def _goal_atoms(record: Record) -> list[Atom]:
    return list(parse_conjunction(record.goal))
