"""Asking a model for the goal an instruction means: the prompt, its grammar, reading the reply.

The prompt is few-shot in both shapes (:mod:`hbtp.llm.backend`): demonstrations ``Instruction: ...``
/ ``Goals: ...`` (the instruction dataset's records most similar to the instruction, by shared
words), then the instruction, ending in ``Goals:``. Feedback rounds add the goals already rejected,
each with its reason (LLM-OBTEA's blacklist), and sample at a higher temperature.

A model taught the world (:mod:`hbtp.train`) is asked the instruction alone
(:func:`taught_goal_prompt`), with every fluent literal and connective offered, and may refuse: an
instruction that names something the world lacks is answered ``Unknown: <what>``
(:func:`refusal_of`).

Constrained decoding: the reply is one goal in the infix syntax of :mod:`hbtp.logic.goals` made of
literals of the task (a GBNF grammar for llama.cpp; a JSON schema ``{"goal": ...}`` for
OpenAI-compatible servers). The literals offered are those whose objects the instruction names
(``kitchen table`` names ``kitchentable``, ``table 1`` names ``Table1``); when it names none, those
the demonstrations' goals name too; all of them when that leaves too few. Only the connectives the
instruction has words for are offered (``|`` for "or", ``~`` for "not", "don't"...).
"""

from __future__ import annotations

import json
import re
from collections.abc import Iterable, Sequence
from dataclasses import dataclass, replace

from hbtp.domains.words import spelled_at, spelling
from hbtp.llm.backend import Message, Request
from hbtp.llm.constrain import Constraint, NameRules, gbnf_literal
from hbtp.logic.atoms import Atom
from hbtp.logic.task import GroundTask

#: The most conjuncts per disjunct, and disjuncts, a constrained goal may have.
MAX_LITERALS = 6
MAX_TERMS = 3
#: Fewer offered literals than this and the grammar offers more (see :func:`offered_atoms`).
MIN_OFFERED = 2
#: Symbols that stand for no object a person names: the agent, "nothing" (an empty hand).
PLACEHOLDERS = frozenset({"self", "nothing", "anything", "anywhere"})

SYNTAX = (
    "Translate the instruction into a goal: literals Predicate_object_object joined by & (and), "
    "| (or, between alternatives) and ~ (not)."
)

_WORD = re.compile(r"[a-z0-9]+")

#: How a taught model begins a refusal: ``Unknown: <what the instruction names and the world lacks>``.
UNKNOWN = "Unknown:"
#: What may follow :data:`UNKNOWN` (a noun phrase of lower-case words).
_REFUSAL_GBNF = '"Unknown: " [a-z0-9] [a-z0-9 \'-]{0,39}'
_REFUSAL_REGEX = "Unknown: [a-z0-9][a-z0-9 '-]{0,39}"


def taught_goal_prompt(instruction: str) -> str:
    """The completion prompt a taught model is asked for the goal of ``instruction``, and trained on."""
    return f"Instruction: {' '.join(instruction.split())}\nGoals:"


def taught_goal_reply(goal: str) -> str:
    """What a taught model learns to answer :func:`taught_goal_prompt` with: the goal, then a blank line."""
    return f" {goal.strip()}\n\n"


def refusal_reply(what: str) -> str:
    """The taught answer to an instruction that names ``what``, which the world lacks."""
    return f" {UNKNOWN} {what}\n\n"


def refusal_of(reply: str) -> str | None:
    """What a refusal (:func:`refusal_reply`) says the world lacks; ``None`` when ``reply`` is not one."""
    text = reply.strip()
    if not text.startswith(UNKNOWN):
        return None
    return text.removeprefix(UNKNOWN).strip() or "something"


@dataclass(frozen=True)
class Example:
    """A demonstration: an instruction and its goal (the datasets' spelling)."""

    instruction: str
    goal: str


@dataclass(frozen=True)
class Rejected:
    """A goal the model proposed and the checks refused, with why; ``never`` are its literals that
    can never hold, or (negated) that contradict the rest (left out of the next round's grammar)."""

    goal: str
    reason: str
    never: tuple[Atom, ...] = ()


#: Words too common to tell instructions apart.
STOPWORDS = frozenset(
    [
        "a",
        "about",
        "an",
        "and",
        "any",
        "are",
        "at",
        "be",
        "but",
        "by",
        "can",
        "could",
        "do",
        "for",
        "from",
        "get",
        "go",
        "have",
        "i",
        "if",
        "in",
        "into",
        "is",
        "it",
        "its",
        "just",
        "me",
        "my",
        "of",
        "on",
        "one",
        "or",
        "please",
        "put",
        "so",
        "some",
        "that",
        "the",
        "them",
        "then",
        "there",
        "this",
        "to",
        "up",
        "want",
        "will",
        "with",
        "would",
        "you",
        "your",
    ]
)


def words(text: str) -> list[str]:
    """The lower-case words of a text."""
    return _WORD.findall(text.lower())


def content_words(text: str) -> frozenset[str]:
    """The words of a text that are not :data:`STOPWORDS`."""
    return frozenset(words(text)) - STOPWORDS


def similarity(left: frozenset[str], right: frozenset[str]) -> float:
    """The Jaccard similarity of two sets of words."""
    return len(left & right) / (len(left | right) or 1)


def similar_examples(instruction: str, pool: Sequence[Example], count: int) -> list[Example]:
    """The ``count`` examples whose instructions share the most content words with ``instruction``
    (ties: pool order), most similar last (nearest the question)."""
    asked = content_words(instruction)
    scores = [similarity(asked, content_words(example.instruction)) for example in pool]
    ranked = sorted(range(len(pool)), key=lambda i: (-scores[i], i))[:count]
    return [pool[i] for i in reversed(ranked)]


def object_positions(task: GroundTask, text: str) -> dict[str, int]:
    """The task's symbols that ``text`` names, with the word where each is first named: a run of up
    to three words that spells the symbol (case and spaces aside, a plural ``s`` aside), the longest
    run first ("kitchen cabinet" names ``kitchencabinet``, not ``cabinet``)."""
    spelled = {spelling(s): s for s in task.symbols}
    found: dict[str, int] = {}
    tokens = words(text)
    start = 0
    while start < len(tokens):
        runs = spelled_at(tokens, start, spelled)
        if runs:
            length, name = runs[0]
            found.setdefault(name, start)
            start += length
        else:
            start += 1
    return found


def mentioned_objects(task: GroundTask, texts: Iterable[str]) -> frozenset[str]:
    """The task's symbols that ``texts`` name (see :func:`object_positions`)."""
    return frozenset(name for text in texts for name in object_positions(task, text))


def nearest_pairs(atoms: Sequence[Atom], positions: dict[str, int]) -> list[Atom]:
    """``atoms`` without the two-object literals ``P(x,y)`` whose ``y`` is not the object the text
    names nearest after ``x`` among those any literal pairs with ``x`` (nearest before when none
    comes after): "put the plate on the nightstand and the book on the desk" pairs plate with
    nightstand, and book with desk."""
    partners: dict[str, set[str]] = {}
    for atom in atoms:
        if len(atom.args) == 2 and all(a in positions for a in atom.args):
            partners.setdefault(atom.args[0], set()).add(atom.args[1])
    chosen: dict[str, str] = {}
    for first, seconds in partners.items():
        after = [y for y in seconds if positions[y] > positions[first]]
        chosen[first] = min(after or seconds, key=lambda y: (abs(positions[y] - positions[first]), y))
    return [a for a in atoms if not (len(a.args) == 2 and a.args[0] in chosen) or chosen[a.args[0]] == a.args[1]]


def offered_atoms(
    task: GroundTask, instruction: str, examples: Sequence[Example], banned: Iterable[Atom] = ()
) -> list[Atom]:
    """The literals the grammar offers (see the module docstring), fluent and not ``banned``: those
    over the objects the instruction names (with the placeholders), else over the objects the
    demonstrations' goals name too, else every literal."""
    placeholders = _placeholders(task)
    excluded = set(banned)
    fluent = [a for a in _fluent_atoms(task) if a not in excluded]
    positions = object_positions(task, instruction)
    named = frozenset(positions) - placeholders
    demonstrated = mentioned_objects(task, [e.goal.replace("_", " ") for e in examples])
    for keep in (named, named | demonstrated):
        if not keep:
            continue
        narrowed = [a for a in fluent if all(arg in keep or arg in placeholders for arg in a.args)]
        if keep is named and not Connectives.licensed_by(instruction).alternatives:
            narrowed = nearest_pairs(narrowed, positions)
        if len(narrowed) >= MIN_OFFERED:
            return narrowed
    return fluent


@dataclass(frozen=True)
class Connectives:
    """Which connectives a goal may use besides ``&``: ``|`` and ``~`` only when the instruction
    has a word for them (a small model otherwise adds alternatives and negations of its own).

    With ``required``, a licensed connective must be used: two alternatives or more for "or"; for
    "not" (without "or"), each conjunction ends with a negated literal. A small model left free
    stops after the first literal, which is what the instruction asks for first."""

    alternatives: bool = True
    negations: bool = True
    required: bool = False
    conjunctions: bool = True

    @classmethod
    def licensed_by(cls, instruction: str, required: bool = False) -> Connectives:
        lowered = instruction.lower()
        found = (_OR_WORDS.search(lowered), _NOT_WORDS.search(lowered), _AND_WORDS.search(lowered))
        return cls(bool(found[0]), bool(found[1]), required, bool(found[2]))


_OR_WORDS = re.compile(r"\b(or|either|whichever|otherwise)\b")
_AND_WORDS = re.compile(r"\b(and|then|also|both|plus|too|as well)\b|[,;]")
_NOT_WORDS = re.compile(r"\b(not|no|never|without|nothing|stop)\b|n't|n’t")


def _atom_rule(atoms: Sequence[Atom], rules: NameRules) -> tuple[str, str]:
    """The GBNF alternatives and the regex of the names of ``atoms`` (``Pred_obj_obj``)."""
    by_predicate: dict[str, set[tuple[str, ...]]] = {}
    for atom in atoms:
        by_predicate.setdefault(atom.predicate, set()).add(atom.args)
    grammar, patterns = [], []
    for predicate in sorted(by_predicate):
        tail, tail_regex = rules.suffixes(frozenset(by_predicate[predicate]))
        grammar.append(gbnf_literal(predicate) + ("" if tail == '""' else f" {tail}"))
        patterns.append(re.escape(predicate) + tail_regex)
    return " | ".join(f"( {g} )" for g in grammar), "(?:" + "|".join(patterns) + ")"


def goal_constraint(
    atoms: Sequence[Atom],
    categories: dict[str, tuple[str, ...]],
    connectives: Connectives = Connectives(),
    not_negated: Iterable[Atom] = (),
    *,
    refusal: bool = False,
) -> Constraint:
    """The grammar and schema of a goal over ``atoms`` with the ``connectives`` allowed; the atoms
    of ``not_negated`` are never offered with ``~`` (a rejected contradiction); with ``refusal``,
    a refusal (:func:`refusal_reply`) instead of a goal."""
    rules = NameRules(categories)
    atom_rule, atom = _atom_rule(atoms, rules)
    kept = set(not_negated)
    negatable = [a for a in atoms if a not in kept]
    negation = connectives.negations and bool(negatable)
    natom_rule, natom = _atom_rule(negatable, rules) if negation else ("", "")
    alternatives = connectives.alternatives
    least = 1 if alternatives and connectives.required else 0
    ending = negation and connectives.required and not alternatives
    more_terms = f'(" | " term){{{least},{MAX_TERMS - 1}}} ' if alternatives else ""
    longest = MAX_LITERALS - 1 if connectives.conjunctions else 0
    term_rule = (
        f'term ::= (atom " & "){{0,{longest}}} "~" natom' if ending else f'term ::= lit (" & " lit){{0,{longest}}}'
    )
    body = f"( term {more_terms}| {_REFUSAL_GBNF} ) " if refusal else f"term {more_terms}"
    lines = [
        # The goal may end the way a demonstration does (a blank line: one token in Gemma's vocabulary).
        f'root ::= " " {body}( "\\n" "\\n"? )?',
        term_rule,
        'lit ::= atom | "~" natom' if negation else "lit ::= atom",
        f"atom ::= {atom_rule}",
        *([f"natom ::= {natom_rule}"] if negation else []),
        *(f"{name} ::= {body}" for name, body in rules.rules.items()),
    ]
    literal = f"(?:{atom}|~{natom})" if negation else atom
    repeat = "*" if connectives.conjunctions else "{0}"
    term = f"(?:{atom} & ){repeat}~{natom}" if ending else f"{literal}(?: & {literal}){repeat}"
    more = f"(?: \\| {term}){'+' if least else '*'}" if alternatives else ""
    pattern = f"(?:{term}{more}|{_REFUSAL_REGEX})" if refusal else f"{term}{more}"
    schema = {
        "type": "object",
        "properties": {"goal": {"type": "string", "pattern": f"^{pattern}$"}},
        "required": ["goal"],
        "additionalProperties": False,
    }
    return Constraint("\n".join(lines) + "\n", json.dumps(schema, sort_keys=True), "goal")


def goal_request(
    task: GroundTask,
    instruction: str,
    examples: Sequence[Example],
    rejected: Sequence[Rejected] = (),
    *,
    constrain: bool = True,
    round_number: int = 0,
    seed: int = 0,
    taught: bool = False,
    refusal: bool = True,
) -> Request:
    """The request asking for the goal of ``instruction`` (see the module docstring); ``taught``:
    of a model taught the world (the instruction alone, every literal offered, a refusal allowed
    unless ``refusal`` is false)."""
    if taught:
        return _taught_goal_request(task, instruction, rejected, constrain, round_number, seed, refusal)
    shots = "".join(f"Instruction: {e.instruction}\nGoals: {e.goal}\n\n" for e in examples)
    refused = "".join(f"Not: {r.goal} ({r.reason})\n" for r in rejected)
    completion = f"{SYNTAX}\n\n{shots}Instruction: {instruction.strip()}\n{refused}Goals:"
    messages = [Message("system", SYNTAX + " Answer with the goal only.")]
    for example in examples:
        messages += [Message("user", example.instruction), Message("assistant", example.goal)]
    feedback = "".join(f"\nNot {r.goal}: {r.reason}." for r in rejected)
    messages.append(Message("user", instruction.strip() + feedback))
    banned = [a for r in rejected for a in r.never if not a.negated]
    not_negated = [a.positive for r in rejected for a in r.never if a.negated]
    offered = offered_atoms(task, instruction, examples, banned)
    # The first answer must use the connectives the instruction has words for; after an objection
    # they are optional (the words may not have meant them: "I can't see").
    connectives = Connectives.licensed_by(instruction, required=not rejected)
    constraint = goal_constraint(offered, task.categories, connectives, not_negated) if constrain else None
    return Request(
        messages=tuple(messages),
        completion_prompt=completion,
        scenario=task.name,
        round=round_number,
        max_tokens=64,
        temperature=0.0 if round_number == 0 else 0.7,
        seed=seed + round_number,
        stop=("\n", "Instruction:"),
        constraint=constraint,
        instruction=instruction.strip(),
    )


def _taught_goal_request(
    task: GroundTask,
    instruction: str,
    rejected: Sequence[Rejected],
    constrain: bool,
    round_number: int,
    seed: int,
    refusal: bool = True,
) -> Request:
    """The request of a taught model: its prompt is the instruction alone (the feedback of a
    rejected answer is the grammar, without the literals that can never hold, and sampling)."""
    banned = {a for r in rejected for a in r.never if not a.negated}
    not_negated = [a.positive for r in rejected for a in r.never if a.negated]
    offered = [a for a in _fluent_atoms(task) if a not in banned]
    constraint = (
        goal_constraint(offered, task.categories, Connectives(), not_negated, refusal=refusal) if constrain else None
    )
    text = " ".join(instruction.split())
    return Request(
        messages=(Message("system", SYNTAX + " Answer with the goal only."), Message("user", text)),
        completion_prompt=taught_goal_prompt(text),
        scenario=task.name,
        round=round_number,
        max_tokens=64,
        temperature=0.0 if round_number == 0 else 0.7,
        seed=seed + round_number,
        stop=("\n", "Instruction:"),
        constraint=constraint,
        instruction=text,
        taught=True,
    )


def named_atoms(
    task: GroundTask, instruction: str, also: frozenset[str] = frozenset()
) -> tuple[frozenset[str], list[Atom]]:
    """The objects the instruction names (placeholders aside; with ``also``, objects named
    otherwise) and the fluent atoms over them and the placeholders."""
    placeholders = _placeholders(task)
    named = (mentioned_objects(task, [instruction]) | also) - placeholders
    return named, [a for a in _fluent_atoms(task) if all(x in named or x in placeholders for x in a.args)]


def _placeholders(task: GroundTask) -> frozenset[str]:
    """The task's constants that stand for no object a person names (:data:`PLACEHOLDERS`)."""
    return frozenset(c for c in task.constants if c.lower() in PLACEHOLDERS)


def _fluent_atoms(task: GroundTask) -> list[Atom]:
    """The task's positive atoms of fluent predicates: what a goal literal can name."""
    return [a for a in task.atoms if not a.negated and a.predicate in task.predicates]


def continuation_request(
    request: Request, goal: str, atoms: Sequence[Atom], categories: dict[str, tuple[str, ...]]
) -> Request:
    """``request`` with its goal begun as ``goal &``, asking for one more literal among ``atoms``
    (a completion-style model's goal that leaves out an object the instruction names)."""
    rules = NameRules(categories)
    atom_rule, atom_regex = _atom_rule(atoms, rules)
    lines = [
        'root ::= " " atom ( "\\n" "\\n"? )?',
        f"atom ::= {atom_rule}",
        *(f"{name} ::= {body}" for name, body in rules.rules.items()),
    ]
    schema = {
        "type": "object",
        "properties": {"goal": {"type": "string", "pattern": f"^{atom_regex}$"}},
        "required": ["goal"],
        "additionalProperties": False,
    }
    constraint = Constraint("\n".join(lines) + "\n", json.dumps(schema, sort_keys=True), "goal")
    return replace(
        request,
        completion_prompt=f"{request.completion_prompt} {goal} &",
        messages=(*request.messages, Message("assistant", f"{goal} &")),
        constraint=constraint,
        temperature=0.0,
    )


def goal_reply(text: str) -> str:
    """The goal text of a reply: the JSON ``{"goal": ...}`` of a constrained server, or the first
    line of a text answer (without a leading ``Goals:``)."""
    stripped = text.strip()
    if stripped.startswith("{"):
        try:
            value = json.loads(stripped)
        except json.JSONDecodeError:
            value = None
        if isinstance(value, dict) and isinstance(value.get("goal"), str):
            return str(value["goal"]).strip()
    first = stripped.splitlines()[0] if stripped else ""
    return first.removeprefix("Goals:").strip()


__all__ = [
    "UNKNOWN",
    "Example",
    "Rejected",
    "continuation_request",
    "goal_constraint",
    "goal_reply",
    "goal_request",
    "mentioned_objects",
    "named_atoms",
    "nearest_pairs",
    "object_positions",
    "offered_atoms",
    "refusal_of",
    "refusal_reply",
    "similar_examples",
    "taught_goal_prompt",
    "taught_goal_reply",
]
