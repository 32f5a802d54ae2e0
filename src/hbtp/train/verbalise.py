"""Goals written as English instructions: training data for the instruction -> goal task.

A taught model learns to turn a person's instruction ("put the milk in the fridge and close it")
into a goal in hbtp's syntax (``IsIn_milk_fridge & IsClose_fridge``). The goals come from the
planner (always solvable); :func:`verbalise` writes several different instructions for each.

What is said about a world lives in ``domains/data/words.toml`` (one home per fact): per predicate,
imperatives that make a literal true (``say``), the literal as a fact (``state``: "{0} is in {1}")
and negative imperatives for the negated literal (``deny``); per object, its names and synonyms.
Anything the file does not cover is derived from the PDDL name (``IsSwitchedOn`` -> "is switched
on", ``Table1`` -> "table 1", "table one", "the first table"), so any ``--pddl`` world gets
instructions. Only generic English glue lives here: the frames that turn a fact into "make sure
... is ...", "... should be ...", "I want ...", "could you ...", "either ... or ...".

A negated literal is always said as a negation ("don't leave the fridge open", "make sure the
fridge is not open"), never as the opposite predicate: ``~IsOpen_fridge`` is not ``IsClose_fridge``.
A pronoun stands only for the object named last in the clause before, so every instruction names
every object of its goal (the robot itself, the ``agent``, is "you").
"""

from __future__ import annotations

import functools
import logging
import random
import re
import tomllib
from collections.abc import Iterable, Mapping, Sequence
from dataclasses import dataclass, field
from importlib import resources
from typing import Any, NamedTuple

from hbtp.domains import Scenario
from hbtp.errors import InputError
from hbtp.logic.atoms import Atom
from hbtp.logic.goals import Term, parse_goal

log = logging.getLogger(__name__)

#: A negation in a phrasing of a negated literal (each ``deny`` template holds one).
NEGATION = re.compile(r"\b(?:not|never|no|nothing)\b|n't", re.IGNORECASE)
#: Candidate instructions drawn per instruction asked for before settling for fewer.
ATTEMPTS = 40

_COPULA = re.compile(r"^(.+?) (is|are) (.+)$")
_SLOT = re.compile(r"\{(S?)(\d)\}")
_WORD = re.compile(r"[A-Z]+(?=[A-Z][a-z])|[A-Z]?[a-z]+|[A-Z]+|[0-9]+")
_NUMBERED = re.compile(r"(.*?[A-Za-z])[_\-]?([0-9]+)")
_NUMBERS = ("zero", "one", "two", "three", "four", "five", "six", "seven", "eight", "nine", "ten", "eleven", "twelve",
            "thirteen", "fourteen", "fifteen", "sixteen", "seventeen", "eighteen", "nineteen", "twenty")  # fmt: skip
_ORDINALS = ("zeroth", "first", "second", "third", "fourth", "fifth", "sixth", "seventh", "eighth", "ninth", "tenth",
             "eleventh", "twelfth", "thirteenth", "fourteenth", "fifteenth", "sixteenth", "seventeenth", "eighteenth",
             "nineteenth", "twentieth")  # fmt: skip
_DETERMINERS = frozenset(("the", "a", "an", "my", "your", "our", "his", "her", "their", "this", "that", "these",
                          "those", "some"))  # fmt: skip

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


@dataclass(frozen=True)
class Phrasing:
    """How a literal is said: imperatives making it true (``say``), facts "SUBJECT is COMPLEMENT"
    (``state``, at least one) and negative imperatives for its negation (``deny``); ``{0}``, ``{1}``
    are the arguments. ``derived``: made up from the PDDL name, not read from the data."""

    say: tuple[str, ...]
    state: tuple[str, ...]
    deny: tuple[str, ...] = ()
    derived: bool = False

    def fits(self, arity: int) -> bool:
        """Whether every placeholder names one of ``arity`` arguments."""
        slots = [int(m.group(2)) for text in (*self.say, *self.state, *self.deny) for m in _SLOT.finditer(text)]
        return all(slot < arity for slot in slots)


@dataclass(frozen=True)
class ObjectEntry:
    """An object's entry in the data: bare names (no article), whether they are plural, whether they
    take "the", and whether the object is the robot itself (said "you", never checked as named)."""

    names: tuple[str, ...]
    plural: bool = False
    article: bool = True
    agent: bool = False


@dataclass(frozen=True)
class Noun:
    """An object as said in a sentence: noun phrases ("the fridge", "table 1"), first the display
    name, then synonyms; its number; whether it is the robot itself; whether it was derived."""

    names: tuple[str, ...]
    plural: bool = False
    agent: bool = False
    derived: bool = False


@dataclass(frozen=True)
class WordsData:
    """The words file read: phrasings per predicate and per ground literal (``Pred_a_b``, positive),
    object entries keyed by lower-case name."""

    predicates: Mapping[str, Phrasing]
    literals: Mapping[str, Phrasing]
    objects: Mapping[str, ObjectEntry]


@dataclass(frozen=True, eq=False)
class Words:
    """The phrasings and nouns of one world (see :func:`words_for`); names it does not know are
    derived on the fly."""

    predicates: Mapping[str, Phrasing]
    objects: Mapping[str, Noun]
    literals: Mapping[str, Phrasing] = field(default_factory=dict)
    data: WordsData | None = None

    def phrasing(self, atom: Atom) -> Phrasing:
        """How ``atom`` (either sign) is said: its literal's own phrasing, else its predicate's."""
        own = self.literals.get(atom.positive.underscored)
        if own is not None and own.fits(len(atom.args)):
            return own
        known = self.predicates.get(atom.predicate)
        if known is not None and known.fits(len(atom.args)):
            return known
        return phrasing_of(atom.predicate, len(atom.args), self.data)

    def noun(self, name: str) -> Noun:
        """How the object ``name`` is said."""
        return self.objects.get(name) or noun_of(name, self.data)


class InstructionExample(NamedTuple):
    """An instruction and the goal it asks for."""

    instruction: str
    goal: str


# ------------------------------------------------------------------ the data


def parse_words(raw: Mapping[str, Any], source: str = "words.toml") -> WordsData:
    """The words file's tables read and checked (:class:`InputError` naming the faulty entry)."""
    predicates = {name: _read_phrasing(f"{source}: predicates.{name}", value)
                  for name, value in _section(raw, "predicates", source).items()}  # fmt: skip
    literals = {name: _read_phrasing(f"{source}: literals.{name}", value)
                for name, value in _section(raw, "literals", source).items()}  # fmt: skip
    objects: dict[str, ObjectEntry] = {}
    for name, value in _section(raw, "objects", source).items():
        if name.lower() in objects:
            raise InputError(f"{source}: objects.{name}: listed twice (object names match case-insensitively)")
        objects[name.lower()] = _read_entry(f"{source}: objects.{name}", value)
    return WordsData(predicates, literals, objects)


@functools.lru_cache(maxsize=1)
def shipped_words() -> WordsData:
    """The shipped ``domains/data/words.toml``, read once."""
    text = resources.files("hbtp.domains").joinpath("data", "words.toml").read_text(encoding="utf-8")
    return parse_words(tomllib.loads(text))


def _section(raw: Mapping[str, Any], name: str, source: str) -> Mapping[str, Any]:
    """The table ``[name]`` of the file (empty when absent)."""
    value = raw.get(name, {})
    if not isinstance(value, dict):
        raise InputError(f"{source}: [{name}] must be a table")
    return value


def _strings(where: str, value: Any) -> tuple[str, ...]:
    """``value`` as a tuple of non-empty strings, stripped; :class:`InputError` naming ``where`` else."""
    if not isinstance(value, list) or not all(isinstance(item, str) and item.strip() for item in value):
        raise InputError(f"{where}: expected a list of non-empty strings")
    return tuple(item.strip() for item in value)


def _read_phrasing(where: str, value: Any) -> Phrasing:
    """A predicate's (or literal's) table, checked: facts are "SUBJECT is COMPLEMENT" (the glue
    frames need the copula) and every ``deny`` holds a negation (never the opposite predicate)."""
    if not isinstance(value, dict) or not set(value) <= {"say", "state", "deny"}:
        raise InputError(f"{where}: expected a table of say, state and deny")
    say, state, deny = (_strings(f"{where}.{key}", value.get(key, [])) for key in ("say", "state", "deny"))
    if not state:
        raise InputError(f'{where}: needs at least one state ("{{0}} is ...")')
    for text in state:
        if not _COPULA.match(text):
            raise InputError(f"{where}.state: {text!r} is not 'SUBJECT is COMPLEMENT'")
    for text in deny:
        if not NEGATION.search(text):
            raise InputError(f"{where}.deny: {text!r} holds no negation (not, n't, never, no)")
    return Phrasing(say, state, deny)


def _read_entry(where: str, value: Any) -> ObjectEntry:
    """An object's entry: a list of names, or a table of names and flags (article defaults to true)."""
    if isinstance(value, list):
        value = {"names": value}
    if not isinstance(value, dict) or not set(value) <= {"names", "plural", "article", "agent"}:
        raise InputError(f"{where}: expected a list of names or a table of names, plural, article and agent")
    names = _strings(f"{where}.names", value.get("names", []))
    flags = {key: value.get(key, key == "article") for key in ("plural", "article", "agent")}
    if not names or not all(isinstance(flag, bool) for flag in flags.values()):
        raise InputError(f"{where}: needs names, and plural/article/agent must be true or false")
    return ObjectEntry(names, flags["plural"], flags["article"], flags["agent"])


# ------------------------------------------------------------------ derived from the PDDL names


def split_name(name: str) -> list[str]:
    """The words of a PDDL name: ``IsSwitchedOn`` -> is, switched, on; ``NFCJuice`` -> NFC, juice;
    ``in-room_2`` -> in, room, 2 (acronyms keep their capitals; one run of lower case stays one word)."""
    pieces = [piece for chunk in re.split(r"[_\-\s]+", name) for piece in _WORD.findall(chunk)]
    return [piece if piece.isupper() and len(piece) > 1 else piece.lower() for piece in pieces]


def phrasing_of(predicate: str, arity: int, data: WordsData | None = None) -> Phrasing:
    """How ``predicate`` with ``arity`` arguments is said: the data's phrasing when it has one that
    fits, else one derived from the name ("{0} is switched on")."""
    known = (data or shipped_words()).predicates.get(predicate)
    if known is not None and known.fits(arity):
        return known
    words = split_name(predicate) or [predicate]
    verb_first = words[0] in ("is", "are") and len(words) > 1
    relation = " ".join(words[1:] if verb_first else words)
    if arity == 0:
        state = f"it is {relation}" if verb_first else relation if " is " in relation else f"{relation} is true"
    else:
        rest = " and ".join(f"{{{k}}}" for k in range(1, arity))
        state = f"{{0}} is {relation}" + (f" {rest}" if rest else "")
    return Phrasing((), (state,), (), derived=True)


def _with_article(name: str, article: bool) -> str:
    """``name`` as said in a sentence: "the fridge", but "table 1", "table one", "the first table"."""
    first, last = name.split()[0].lower(), name.split()[-1].lower()
    if not article or first in _DETERMINERS or last.isdigit() or last in _NUMBERS:
        return name
    return f"the {name}"


def _numbered(stems: Sequence[str], number: int) -> list[str]:
    """Names of the ``number``-th of a kind: "table 1", "table one", "the first table"."""
    names: list[str] = []
    for stem in stems:
        names.append(f"{stem} {number}")
        if number < len(_NUMBERS):
            names += [f"{stem} {_NUMBERS[number]}", f"the {_ORDINALS[number]} {stem}"]
    return list(dict.fromkeys(names))


def noun_of(name: str, data: WordsData | None = None) -> Noun:
    """How the object ``name`` is said: its data entry; for a numbered object without one (``Table1``)
    its stem's entry (``Table``) with the number; else names derived from ``name``."""
    objects = (data or shipped_words()).objects
    entry = objects.get(name.lower())
    if entry is not None:
        names = tuple(_with_article(bare, entry.article) for bare in entry.names)
        return Noun(tuple(dict.fromkeys(names)), entry.plural, entry.agent)
    match = _NUMBERED.fullmatch(name)
    if match:
        stem = objects.get(match.group(1).lower())
        stems = stem.names if stem is not None else (" ".join(split_name(match.group(1))),)
        return Noun(tuple(_numbered(stems, int(match.group(2)))), derived=stem is None)
    return Noun((_with_article(" ".join(split_name(name)) or name, True),), derived=True)


def words_from(predicates: Mapping[str, int], objects: Iterable[str], data: WordsData | None = None) -> Words:
    """The words of a world with these predicates (name -> arity) and objects."""
    data = data or shipped_words()
    return Words(
        {name: phrasing_of(name, arity, data) for name, arity in predicates.items()},
        {name: noun_of(name, data) for name in objects},
        dict(data.literals),
        data,
    )


def words_for(scenario: Scenario) -> Words:
    """The words of ``scenario``: every predicate, object and constant of its task, from the shipped
    data where it has them, else derived from the PDDL names."""
    task = scenario.task
    return words_from(task.predicates, (*task.objects, *task.constants))


# ------------------------------------------------------------------ the forms of a literal


@dataclass
class _Forms:
    """The ways one literal can be said, by kind: the data's own, and the glue frames'."""

    data: dict[str, list[str]] = field(default_factory=lambda: {kind: [] for kind in _KINDS})
    glue: dict[str, list[str]] = field(default_factory=lambda: {kind: [] for kind in _KINDS})


def _forms(atom: Atom, words: Words) -> _Forms:
    """Every form of ``atom``; placeholders ``{k}`` (object case) and ``{Sk}`` (subject case)."""
    phrasing = words.phrasing(atom)
    forms = _Forms()
    if atom.negated:
        for text in phrasing.deny:
            forms.data[DONT if re.match(r"(don't|do not|never)\b", text) else DO].append(text)
    else:
        forms.data[DO].extend(phrasing.say)
    for text in phrasing.state:
        _state_forms(text, atom, words, forms.glue)
    return forms


def _state_forms(text: str, atom: Atom, words: Words, out: dict[str, list[str]]) -> None:
    """The glue frames around the fact ``text`` ("{0} is open"), with the verbs agreeing."""
    match = _COPULA.match(text)
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
    return f"{head}{',' if mode == 'oxford' and len(parts) > 2 else ''} and {last}"


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

    def __init__(self, words: Words, rng: random.Random) -> None:
        self.words = words
        self.rng = rng
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

        said = _SLOT.sub(slot, text)
        things = [name for name in named if not self.words.noun(name).agent]
        self.last = things[-1] if things else None
        return said

    def part(self, atom: Atom, kinds: Sequence[str]) -> tuple[str, str]:
        """``atom`` said as one of ``kinds`` (the data's own forms preferred), and the kind used."""
        forms = _forms(atom, self.words)
        usable = [kind for kind in kinds if forms.data[kind] or forms.glue[kind]]
        kind = self.rng.choice(usable)
        own, glue = forms.data[kind], forms.glue[kind]
        pool = own if own and (not glue or self.rng.random() < 0.7) else glue
        return self.fill(self.rng.choice(pool), atom.args), kind

    def conjunction(self, term: Term, style: str, top: bool) -> tuple[str, str]:
        """One disjunct, its literals in a random order, each said in ``style``; and its kind."""
        order = list(term)
        self.rng.shuffle(order)
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


def _key(text: str) -> str:
    """What two instructions must differ in to count as different: not case, spaces or the end mark."""
    return " ".join(text.lower().rstrip(".?!").split())


def verbalise(goal_text: str, words: Words, rng: random.Random, count: int) -> list[str]:
    """``count`` different instructions asking for the goal ``goal_text`` (hbtp's syntax: ``&``,
    ``|``, ``~`` over ``Pred_a_b`` literals), in varied styles: imperative, polite, the state wanted,
    "I want ...", mixed. Deterministic for ``rng``'s state. Fewer come back (logged) only when the
    goal's words cannot make ``count`` different ones within :data:`ATTEMPTS` tries each."""
    terms = parse_goal(goal_text)
    styles = list(_STYLES)
    rng.shuffle(styles)
    found: dict[str, str] = {}
    for attempt in range(max(0, count) * ATTEMPTS):
        if len(found) >= count:
            break
        text = _Speaker(words, rng).instruction(terms, styles[attempt % len(styles)])
        found.setdefault(_key(text), text)
    if len(found) < count:
        log.debug("%s: only %d different instructions of %d asked", goal_text, len(found), count)
    return list(found.values())


def instruction_examples(
    goals: Iterable[str], words: Words, rng: random.Random, per_goal: int = 3
) -> list[InstructionExample]:
    """(instruction, goal) pairs: ``per_goal`` instructions (:func:`verbalise`) for each goal text,
    the goal kept as given (sampled goals are already in the datasets' spelling)."""
    return [InstructionExample(text, goal.strip()) for goal in goals for text in verbalise(goal, words, rng, per_goal)]


__all__ = [
    "NEGATION",
    "InstructionExample",
    "Noun",
    "ObjectEntry",
    "Phrasing",
    "Words",
    "WordsData",
    "instruction_examples",
    "noun_of",
    "parse_words",
    "phrasing_of",
    "shipped_words",
    "split_name",
    "verbalise",
    "words_for",
    "words_from",
]
