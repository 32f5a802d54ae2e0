"""Instruction in, checked goal out: the model proposes a goal, hbtp checks it, feeds back, repeats.

Each proposal is read in the goal syntax (:mod:`hbtp.logic.goals`) and checked against the scenario
before any planning:

* *refused*: not a goal (malformed, unknown names), a contradiction (``IsOpen_fridge &
  ~IsOpen_fridge``, or literals the domain's proved mutexes forbid together: ``IsOpen_fridge &
  IsClose_fridge``), literals no action can make true (these are left out of the next grammar),
  or literals no plan makes hold together for want of a last action (``Holding_VacuumCup &
  On_VacuumCup_Table2``: :func:`hbtp.planning.regression.stuck`);
* *doubtful*: the goal already holds in s0 (the robot would do nothing).

A refused goal goes back to the model with the reason (the blacklist of LLM-OBTEA) for at most
``rounds`` more answers; the first goal with no objection is chosen; failing that, nothing, and the
reasons are the error. A doubtful goal ends the asking and is refused: the instruction asks for
what already holds (a goal asked for again would only drift from what was meant). A model taught
the world may refuse itself: an instruction that names what the world lacks is answered with what
it lacks (:func:`hbtp.llm.goal_prompt.refusal_of`), and that is the error, unless the refusal
cannot stand (:func:`false_refusal`: the instruction does not say the thing, or the world has an
object called so), when the model is asked again with refusals not offered; in its answer, a thing
said short or by a part is the thing meant (:mod:`hbtp.pipeline.referents`), an
object the instruction names and the goal leaves out takes the place of one it never names
(:mod:`hbtp.pipeline.stand_ins`), a literal about two things never named together takes what the
instruction says of them (:mod:`hbtp.pipeline.apart`); the answer loses the
literals about objects the instruction never names, when others are about objects it names
(:func:`unsaid_dropped`), and its literals about the robot itself that the instruction does not ask
for (:mod:`hbtp.pipeline.own_state`), and a literal it wrote positive where the instruction says it negated
becomes its negation (:mod:`hbtp.pipeline.polarity`), as does one it says undone ("leave the bar",
:mod:`hbtp.pipeline.undone`), and its alternatives are grouped as the
instruction joins their objects (:mod:`hbtp.pipeline.grouping`). A completion-style model's accepted
conjunction is then extended with a literal for each object the instruction names and the goal
leaves out (asked as a continuation of its own goal; a literal that draws an objection is dropped),
and a taught model's, with a literal for each clause that asks for one it leaves out ("... and run
it": :mod:`hbtp.pipeline.deeds`; the one the clause says, or the model's choice of several).
A goal is refused when it stands in for a thing the instruction names that the world lacks
(:func:`substituted`), or leaves out such a thing the instruction asks about
(:mod:`hbtp.pipeline.strangers`). An instruction that names no object of the domain and shares no
word with a known instruction is refused before the model is asked (a model under a grammar always
answers *some* goal): for what it names that the world lacks, when it names such a thing ("bring
me the guitar"), else as about nothing the domain knows.
"""

from __future__ import annotations

import logging
from collections.abc import Callable, Sequence
from dataclasses import dataclass, field, replace
from functools import partial
from typing import Any

from hbtp.datasets.instructions import load_instructions
from hbtp.deadline import Deadline, expired
from hbtp.domains.scenarios import Scenario
from hbtp.domains.words import Words, spoken_words, words_for
from hbtp.errors import BackendTimeLimit, InputError
from hbtp.llm.backend import Backend, PromptStyle, Reply, Request
from hbtp.llm.goal_prompt import (
    STOPWORDS,
    Connectives,
    Example,
    Rejected,
    content_words,
    continuation_request,
    goal_reply,
    goal_request,
    mentioned_objects,
    named_atoms,
    refusal_of,
    similar_examples,
)
from hbtp.logic.atoms import Atom
from hbtp.logic.goals import format_goal, parse_goal
from hbtp.pipeline.apart import apart_mended
from hbtp.pipeline.clauses import has_twin, objects_of, spoken_objects
from hbtp.pipeline.deeds import unanswered
from hbtp.pipeline.grouping import regrouped
from hbtp.pipeline.mend import parsed
from hbtp.pipeline.own_state import unasked_own_dropped
from hbtp.pipeline.polarity import negations_mended
from hbtp.pipeline.referents import referents_read
from hbtp.pipeline.sides import sides_as_said
from hbtp.pipeline.stand_ins import named_in_place
from hbtp.pipeline.strangers import asked_about, asked_beside
from hbtp.pipeline.undone import undone_added
from hbtp.pipeline.unspoken import kind_as_said, unspoken_dropped, unspoken_listed
from hbtp.planning.regression import stuck

log = logging.getLogger(__name__)

#: Symbols that name no object when written in an instruction (the agent itself, plain words).
NOT_OBJECTS = STOPWORDS | {"self", "nothing", "off", "robot"}


@dataclass(frozen=True)
class InstructOptions:
    """How the goal of an instruction is asked for."""

    rounds: int = 3  # feedback rounds after the first answer
    examples: int = 8  # demonstrations in the prompt
    constrain: bool = True  # constrained decoding (grammar / JSON schema)
    seed: int = 0
    cover: bool = True  # extend a completion model's goal to the objects the instruction names
    #: Drop a taught model's literals about objects the instruction does not name (when it names
    #: those of other literals of the same conjunction): :func:`unsaid_dropped`; and its literals
    #: about the robot itself that the instruction does not say (beside literals about the world):
    #: :func:`hbtp.pipeline.own_state.unasked_own_dropped`; and its literals of a kind of fact the
    #: instruction never speaks of that name nothing new: :func:`hbtp.pipeline.unspoken.unspoken_dropped`
    #: (one about a thing listed with another's first takes its kind: :func:`~hbtp.pipeline.unspoken.unspoken_listed`;
    #: a kind its clause never says, the one it says: :func:`~hbtp.pipeline.unspoken.kind_as_said`;
    #: a literal about two things never named together, what is said of them:
    #: :func:`hbtp.pipeline.apart.apart_mended`).
    drop_unsaid: bool = True
    #: Turn a taught model's positive literal into its negation where the instruction says it negated
    #: ("never turn the temperature down"): :func:`hbtp.pipeline.polarity.negations_mended`; and add
    #: the negation of a literal it says undone ("leave the bar"): :func:`hbtp.pipeline.undone.undone_added`.
    mend_negations: bool = True
    #: Put an object the instruction names and a taught model's goal leaves out in the place of one
    #: it never names ("Bright table 6 ..." read as ``On_MilkDrink_Table1``):
    #: :func:`hbtp.pipeline.stand_ins.named_in_place`; and read a thing said short or by a part as
    #: the thing meant ("the cabinet door"): :func:`hbtp.pipeline.referents.referents_read`.
    place_named: bool = True
    #: Group a taught model's alternatives as the instruction joins their objects ("the juice or a
    #: soft drink" read with ``&``): :func:`hbtp.pipeline.grouping.regrouped`; and take its choices of
    #: several literals from the sides of the instruction's "or": :func:`hbtp.pipeline.sides.sides_as_said`.
    group_as_said: bool = True
    #: Refuse a goal that puts an object the instruction never names in the place of a thing it names
    #: that the world lacks (:func:`substituted`), or drops a thing the world lacks that the
    #: instruction asks about (:func:`hbtp.pipeline.strangers.asked_about`).
    refuse_lacking: bool = True


@dataclass(frozen=True)
class GoalAttempt:
    """One answer of the model and what the checks said of it."""

    round: int
    reply: str
    goal: str
    objections: tuple[str, ...]
    doubtful: bool  # only objection: the goal holds in s0
    seconds: float

    @property
    def accepted(self) -> bool:
        return not self.objections

    def to_dict(self) -> dict[str, Any]:
        return {
            "round": self.round,
            "reply": self.reply,
            "goal": self.goal,
            "objections": list(self.objections),
            "seconds": round(self.seconds, 6),
        }


@dataclass(frozen=True)
class GoalChoice:
    """The goal chosen for an instruction (``None`` when every proposal was refused), with the attempts."""

    instruction: str
    goal: str | None
    attempts: tuple[GoalAttempt, ...] = ()
    llm_seconds: float = 0.0
    message: str = ""
    #: The goal the instruction asks for when it was refused for already holding at the start.
    holding: str | None = None
    #: What the instruction names that the world lacks, when it was refused for that.
    lacking: str | None = None

    def to_dict(self) -> dict[str, Any]:
        return {
            "instruction": self.instruction,
            "goal": self.goal,
            "holding": self.holding,
            "lacking": self.lacking,
            "rounds": len(self.attempts),
            "llm_s": round(self.llm_seconds, 6),
            "message": self.message,
            "attempts": [a.to_dict() for a in self.attempts],
        }


@dataclass(frozen=True)
class Verdict:
    """The checks of one proposed goal."""

    objections: tuple[str, ...] = ()
    doubtful: bool = False
    never: tuple[Atom, ...] = field(default=())
    #: A taught model's refusal that stands (the instruction names what the world lacks).
    refused: bool = False


def check_goal(scenario: Scenario, text: str) -> Verdict:
    """The objections to ``text`` as the goal of ``scenario`` (see the module docstring)."""
    try:
        extended, goal = scenario.resolve_goal(text)
    except InputError as error:
        return Verdict((f"not a goal: {error}",))
    if goal.unsolvable is not None:
        objections = [f"{format_goal((term,))} asks for a literal and its negation" for term in goal.contradictory]
        if goal.unreachable:
            objections.append("never true: " + ", ".join(a.underscored for a in goal.unreachable))
        contradicting = tuple(a for term in goal.contradictory for a in term if a.negated and a.positive in term)
        return Verdict(tuple(objections), never=(*goal.unreachable, *contradicting))
    proved = extended.mutexes.proved_only()
    clashes = [proved.conflict(d) for d in goal.reachable]
    if all(clash is not None for clash in clashes):
        first = next(clash for clash in clashes if clash is not None)
        names = " and ".join(a.underscored for a in (extended.task.atoms[i] for i in sorted(first)))
        return Verdict((f"{names} cannot hold together",))
    if goal.holds(extended.task.initial_state):
        return Verdict(("it already holds at the start",), doubtful=True)
    live = [d for d, clash in zip(goal.reachable, clashes, strict=True) if clash is None]
    if all(stuck(extended.task, d, proved) for d in live):
        names = " and ".join(extended.task.atoms[i].underscored for i in sorted(live[0]))
        return Verdict((f"no plan makes {names} hold together",))
    return Verdict()


def instruction_pool(scenario: Scenario, exclude: frozenset[str] = frozenset()) -> list[Example]:
    """The demonstrations of a shipped scenario: each phrasing of each record of its instruction
    dataset, leaving out the records whose ids are in ``exclude``; none for other scenarios."""
    try:
        records = load_instructions(scenario.name)
    except InputError:
        return []
    return [Example(text, r.goal) for r in records if r.id not in exclude for text in r.instructions]


def goal_from_instruction(
    scenario: Scenario,
    instruction: str,
    backend: Backend,
    pool: Sequence[Example] = (),
    options: InstructOptions = InstructOptions(),
    deadline: Deadline | None = None,
) -> GoalChoice:
    """Ask ``backend`` for the goal of ``instruction`` in ``scenario`` (see the module docstring), all
    of the asking by ``deadline``.

    Raises :class:`InputError` for an empty instruction or one about nothing the domain knows, and
    :class:`BackendError` when the model cannot be asked at all (:class:`BackendTimeLimit` when the
    time given was too short for even one answer).
    """
    text = " ".join(instruction.split())
    if not text:
        raise InputError("empty instruction")
    task = scenario.task
    # A taught model needs no demonstrations, and judges itself what the world lacks.
    taught = bool(getattr(backend, "taught", False))
    examples = [] if taught else similar_examples(text, pool, options.examples)
    if not taught and not _relevant(scenario, text, pool):
        return _unrelated(scenario, text, options)
    ask = partial(goal_request, task, text, examples, constrain=options.constrain, seed=options.seed, taught=taught)
    attempts: list[GoalAttempt] = []
    rejected: list[Rejected] = []
    spent = 0.0
    for number in range(options.rounds + 1):
        if expired(deadline):
            break
        request = replace(ask(rejected, round_number=number), deadline=deadline)
        try:
            reply = backend.complete(request)
        except BackendTimeLimit:
            if not attempts:
                raise
            log.info("instruction round %d: no time left to ask again", number)
            break
        spent += reply.seconds
        proposed = goal_reply(reply.text)
        lacking = refusal_of(proposed) if taught else None
        if taught and lacking is None:
            proposed = _read_against(scenario, text, proposed, options=options)
        verdict = _verdict(scenario, text, proposed, lacking)
        attempts.append(GoalAttempt(number, reply.text, "" if lacking else proposed, verdict.objections,
                                    verdict.doubtful, reply.seconds))  # fmt: skip
        log.info("instruction round %d: %r -> %s", number, proposed, "; ".join(verdict.objections) or "accepted")
        if lacking is not None and verdict.refused:
            return GoalChoice(text, None, tuple(attempts), spent, lacks(scenario, lacking), lacking=lacking)
        if not verdict.objections or verdict.doubtful:
            break
        rejected.append(Rejected(proposed or reply.text.strip()[:80], "; ".join(verdict.objections), verdict.never))
        if lacking is not None:  # a refusal overruled: refusals are not offered again
            ask = partial(ask, refusal=False)
    cover = options.cover and backend.prompt_style is PromptStyle.COMPLETION
    if cover and attempts and attempts[-1].accepted:
        read = partial(_read_against, scenario, text, options=options) if taught else None
        spent += _cover(scenario, text, backend, request, attempts, deadline, by_words=taught, read=read)
    return _refused_if_substituted(scenario, _choose(text, attempts, spent), options)


def _read_against(scenario: Scenario, text: str, proposed: str, *, options: InstructOptions) -> str:
    """A taught model's goal read against the words of its instruction: things said short or by a
    part read as the things meant (:func:`hbtp.pipeline.referents.referents_read`), objects it names
    put in the place of others (:func:`hbtp.pipeline.stand_ins.named_in_place`), literals about
    two things it never names together given what it says of them
    (:func:`hbtp.pipeline.apart.apart_mended`), literals about objects it
    does not name left out (:func:`unsaid_dropped`), those of a kind of fact it never speaks of given
    the kind of one about a thing listed with theirs (:func:`hbtp.pipeline.unspoken.unspoken_listed`),
    kinds their own clause never says given the one it says (:func:`hbtp.pipeline.unspoken.kind_as_said`)
    or, naming nothing new, left out (:func:`hbtp.pipeline.unspoken.unspoken_dropped`), literals it says negated negated
    (:func:`hbtp.pipeline.polarity.negations_mended`) and those it says undone added negated
    (:func:`hbtp.pipeline.undone.undone_added`), literals about the robot itself it does not
    ask for left out (:func:`hbtp.pipeline.own_state.unasked_own_dropped`), alternatives taken from
    the sides of its "or" (:func:`hbtp.pipeline.sides.sides_as_said`) and grouped as it joins their
    objects (:func:`hbtp.pipeline.grouping.regrouped`)."""
    if options.place_named:
        proposed = named_in_place(scenario, text, referents_read(scenario, text, proposed))
    if options.drop_unsaid:
        proposed = unsaid_dropped(scenario, text, proposed)
        proposed = apart_mended(scenario, text, kind_as_said(scenario, text, proposed))
        proposed = unspoken_listed(scenario, text, proposed)
        proposed = unspoken_dropped(scenario, text, proposed)
    if options.mend_negations:
        proposed = undone_added(scenario, text, negations_mended(scenario, text, proposed))
    if options.drop_unsaid:
        proposed = unasked_own_dropped(scenario, text, proposed)
    if options.group_as_said:
        proposed = regrouped(scenario, text, sides_as_said(scenario, text, proposed))
    return proposed


def _unrelated(scenario: Scenario, text: str, options: InstructOptions) -> GoalChoice:
    """The refusal of ``text``, which names no object of the world and is like no known instruction:
    for what it names that the world lacks ("the electric fan should be on"), as a taught model
    would refuse; raises :class:`InputError` when it names no such thing either."""
    strangers = " and ".join(words_for(scenario).lacking_in(text)) if options.refuse_lacking else ""
    if not strangers:
        raise InputError(f"the instruction {text[:80]!r} names no object of {scenario.name!r} and is like no known one")
    return GoalChoice(text, None, message=lacks(scenario, strangers), lacking=strangers)


def _refused_if_substituted(scenario: Scenario, choice: GoalChoice, options: InstructOptions) -> GoalChoice:
    """``choice`` refused when its goal stands in for a thing the instruction names and the world
    lacks, or when the instruction asks about such a thing (:mod:`hbtp.pipeline.strangers`); a
    choice refused for another reason (a goal that holds at the start, no acceptable answer) is
    refused for that thing instead, the reason that comes first."""
    if not options.refuse_lacking or choice.lacking is not None:
        return choice
    strangers = substituted(scenario, choice.instruction, choice.goal) if choice.goal is not None else ""
    strangers = strangers or " and ".join(asked_about(scenario, choice.instruction))
    if choice.goal is not None and not strangers:
        strangers = " and ".join(asked_beside(scenario, choice.instruction, parse_goal(choice.goal)))
    return replace(choice, goal=None, message=lacks(scenario, strangers), lacking=strangers) if strangers else choice


def substituted(scenario: Scenario, text: str, goal: str) -> str:
    """What ``text`` names that the world lacks (a noun of the words file said as a thing, "the
    guitar": :meth:`hbtp.domains.words.Words.lacking_in`), when ``goal`` puts an object the
    instruction never names in its place ("put the guitar on the desk" read as ``IsOn_chips_desk``:
    a model under a grammar answers with the world's objects); else ``""``. A thing the world lacks
    said beside what the goal is about ("shut the door" of the fridge, "for my cereal") is no reason."""
    words = words_for(scenario)
    strangers = words.lacking_in(text)
    if not strangers:
        return ""
    objects = {x for term in parse_goal(goal) for atom in term for x in objects_of(words, atom)}
    return " and ".join(strangers) if objects - spoken_objects(words, text) else ""


def lacks(scenario: Scenario, things: str) -> str:
    """The reason an instruction is refused for naming ``things`` the world lacks."""
    return f"the instruction names {things}, which {scenario.name!r} does not have"


def _verdict(scenario: Scenario, text: str, proposed: str, lacking: str | None) -> Verdict:
    """The checks' verdict on a proposed goal, or on a refusal of ``lacking`` (``refused`` when it
    stands; else its objection, :func:`false_refusal`)."""
    if lacking is not None:
        overruled = false_refusal(scenario, text, lacking)
        return Verdict((f"names {lacking}",), refused=True) if overruled is None else Verdict((overruled,))
    return check_goal(scenario, proposed) if proposed else Verdict(("no goal in the reply",))


def false_refusal(scenario: Scenario, text: str, lacking: str) -> str | None:
    """Why a taught model's refusal of ``lacking`` cannot stand, or ``None`` when it may: the
    instruction must say the thing (each of its words), and the world must have no object called so
    (a name of its words, :mod:`hbtp.domains.words`, or the last word of one: "bottle" for the
    condiment bottle)."""
    said = set(spoken_words(text))
    wanted = spoken_words(lacking)
    if not wanted or not set(wanted) <= said:
        return f"refused {lacking!r}, which the instruction does not say"
    for name, noun in sorted(words_for(scenario).objects.items()):
        for spoken in () if noun.agent else noun.names:
            words = spoken_words(spoken)
            if words and (wanted == words or wanted == words[-1:]):
                return f"refused {lacking!r}, which {scenario.name!r} has ({name})"
    return None


def unsaid_dropped(scenario: Scenario, text: str, goal: str) -> str:
    """``goal`` without the literals about an object the instruction does not name, in each
    conjunction that also has literals about objects it does name (by the world's words for them or
    their spelling, :meth:`hbtp.domains.words.Words.named_in`), and without the literals that repeat
    another of their conjunction but for one object, which the instruction does not name where the
    other's is named (:func:`hbtp.pipeline.clauses.has_twin`); an alternative about objects, none
    of whose literals is said so, goes when another is left ("a coffee or a water": ``Exists_Coffee |
    Exists_Water | ~On_Coffee_WaterStation``). A taught model that has written the
    literal asked for tends to go on with one more ("switch on the AC": ``Active_AC &
    IsClean_Chairs``; "wipe the fridge": ``IsClean_fridge & IsIn_rag_fridge``; "bring the juice to
    table 2": ``On_Juice_Table2 & On_Juice_Table1``). Where the instruction names a thing the world
    lacks, a literal is kept when it names one of its objects, and twins are kept: either may stand
    in for that thing ("put the bread and the pancake in the fridge": ``IsIn_breadslice_fridge &
    IsIn_chips_fridge``), which
    :func:`substituted` refuses. A literal with no object but the robot or a placeholder is kept; a
    goal that does not parse is returned as it is, for the checks to refuse."""
    terms = parsed(goal)
    if terms is None:
        return goal
    words = words_for(scenario)
    spoken = spoken_objects(words, text)
    strict = not words.lacking_in(text)
    kept, dropped = [], []
    for term in terms:
        said = [literal for literal in term if _said(objects_of(words, literal), spoken, strict)]
        said = [literal for literal in said if not (strict and has_twin(words, literal, term, spoken))]
        if any(objects_of(words, literal) for literal in said) and len(said) < len(term):
            dropped += [literal.underscored for literal in term if literal not in said]
            term = tuple(said)
        kept.append(term)
    unsaid = [term for term in kept if _unsaid(words, term, spoken, strict)]
    if unsaid and len(unsaid) < len(kept):
        dropped += [format_goal([term]) for term in unsaid]
        kept = [term for term in kept if term not in unsaid]
    if not dropped:
        return goal
    log.info("instruction: left out %s (about objects the instruction does not name)", ", ".join(dropped))
    return format_goal(kept)


def _unsaid(words: Words, term: Sequence[Atom], spoken: frozenset[str], strict: bool) -> bool:
    """Whether ``term`` is about objects and none of its literals is said by an instruction that
    names ``spoken``."""
    about = [objects_of(words, literal) for literal in term]
    return any(about) and not any(objects and _said(objects, spoken, strict) for objects in about)


def _said(about: set[str], spoken: frozenset[str], strict: bool) -> bool:
    """Whether a literal about the objects ``about`` is said by an instruction that names
    ``spoken``: all of them (``strict``) or one, or it is about no object."""
    return not about or (about <= spoken if strict else bool(about & spoken))


def _cover(
    scenario: Scenario,
    text: str,
    backend: Backend,
    request: Request,
    attempts: list[GoalAttempt],
    deadline: Deadline | None,
    by_words: bool = False,
    read: Callable[[str], str] | None = None,
) -> float:
    """Extend an accepted conjunction with a literal for each object the instruction names and the
    goal leaves out (a small model stops after the first literal, a taught one may skip one of a
    long list); a literal that draws an objection is left out. Objects are named by their spelling,
    and ``by_words`` (a taught model) also by the world's words for them; ``read`` reads each longer
    goal against the instruction as the model's first answer was (:func:`_read_against`: the
    continuation offers positive literals only, so one the instruction says negated is negated; a
    literal about the robot it does not ask for goes); a literal it leaves out is not added. With
    ``read``, the deeds the instruction asks for and the goal leaves out follow (:func:`_answer_deeds`).
    Returns the model's time."""
    terms = parse_goal(attempts[-1].goal)
    goal = format_goal(terms)  # "A | A" is one alternative: the literal joins all of it
    if len(terms) != 1 or not Connectives.licensed_by(text).conjunctions:
        return 0.0
    named, atoms = named_atoms(
        scenario.task, text, spoken_objects(words_for(scenario), text) if by_words else frozenset()
    )
    spent = 0.0
    for missing in sorted(named):
        literals = parse_goal(goal)[0]
        used = {arg for atom in literals for arg in atom.args}
        offered = [a for a in atoms if missing in a.args and a not in literals]
        if missing in used or not offered or expired(deadline):
            continue
        reply = _asked_more(scenario, backend, request, goal, offered)
        if reply is None:
            break
        spent += reply.seconds
        goal = _continued(scenario, goal, reply, read, attempts)
    if read is not None and attempts[-1].accepted:
        spent += _answer_deeds(scenario, text, backend, request, attempts, deadline, read)
    return spent


def _answer_deeds(
    scenario: Scenario,
    text: str,
    backend: Backend,
    request: Request,
    attempts: list[GoalAttempt],
    deadline: Deadline | None,
    read: Callable[[str], str],
) -> float:
    """Extend a taught model's accepted conjunction with a literal for each clause that asks for one
    it leaves out (:func:`hbtp.pipeline.deeds.unanswered`): the one the clause says, or the model's
    choice of several; read against the instruction and checked as :func:`_cover` does. Returns the
    model's time."""
    goal = attempts[-1].goal
    terms = parse_goal(goal)
    if len(terms) != 1:
        return 0.0
    spent = 0.0
    for offered in unanswered(scenario, text, terms[0]):
        offered = tuple(a for a in offered if a not in parse_goal(goal)[0])
        if not offered or expired(deadline):
            continue
        one = len(offered) == 1
        reply = (
            Reply(offered[0].underscored, seconds=0.0)
            if one
            else _asked_more(scenario, backend, request, goal, offered)
        )
        if reply is None:
            break
        spent += reply.seconds
        goal = _continued(scenario, goal, reply, read, attempts)
    return spent


def _asked_more(
    scenario: Scenario, backend: Backend, request: Request, goal: str, offered: Sequence[Atom]
) -> Reply | None:
    """The model's continuation of ``goal`` with one of ``offered``; ``None`` when its time is up."""
    try:
        return backend.complete(continuation_request(request, goal, offered, scenario.task.categories))
    except BackendTimeLimit:
        return None


def _continued(
    scenario: Scenario, goal: str, reply: Reply, read: Callable[[str], str] | None, attempts: list[GoalAttempt]
) -> str:
    """``goal`` and the literal of ``reply``, read with ``read`` and checked, recorded in ``attempts``;
    ``goal`` as it was when the longer goal draws an objection (or reads as ``goal``)."""
    literal = goal_reply(reply.text)
    longer = f"{goal} & {literal}" if literal else goal
    if literal and read is not None:
        longer = read(longer)
    if not literal or longer == goal:
        verdict = Verdict((f"{literal}: not what the instruction says" if literal else "no literal in the reply",))
    else:
        verdict = check_goal(scenario, longer)
    attempts.append(GoalAttempt(len(attempts), reply.text, longer, verdict.objections, verdict.doubtful, reply.seconds))
    return goal if verdict.objections else longer


def _relevant(scenario: Scenario, text: str, pool: Sequence[Example]) -> bool:
    """Whether the instruction names an object of the scenario or shares a content word with a known one."""
    if any(name.lower() not in NOT_OBJECTS for name in mentioned_objects(scenario.task, [text])):
        return True
    asked = content_words(text)
    return any(asked & content_words(example.instruction) for example in pool)


def _choose(text: str, attempts: Sequence[GoalAttempt], spent: float) -> GoalChoice:
    accepted = [a for a in attempts if a.accepted]
    if accepted:
        chosen = accepted[-1]  # the last accepted: the most complete
        goal = format_goal(parse_goal(chosen.goal))
        return GoalChoice(text, goal, tuple(attempts), spent)
    doubtful = [a for a in attempts if a.doubtful]
    if doubtful:
        holding = format_goal(parse_goal(doubtful[0].goal))
        message = f"the instruction asks for {holding}, which already holds at the start: there is nothing to do"
        return GoalChoice(text, None, tuple(attempts), spent, message, holding)
    reasons = "; ".join(dict.fromkeys(o for a in attempts for o in a.objections)) or "the model gave no answer in time"
    return GoalChoice(
        text, None, tuple(attempts), spent, f"no acceptable goal after {len(attempts)} answer(s): {reasons}"
    )


__all__ = [
    "GoalAttempt",
    "GoalChoice",
    "InstructOptions",
    "Verdict",
    "check_goal",
    "false_refusal",
    "goal_from_instruction",
    "instruction_pool",
    "substituted",
]
