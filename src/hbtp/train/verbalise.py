"""Goals written as English instructions: training data for the instruction -> goal task.

A taught model learns to turn a person's instruction ("put the milk in the fridge and close it")
into a goal in hbtp's syntax (``IsIn_milk_fridge & IsClose_fridge``). The goals come from the
planner (always solvable); :func:`verbalise` writes several different instructions for each.

The words of a world (how each predicate and object is said) come from :mod:`hbtp.domains.words`.
Only generic English glue lives here: the frames that turn a fact into "make sure ... is ...",
"... should be ...", "I want ...", "could you ...", "either ... or ...", and lists ("put the pear
and the apple on the table" for literals alike but for one argument).

A negated literal is always said as a negation ("don't leave the fridge open", "make sure the
fridge is not open"), never as the opposite predicate: ``~IsOpen_fridge`` is not ``IsClose_fridge``.
Where its atom does not hold at the start (the caller says which: ``absent``), it is also said as
the deed forbidden, "don't open the fridge": not doing it keeps the fridge shut.
A pronoun stands only for the object named last in the clause before, so every instruction names
every object of its goal (the robot itself, the ``agent``, is "you").
"""

from __future__ import annotations

import logging
import random
import re
from collections.abc import Collection, Iterable, Mapping, Sequence
from dataclasses import dataclass, field, replace
from typing import NamedTuple

from hbtp.domains.words import COPULA, SLOT, Noun, Words
from hbtp.logic.atoms import Atom
from hbtp.logic.goals import Term, format_goal, parse_goal

log = logging.getLogger(__name__)

#: Candidate instructions drawn per instruction asked for before settling for fewer.
ATTEMPTS = 40
#: How often literals alike but for one argument are said once, with a list (:func:`groups`).
GROUPED = 0.8


# What an instruction's pieces are, which decides the frames around them.
DO = "do"  # a positive imperative: "put the milk in the fridge" (takes "could you ...")
DONT = "dont"  # a negative imperative: "don't leave the tv on" (takes "please ...")
CLAUSE = "clause"  # a full clause: "the fridge should be closed"
SMALL = "small"  # a small clause after "I want": "the fridge closed"
INF = "inf"  # an infinitive clause after "I want": "the fridge to be closed"
_KINDS = (DO, DONT, CLAUSE, SMALL, INF)

# The frames a fact ``{s} {be} {c}`` is said in; {s}/{o}: the subject in subject/object case.
_POSITIVE: Mapping[str, tuple[str, ...]] = {
    DO: ("make sure {s} {be} {c}", "make sure that {s} {be} {c}", "ensure {s} {be} {c}", "see to it that {s} {be} {c}"),
    CLAUSE: ("{s} should be {c}", "{s} should end up {c}", "{s} must be {c}", "{s} {need} to be {c}",
             "{s} {have} to be {c}", "{s} ought to be {c}"),
    SMALL: ("{o} {c}",),
    INF: ("{o} to be {c}",),
}  # fmt: skip
_NEGATIVE: Mapping[str, tuple[str, ...]] = {
    DO: ("make sure {s} {be} not {c}", "make sure {s} {be}n't {c}", "ensure {s} {be} not {c}",
         "see to it that {s} {be} not {c}"),
    CLAUSE: ("{s} should not be {c}", "{s} shouldn't be {c}", "{s} must not be {c}", "{s} should not end up {c}",
             "{s} {be}n't supposed to be {c}", "I don't want {o} {c}"),
    SMALL: ("{o} not {c}",),
    INF: ("{o} not to be {c}",),
}  # fmt: skip
# Frames for an object subject only ("get the fridge open", not "get you near the sink").
_POSITIVE_THIRD: Mapping[str, tuple[str, ...]] = {DO: ("get {o} {c}",)}
_NEGATIVE_THIRD: Mapping[str, tuple[str, ...]] = {DONT: ("don't let {o} be {c}",)}
# A deed forbidden ({x}: one of the literal's ``say`` forms), for a literal whose atom is absent.
_FORBID: Mapping[str, tuple[str, ...]] = {
    DONT: ("don't {x}", "do not {x}", "never {x}"),
    DO: ("make sure not to {x}", "make sure you don't {x}", "be careful not to {x}", "take care not to {x}"),
}

_POLITE = ("could you {x}?", "can you {x}?", "would you {x}?", "will you {x}?", "please {x}", "{x}, please",
           "I'd like you to {x}", "I need you to {x}", "when you get a chance, {x}", "do me a favor and {x}",
           "if you could {x}, that would be great", "go ahead and {x}")  # fmt: skip
_PLEASE = ("please {x}", "{x}, please")
_AT_THE_END = ("by the time you're done, {x}", "when you're finished, {x}", "in the end, {x}", "at the end, {x}")
_WANT = ("I want {x}", "I'd like {x}", "I need {x}")
_WANT_TO_BE = (*_WANT, "the goal is for {x}", "what I want is for {x}")
# Alternatives; between conjunctions only the ones whose commas show where each alternative ends.
_EITHER_CLEAR = ("either {a}, or {b}", "{a}, or, if that's not possible, {b}", "{a}, or else {b}",
                 "{a}; or, if you can't, {b}")  # fmt: skip
_EITHER = (*_EITHER_CLEAR, "either {a} or {b}", "{a} or {b}", "{a} or, failing that, {b}",
           "{a} or {b}, whichever is easier")  # fmt: skip
_STYLES = ("do", "polite", "state", "want", "mixed")


class InstructionExample(NamedTuple):
    """An instruction and the goal it asks for."""

    instruction: str
    goal: str


# ------------------------------------------------------------------ the forms of a literal


@dataclass
class _Forms:
    """The ways one literal can be said, by kind: the data's own, and the glue frames'."""

    data: dict[str, list[str]] = field(default_factory=lambda: {kind: [] for kind in _KINDS})
    glue: dict[str, list[str]] = field(default_factory=lambda: {kind: [] for kind in _KINDS})


def _forms(atom: Atom, words: Words, absent: bool = False) -> _Forms:
    """Every form of ``atom``; placeholders ``{k}`` (object case) and ``{Sk}`` (subject case). A
    negated literal whose atom is ``absent`` at the start is also said as a deed forbidden."""
    phrasing = words.phrasing(atom)
    forms = _Forms()
    if atom.negated:
        for text in phrasing.deny:
            forms.data[DONT if re.match(r"(don't|do not|never)\b", text) else DO].append(text)
        for kind, frames in _FORBID.items() if absent else ():
            forms.data[kind].extend(frame.format(x=text) for frame in frames for text in phrasing.say)
    else:
        forms.data[DO].extend(phrasing.say)
    for text in phrasing.state:
        _state_forms(text, atom, words, forms.glue)
    return forms


def _state_forms(text: str, atom: Atom, words: Words, out: dict[str, list[str]]) -> None:
    """The glue frames around the fact ``text`` ("{0} is open"), with the verbs agreeing."""
    match = COPULA.match(text)
    if match is None:  # checked when read; a derived fact always matches
        return
    subject, copula, complement = match.groups()
    slot = re.fullmatch(r"\{(\d)\}", subject)
    noun = words.noun(atom.args[int(slot.group(1))]) if slot and int(slot.group(1)) < len(atom.args) else None
    plural = noun.plural if noun is not None else copula == "are"
    thing = noun is not None and not noun.agent
    values = {
        "s": f"{{S{slot.group(1)}}}" if slot else subject,
        "o": subject,
        "c": complement,
        "be": "are" if plural else "is",
        "need": "need" if plural else "needs",
        "have": "have" if plural else "has",
    }
    frames = [_NEGATIVE if atom.negated else _POSITIVE]
    if thing:
        frames.append(_NEGATIVE_THIRD if atom.negated else _POSITIVE_THIRD)
    for table in frames:
        for kind, texts in table.items():
            out[kind].extend(frame.format(**values) for frame in texts)


# ------------------------------------------------------------------ instructions


def _capital(text: str) -> str:
    """``text`` with its first letter capitalised (the rest kept: "TV" stays "TV")."""
    return text[:1].upper() + text[1:]


def _join(parts: Sequence[str], kinds: Sequence[str], rng: random.Random, top: bool) -> str:
    """Clauses joined as one conjunction: "A, B and C", "A, then B", "first A, then B", "A. B"."""
    if len(parts) == 1:
        return parts[0]
    modes = ["and", "oxford"]
    if all(kind == DO for kind in kinds):
        modes += ["then", "and then", "first"] if top else ["and then"]
    if top and all(kind in (DO, DONT, CLAUSE) for kind in kinds):
        mixed = CLAUSE in kinds and len(set(kinds)) > 1  # "put ..., the fridge should ... and close ..."
        modes = ["sentences"] if mixed and len(parts) > 2 else [*modes, *["sentences"] * (3 if mixed else 1)]
    mode = rng.choice(modes)
    head, last = ", ".join(parts[:-1]), parts[-1]
    if mode == "then":
        return ", then ".join(parts)
    if mode == "and then":
        return f"{head} and then {last}"
    if mode == "first":
        middle = ", then ".join(parts[1:-1])
        return f"first {parts[0]}, " + (f"then {middle}, and finally {last}" if middle else f"then {last}")
    if mode == "sentences":
        return ". ".join([parts[0], *map(_capital, parts[1:])])
    # "turn on the AC, but don't set it low": a deed forbidden after ones asked for
    but = kinds[-1] == DONT and DONT not in kinds[:-1] and rng.random() < 0.5
    return f"{head}{',' if (mode == 'oxford' and len(parts) > 2) or but else ''} {'but' if but else 'and'} {last}"


def _either(parts: Sequence[str], rng: random.Random, single: bool) -> str:
    """Alternatives joined: "either A or B", "A, or, if that's not possible, B", "A, B or C";
    alternatives of several literals (not ``single``) only with the commas that delimit them."""
    if len(parts) == 2:
        return rng.choice(_EITHER if single else _EITHER_CLEAR).format(a=parts[0], b=parts[1])
    head = ", ".join(parts[:-1])
    if not single:
        return rng.choice((f"either {head}, or {parts[-1]}", f"{', or '.join(parts)}"))
    return rng.choice((f"either {head} or {parts[-1]}", f"{head}, or {parts[-1]}", f"{head} or {parts[-1]}"))


def _whole_kind(kinds: Iterable[str]) -> str:
    """The kind of pieces joined: a clause if any is, else a negative imperative if any is."""
    found = set(kinds)
    for kind in (CLAUSE, SMALL, INF, DONT):
        if kind in found:
            return kind
    return DO


class _Speaker:
    """Writes one instruction: keeps the names chosen for its objects (one synonym each) and the
    object named last, for pronouns."""

    def __init__(self, words: Words, rng: random.Random, absent: Collection[Atom] = ()) -> None:
        self.words = words
        self.rng = rng
        self.absent = set(absent)
        self.chosen: dict[str, str] = {}
        self.last: str | None = None
        self.pronouns = True
        self.want = SMALL  # the small clause of the "want" style, one kind throughout

    def mention(self, name: str, subject: bool, again: bool) -> str:
        """The object ``name`` said here: a pronoun for the object named last before this clause
        (sometimes), else its name."""
        noun = self.words.noun(name)
        if noun.agent:
            return self.chosen.setdefault(name, self.rng.choice(noun.names))
        if self.pronouns and not again and name == self.last and self.rng.random() < 0.5:
            return ("they" if subject else "them") if noun.plural else "it"
        return self.chosen.setdefault(name, self.rng.choice(noun.names))

    def fill(self, text: str, args: Sequence[str]) -> str:
        """``text`` with its placeholders said; the last object named becomes :attr:`last`."""
        named: list[str] = []

        def slot(match: re.Match[str]) -> str:
            name = args[int(match.group(2))]
            said = self.mention(name, subject=bool(match.group(1)), again=name in named)
            named.append(name)
            return said

        said = SLOT.sub(slot, text)
        things = [name for name in named if not self.words.noun(name).agent]
        self.last = things[-1] if things else None
        return said

    def part(self, atom: Atom, kinds: Sequence[str]) -> tuple[str, str]:
        """``atom`` said as one of ``kinds`` (the data's own forms preferred), and the kind used."""
        forms = _forms(atom, self.words, atom.positive in self.absent)
        usable = [kind for kind in kinds if forms.data[kind] or forms.glue[kind]]
        kind = self.rng.choice(usable)
        own, glue = forms.data[kind], forms.glue[kind]
        pool = own if own and (not glue or self.rng.random() < 0.7) else glue
        return self.fill(self.rng.choice(pool), atom.args), kind

    def group(self, atoms: Sequence[Atom], position: int, alternatives: bool = False) -> Atom:
        """``atoms`` (alike but for the argument at ``position``) as one atom whose argument there is
        a made-up object said as their list: "the pear, the bananas and the apple"; for
        ``alternatives``, "the yogurt or the milk drink" (the verb agreeing with the last)."""
        key = f"\x00{len(self.words.objects)}"  # no object has such a name
        said = [self.mention(atom.args[position], subject=False, again=True) for atom in atoms]
        if alternatives:
            either = "either " if self.rng.random() < 0.3 else ""
            listed = f"{either}{', '.join(said[:-1])} or {said[-1]}"
            plural = self.words.noun(atoms[-1].args[position]).plural
        else:
            listed, plural = f"{', '.join(said[:-1])} and {said[-1]}", True
        self.words = replace(self.words, objects={**self.words.objects, key: Noun((listed,), plural=plural)})
        first = atoms[0]
        grouped = Atom(first.predicate, (*first.args[:position], key, *first.args[position + 1 :]), first.negated)
        if all(atom.positive in self.absent for atom in atoms):
            self.absent.add(grouped.positive)
        return grouped

    def conjunction(self, term: Term, style: str, top: bool) -> tuple[str, str]:
        """One disjunct, its literals in a random order, each said in ``style``; and its kind.
        Literals alike but for one argument are often said once, with that argument a list
        (:func:`groups`)."""
        order: list[Atom] = list(term)
        self.rng.shuffle(order)
        for atoms, position in groups(order, self.words):
            if self.rng.random() < GROUPED:
                at = order.index(atoms[0])
                order = [atom for atom in order if atom not in atoms]
                order.insert(at, self.group(atoms, position))
        if style == "want":
            kinds: tuple[str, ...] = (self.want,)
        else:
            kinds = {"do": (DO, DONT), "polite": (DO, DONT), "state": (CLAUSE,)}.get(style, (DO, DONT, CLAUSE))
        parts = [self.part(atom, kinds) for atom in order]
        used = [kind for _, kind in parts]
        return _join([text for text, _ in parts], used, self.rng, top), _whole_kind(used)

    def instruction(self, terms: Sequence[Term], style: str) -> str:
        """The whole instruction for the goal ``terms`` (its disjuncts) in ``style``."""
        order = list(terms)
        self.rng.shuffle(order)
        listed = alternatives(order, self.words)
        if listed is not None and self.rng.random() < GROUPED:  # "put the yogurt or the milk drink on table 3"
            order = [(self.group([term[0] for term in order], listed, alternatives=True),)]
        if style == "want":  # "I want the milk in the fridge and the fridge closed": no pronouns
            self.want = self.rng.choice((SMALL, INF))
            self.pronouns = False
        parts = [self.conjunction(term, style, top=len(order) == 1) for term in order]
        kinds = [kind for _, kind in parts]
        single = all(len(term) == 1 for term in terms)
        text = parts[0][0] if len(parts) == 1 else _either([text for text, _ in parts], self.rng, single)
        return self.sentence(text, _whole_kind(kinds), style)

    def sentence(self, text: str, kind: str, style: str) -> str:
        """``text`` in its sentence frame ("could you ...?", "I want ...", ...), finished."""
        frames: tuple[str, ...] = ("{x}",)
        if ". " in text:  # sentences of their own: no frame around them
            pass
        elif kind in (SMALL, INF):
            frames = _WANT if kind == SMALL else _WANT_TO_BE
        elif style == "polite":
            frames = _POLITE if kind == DO else _PLEASE if kind == DONT else frames
        elif kind == CLAUSE and style == "state" and self.rng.random() < 0.4:
            frames = _AT_THE_END
        frame = self.rng.choice(frames)
        question = frame.endswith("?")
        text = frame.replace("?", "").format(x=text) if question else frame.format(x=text)
        if ". " in text or self.rng.random() < 0.6:
            return _capital(text) + ("?" if question else ".")
        return text


def groups(atoms: Sequence[Atom], words: Words) -> list[tuple[list[Atom], int]]:
    """The literals of one conjunction that are alike but for one argument (same predicate, same sign,
    the same other arguments: ``IsOn_pear_table & IsOn_apple_table``), at least two, in their order,
    with that argument's position; each literal in at most one group, the robot itself never listed."""
    found: list[tuple[list[Atom], int]] = []
    used: set[Atom] = set()
    for position in range(max((len(atom.args) for atom in atoms), default=0)):
        alike: dict[tuple[object, ...], list[Atom]] = {}
        for atom in atoms:
            if atom in used or position >= len(atom.args) or words.noun(atom.args[position]).agent:
                continue
            rest = (atom.predicate, atom.negated, *atom.args[:position], *atom.args[position + 1 :])
            alike.setdefault(rest, []).append(atom)
        for members in alike.values():
            if len(members) > 1:
                found.append((members, position))
                used.update(members)
    return found


def alternatives(terms: Sequence[Term], words: Words) -> int | None:
    """The position of the one argument in which alternatives of one literal each differ (``On_Yogurt_Table3 |
    On_MilkDrink_Table3``: 0), said once with a list, "the yogurt or the milk drink"; ``None`` when
    they are not alike so (:func:`groups`)."""
    if len(terms) < 2 or any(len(term) != 1 for term in terms):
        return None
    found = groups([term[0] for term in terms], words)
    return found[0][1] if len(found) == 1 and len(found[0][0]) == len(terms) else None


def _key(text: str) -> str:
    """What two instructions must differ in to count as different: not case, spaces or the end mark."""
    return " ".join(text.lower().rstrip(".?!").split())


def verbalise(goal_text: str, words: Words, rng: random.Random, count: int, absent: Collection[Atom] = ()) -> list[str]:
    """``count`` different instructions asking for the goal ``goal_text`` (hbtp's syntax: ``&``,
    ``|``, ``~`` over ``Pred_a_b`` literals), in varied styles: imperative, polite, the state wanted,
    "I want ...", mixed. A negated literal whose atom is one of ``absent`` (it does not hold at the
    start) may be said as a deed forbidden ("don't open the fridge"). Deterministic for ``rng``'s
    state. Fewer come back (logged) only when the goal's words cannot make ``count`` different ones
    within :data:`ATTEMPTS` tries each."""
    terms = parse_goal(goal_text)
    styles = list(_STYLES)
    rng.shuffle(styles)
    found: dict[str, str] = {}
    for attempt in range(max(0, count) * ATTEMPTS):
        if len(found) >= count:
            break
        text = _Speaker(words, rng, absent).instruction(terms, styles[attempt % len(styles)])
        found.setdefault(_key(text), text)
    if len(found) < count:
        log.debug("%s: only %d different instructions of %d asked", goal_text, len(found), count)
    return list(found.values())


class Lacking(NamedTuple):
    """An instruction about a thing the world lacks, and that thing as it is said, bare ("sofa")."""

    instruction: str
    thing: str


def lacking_instruction(
    goal_text: str, constants: Collection[str], foreign: Sequence[str], words: Words, rng: random.Random
) -> Lacking | None:
    """An instruction asking for ``goal_text`` with one of its objects (not one of ``constants``)
    swapped for one of the ``foreign`` things (of the words file, the world lacks them): "put the
    sofa in the fridge" where there is no sofa. ``None`` when the goal has no such object or the
    words cannot say it. Deterministic for ``rng``'s state."""
    terms = parse_goal(goal_text)
    objects = sorted({arg for term in terms for atom in term for arg in atom.args} - set(constants))
    if not objects or not foreign:
        return None
    swapped, stranger = rng.choice(objects), rng.choice(foreign)

    def swap(atom: Atom) -> Atom:
        return Atom(atom.predicate, tuple(stranger if x == swapped else x for x in atom.args), atom.negated)

    goal = format_goal([tuple(swap(atom) for atom in term) for term in terms])
    # The stranger is said by one of its names, and the refusal repeats that name.
    noun = words.noun(stranger)
    name = rng.choice(noun.names)
    said = verbalise(goal, replace(words, objects={**words.objects, stranger: replace(noun, names=(name,))}), rng, 1)
    if not said:
        return None
    return Lacking(said[0], re.sub(r"^(?:the|a|an)\s+", "", name.lower()))


def instruction_examples(
    goals: Iterable[str], words: Words, rng: random.Random, per_goal: int = 3
) -> list[InstructionExample]:
    """(instruction, goal) pairs: ``per_goal`` instructions (:func:`verbalise`) for each goal text,
    the goal kept as given (sampled goals are already in the datasets' spelling)."""
    return [InstructionExample(text, goal.strip()) for goal in goals for text in verbalise(goal, words, rng, per_goal)]


__all__ = [
    "ATTEMPTS",
    "GROUPED",
    "InstructionExample",
    "Lacking",
    "alternatives",
    "groups",
    "instruction_examples",
    "lacking_instruction",
    "verbalise",
]
