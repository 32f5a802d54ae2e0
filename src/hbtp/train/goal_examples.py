"""Instruction examples for a taught model: goals said in words, and what to answer.

The goals are built from the planner's labelled goals of everyday activity (the ends of random
walks, :data:`hbtp.planning.generate.Draw.WALK`: goals drawn from every reachable atom ask for
intermediate facts such as where the robot stands, which people rarely ask for, and a model taught
them adds such literals to what people said). A walk's end also makes several facts about the
robot itself true (what its hands hold, where it stands): most of them are dropped
(:func:`about_world`; :meth:`hbtp.domains.words.Words.about_robot` says which are). Every goal is
solvable and none holds at the start:

* *one*: one literal of a labelled goal that does not hold at the start (most instructions people
  give ask for one thing; labelled goals mostly have two or three literals);
* *and*: a labelled goal as it is (one literal or several);
* *group*: a labelled goal with one or two more literals alike one of its own but for one argument
  (``IsOn_pear_table`` beside ``IsOn_apple_table``): people list things, "put the pear and the apple
  on the table", and :func:`hbtp.train.verbalise.verbalise` says such literals as one list;
* *both*: two labelled goals asked for together (longer conjunctions);
* *kept*: a labelled goal and a literal that holds at the start and that its optimal plan leaves
  true (people ask for what is so already, "and leave the light off", beside what is not);
* *or*: two labelled goals as alternatives (``A | B``);
* *choice*: one literal of a labelled goal that does not hold at the start and one or two alike it
  but for one argument, as alternatives (``On_Yogurt_Table3 | On_MilkDrink_Table3``): people offer a
  choice among things of one kind, "a yogurt or a milk drink", and the verbaliser says it as one list;
* *not*: a labelled goal with the negation of an atom its optimal plan makes false
  (``A & ~p``: the plan reaches it), or that negation alone;
* *guard*: a labelled goal with the negation of an atom that holds neither at the start nor after
  its optimal plan, but that some plan could make true ("turn on the AC, but don't set the
  temperature low"): people forbid a side effect, and the same plan keeps it false. Its
  instruction may say the deed forbidden ("don't close the curtain", :func:`absent_atoms`).

The atom of a *kept*, *not* or *guard* goal is drawn predicate first (:func:`draw`): every kind of
fact gets its share, not only where each thing is.

A *group* or *both* goal is kept only when the labelling search solves it within
:data:`LABEL_EXPANSIONS` (else the labelled goal is used). Each goal is said as an instruction by
:func:`hbtp.train.verbalise.verbalise` and answered with the goal
(:func:`hbtp.llm.goal_prompt.taught_goal_reply`). A share of *refusals* teaches the model to refuse
an instruction about something the world lacks: a labelled goal with one of its objects swapped for
an object of the words file this world does not have ("put the sofa in the fridge" where there is no
sofa), answered ``Unknown: sofa`` (:func:`hbtp.llm.goal_prompt.refusal_reply`)."""

from __future__ import annotations

import random
from collections.abc import Sequence
from dataclasses import replace

from hbtp.datasets.records import Record
from hbtp.domains import Scenario
from hbtp.domains.words import Words, words_for
from hbtp.errors import InputError
from hbtp.llm.goal_prompt import refusal_reply, taught_goal_prompt, taught_goal_reply
from hbtp.logic.atoms import Atom, parse_atom
from hbtp.logic.execution import apply_actions
from hbtp.logic.goals import format_goal, parse_goal
from hbtp.planning.generate import label_goal, relaxed_reachable
from hbtp.planning.limits import Limits
from hbtp.train.examples import Example, ExampleKind, goal_key, held_goals
from hbtp.train.verbalise import lacking_instruction, verbalise

#: The shapes of the instruction goals, with their shares (refusals come on top: :data:`REFUSALS`).
SHAPES: tuple[tuple[str, float], ...] = (
    ("one", 0.18),
    ("and", 0.12),
    ("group", 0.12),
    ("both", 0.08),
    ("kept", 0.1),
    ("or", 0.1),
    ("choice", 0.1),
    ("not", 0.1),
    ("guard", 0.1),
)
#: Refusals per instruction example.
REFUSALS = 0.12
#: Instruction examples per labelled goal.
PER_GOAL = 2
#: How often a literal about the robot itself (its hands, where it stands) is asked for beside
#: literals about the world: a walk's end makes several true, people rarely ask for them.
SELF_KEPT = 0.15
#: The labelling search's bound for a goal built of several labelled ones (*group*, *both*).
LABEL_EXPANSIONS = 20_000


def negatable(scenario: Scenario, record: Record) -> list[Atom]:
    """The fluent atoms that hold at the start and no longer hold after ``record``'s plan: their
    negation is reached by that plan."""
    return _start_atoms(scenario, record, kept=False)


def kept_atoms(scenario: Scenario, record: Record) -> list[Atom]:
    """The fluent atoms that hold at the start and still hold after ``record``'s plan: asked for
    beside the record's goal, the same plan reaches them."""
    return _start_atoms(scenario, record, kept=True)


def _final_state(scenario: Scenario, record: Record) -> frozenset[int] | None:
    """The state ``record``'s optimal plan ends in; ``None`` when it does not run from the start."""
    task = scenario.task
    try:
        actions = [task.action(parse_atom(name)) for name in record.optimal_actions]
    except InputError:
        return None
    final, done = apply_actions(task, actions)
    return frozenset(final) if done == len(actions) else None


def _start_atoms(scenario: Scenario, record: Record, *, kept: bool) -> list[Atom]:
    task = scenario.task
    final = _final_state(scenario, record)
    if final is None:
        return []
    chosen = task.initial_state & final if kept else task.initial_state - final
    return sorted(
        (task.atoms[i] for i in chosen if not task.atoms[i].negated and task.atoms[i].predicate in task.predicates),
        key=lambda atom: atom.underscored,
    )


def unmet_literals(scenario: Scenario, goal: str) -> list[str]:
    """The literals of a conjunctive ``goal`` that do not hold at the start (each a goal the same
    plan reaches), in the goal's order; none for a goal with alternatives."""
    terms = parse_goal(goal)
    if len(terms) != 1:
        return []
    task = scenario.task
    holding = task.initial_state
    unmet = []
    for literal in terms[0]:
        atom_id = task.atom_ids.get(literal)
        if atom_id is not None and atom_id not in holding:
            unmet.append(literal.underscored)
    return unmet


def absent_atoms(scenario: Scenario, goal: str) -> frozenset[Atom]:
    """The atoms of ``goal``'s negated literals that do not hold at the start: "don't close the
    curtain" asks for ``~Closed_Curtain`` only where the curtain is open already."""
    task = scenario.task
    negated = {atom.positive for term in parse_goal(goal) for atom in term if atom.negated}
    return frozenset(atom for atom in negated if task.atom_ids.get(atom) not in task.initial_state)


def _compatible(scenario: Scenario, goal: str, atoms: Sequence[Atom]) -> list[Atom]:
    """The ``atoms`` that the world's mutexes let hold together with the conjunctive ``goal``."""
    terms = parse_goal(goal)
    if len(terms) != 1:
        return []
    task = scenario.task
    literals = {task.atom_id(literal) for literal in terms[0]}
    return [atom for atom in atoms if scenario.mutexes.conflict(literals | {task.atom_id(atom)}) is None]


class _Alike:
    """The atoms a plan may make true (relaxed reachable, not holding at the start), by predicate,
    to find literals alike a goal's own but for one argument."""

    def __init__(self, scenario: Scenario, words: Words) -> None:
        task = scenario.task
        self.scenario, self.words = scenario, words
        self.by_predicate: dict[str, list[Atom]] = {}
        for index in sorted(relaxed_reachable(task) - task.initial_state):
            atom = task.atoms[index]
            if not atom.negated and parse_atom(atom.underscored) == atom:
                self.by_predicate.setdefault(atom.predicate, []).append(atom)

    def alike(self, literal: Atom, rng: random.Random) -> list[Atom]:
        """The atoms alike ``literal`` but for one argument (drawn, not the robot itself), shuffled."""
        positions = [i for i, arg in enumerate(literal.args) if not self.words.noun(arg).agent]
        if not positions:
            return []
        at = rng.choice(positions)
        same = literal.args[:at] + literal.args[at + 1 :]
        found = [a for a in self.by_predicate.get(literal.predicate, []) if a.args[:at] + a.args[at + 1 :] == same]
        rng.shuffle(found)
        return [atom for atom in found if atom != literal]

    def choice(self, goal: str, rng: random.Random) -> str | None:
        """One literal of ``goal`` that does not hold at the start and one or two alike it but for one
        argument, as alternatives; ``None`` when there are none."""
        unmet = unmet_literals(self.scenario, goal)
        if not unmet:
            return None
        literal = parse_atom(rng.choice(unmet))
        others = self.alike(literal, rng)[: rng.randint(1, 2)]
        return " | ".join(atom.underscored for atom in [literal, *others]) if others else None

    def guard(self, record: Record, rng: random.Random) -> str | None:
        """``record``'s goal and the negation of an atom about the world that holds neither at the
        start nor after its plan (one about an object of the goal half of the time); ``None`` when
        there is none."""
        final = _final_state(self.scenario, record)
        if final is None or len(parse_goal(record.goal)) != 1:
            return None
        task = self.scenario.task
        candidates = [
            atom
            for atoms in self.by_predicate.values()
            for atom in atoms
            if task.atom_id(atom) not in final and not self.words.about_robot(atom)
        ]
        named = {arg for atom in parse_goal(record.goal)[0] for arg in atom.args}
        near = [atom for atom in candidates if named & set(atom.args)]
        pool = near if near and rng.random() < 0.5 else candidates
        return f"{record.goal} & ~{draw(pool, rng).underscored}" if pool else None

    def extend(self, goal: str, rng: random.Random) -> str | None:
        """``goal`` (conjunctive) with one or two literals alike one of its own but for one argument
        (not the robot itself), none that the mutexes rule out beside it; ``None`` when there is none."""
        terms = parse_goal(goal)
        if len(terms) != 1:
            return None
        literal = rng.choice([atom for atom in terms[0] if not atom.negated] or [None])
        if literal is None:
            return None
        alike = self.alike(literal, rng)
        task = self.scenario.task
        ids = {task.atom_id(atom) for atom in terms[0]}
        added: list[str] = []
        wanted = rng.randint(1, 2)
        for atom in alike:
            if len(added) == wanted:
                break
            index = task.atom_id(atom)
            if index not in ids and self.scenario.mutexes.conflict(ids | {index}) is None:
                ids.add(index)
                added.append(atom.underscored)
        return " & ".join([goal, *added]) if added else None


def _about_world(atoms: Sequence[Atom], words: Words) -> list[Atom]:
    """The ``atoms`` that are not about the robot itself (:meth:`Words.about_robot`)."""
    return [atom for atom in atoms if not words.about_robot(atom)]


def draw(atoms: Sequence[Atom], rng: random.Random) -> Atom:
    """One of ``atoms`` (not empty), its predicate drawn first: each predicate among them is as likely,
    so the many atoms of one predicate (where each thing is) do not crowd out the few of another
    (whether the light is on)."""
    by_predicate: dict[str, list[Atom]] = {}
    for atom in atoms:
        by_predicate.setdefault(atom.predicate, []).append(atom)
    return rng.choice(by_predicate[rng.choice(sorted(by_predicate))])


def _solvable(scenario: Scenario, goal: str) -> bool:
    """Whether the labelling search solves the conjunctive ``goal`` within :data:`LABEL_EXPANSIONS`."""
    task = scenario.task
    literals = frozenset(task.atom_id(atom) for atom in parse_goal(goal)[0])
    proved = scenario.mutexes.proved_only()
    return label_goal(task, literals, proved, Limits(max_expansions=LABEL_EXPANSIONS)) is not None


def instruction_goal(
    scenario: Scenario, record: Record, others: Sequence[Record], rng: random.Random, alike: _Alike | None = None
) -> str:
    """A goal of one of the :data:`SHAPES` (drawn by their shares) built on ``record``'s goal."""
    shape = rng.choices([name for name, _ in SHAPES], [share for _, share in SHAPES])[0]
    alike = alike or _Alike(scenario, words_for(scenario))
    if shape == "one":
        unmet = unmet_literals(scenario, record.goal)
        if unmet:
            return rng.choice(unmet)
    if shape == "group":
        grouped = alike.extend(record.goal, rng)
        if grouped is not None and _solvable(scenario, grouped):
            return grouped
    if shape == "both" and others:
        other = rng.choice(others)
        both = f"{record.goal} & {other.goal}"
        if len(parse_goal(both)) == 1 and other.goal != record.goal and _solvable(scenario, both):
            return format_goal(parse_goal(both))
    if shape == "kept":
        atoms = _about_world(_compatible(scenario, record.goal, kept_atoms(scenario, record)), alike.words)
        if atoms:
            return f"{record.goal} & {draw(atoms, rng).underscored}"
    if shape == "or" and others:
        other = rng.choice(others)
        if other.goal != record.goal:
            return f"{record.goal} | {other.goal}"
    if shape == "choice":
        offered = alike.choice(record.goal, rng)
        if offered is not None:
            return offered
    if shape == "guard":
        guarded = alike.guard(record, rng)
        if guarded is not None:
            return guarded
    if shape == "not":
        atoms = negatable(scenario, record)
        atoms = atoms if rng.random() < SELF_KEPT else _about_world(atoms, alike.words)
        if atoms:
            negated = "~" + draw(atoms, rng).underscored
            return negated if rng.random() < 0.3 else f"{record.goal} & {negated}"
    return record.goal


def about_world(record: Record, words: Words, rng: random.Random) -> Record:
    """``record`` with each literal about the robot itself (an ``agent`` argument) dropped but for
    :data:`SELF_KEPT` of them; when the goal is only about the robot, one of them is kept (the same
    plan reaches what remains)."""
    literals = record.goal.split(" & ")
    if "|" in record.goal or len(literals) == 1:
        return record
    agent = [words.about_robot(parse_atom(literal)) for literal in literals]
    sure = rng.randrange(len(literals)) if all(agent) else -1
    kept = [
        literal
        for index, (literal, own) in enumerate(zip(literals, agent, strict=True))
        if not own or index == sure or rng.random() < SELF_KEPT
    ]
    return replace(record, goal=" & ".join(kept))


def refusal_example(
    scenario: Scenario, record: Record, foreign: Sequence[str], words: Words, rng: random.Random
) -> Example | None:
    """``record``'s goal with one object swapped for a foreign one, said in words and refused."""
    said = lacking_instruction(record.goal, scenario.task.constants, foreign, words, rng)
    if said is None:
        return None
    return Example(ExampleKind.GOAL, record.goal, taught_goal_prompt(said.instruction), refusal_reply(said.thing))


def goal_examples(scenario: Scenario, records: Sequence[Record], seed: int, per_goal: int = 1) -> list[Example]:
    """``per_goal`` instruction examples per record (each a goal of a drawn shape, said in words,
    never one of an evaluation set: then the record's own goal), and refusals for about
    :data:`REFUSALS` of them; the same for the same seed."""
    rng = random.Random(f"goal-examples|{seed}")
    words = words_for(scenario)
    foreign = words.foreign()
    alike = _Alike(scenario, words)
    examples: list[Example] = []
    held = held_goals(scenario)
    others = [about_world(record, words, rng) for record in records]
    for record in records:
        for _ in range(per_goal):
            asked = about_world(record, words, rng)
            goal = instruction_goal(scenario, asked, others, rng, alike)
            if goal_key(goal) in held:  # a part of a labelled goal can be an evaluation goal: never taught
                goal = record.goal
            said = verbalise(goal, words, rng, 1, absent=absent_atoms(scenario, goal))
            if said:
                examples.append(Example(ExampleKind.GOAL, goal, taught_goal_prompt(said[0]), taught_goal_reply(goal)))
        if rng.random() < REFUSALS * per_goal:
            asked = about_world(record, words, rng)
            refused = asked if goal_key(asked.goal) not in held else record
            refusal = refusal_example(scenario, refused, foreign, words, rng)
            if refusal is not None:
                examples.append(refusal)
    return examples


__all__ = [
    "LABEL_EXPANSIONS",
    "PER_GOAL",
    "REFUSALS",
    "SELF_KEPT",
    "SHAPES",
    "about_world",
    "absent_atoms",
    "draw",
    "goal_examples",
    "instruction_goal",
    "kept_atoms",
    "negatable",
    "refusal_example",
    "unmet_literals",
]
