"""The words of a world: how its predicates and objects are said in English.

What is said about a world lives in ``domains/data/words.toml`` (one home per fact): per predicate,
imperatives that make a literal true (``say``), the literal as a fact (``state``: "{0} is in {1}")
and negative imperatives for the negated literal (``deny``); per object, its names and synonyms.
Anything the file does not cover is derived from the PDDL name (``IsSwitchedOn`` -> "is switched
on", ``Table1`` -> "table 1", "table one", "the first table"), so any ``--pddl`` world has words.
:mod:`hbtp.train.verbalise` says goals with them.
"""

from __future__ import annotations

import functools
import re
import tomllib
from collections.abc import Iterable, Mapping, Sequence
from dataclasses import dataclass, field
from importlib import resources
from typing import Any

from hbtp.domains.scenarios import Scenario
from hbtp.errors import InputError
from hbtp.logic.atoms import Atom

#: A negation in a phrasing of a negated literal (each ``deny`` template holds one).
NEGATION = re.compile(r"\b(?:not|never|no|nothing)\b|n't", re.IGNORECASE)
#: A fact: "SUBJECT is COMPLEMENT".
COPULA = re.compile(r"^(.+?) (is|are) (.+)$")
#: A placeholder of a phrasing: ``{k}`` (object case) or ``{Sk}`` (subject case) of argument k.
SLOT = re.compile(r"\{(S?)(\d)\}")
_WORD = re.compile(r"[A-Z]+(?=[A-Z][a-z])|[A-Z]?[a-z]+|[A-Z]+|[0-9]+")
_NUMBERED = re.compile(r"(.*?[A-Za-z])[_\-]?([0-9]+)")
_NUMBERS = ("zero", "one", "two", "three", "four", "five", "six", "seven", "eight", "nine", "ten", "eleven", "twelve",
            "thirteen", "fourteen", "fifteen", "sixteen", "seventeen", "eighteen", "nineteen", "twenty")  # fmt: skip
_ORDINALS = ("zeroth", "first", "second", "third", "fourth", "fifth", "sixth", "seventh", "eighth", "ninth", "tenth",
             "eleventh", "twelfth", "thirteenth", "fourteenth", "fifteenth", "sixteenth", "seventeenth", "eighteenth",
             "nineteenth", "twentieth")  # fmt: skip
_ALNUM = re.compile(r"[a-z0-9]+")
_DETERMINERS = frozenset(("the", "a", "an", "my", "your", "our", "his", "her", "their", "this", "that", "these",
                          "those", "some"))  # fmt: skip


@dataclass(frozen=True)
class Phrasing:
    """How a literal is said: imperatives making it true (``say``), facts "SUBJECT is COMPLEMENT"
    (``state``, at least one), negative imperatives for its negation (``deny``) and imperatives that
    make it false with no negation word, its one object last (``undo``: "leave {0}"); ``{0}``, ``{1}``
    are the arguments. ``heard``: deeds or facts that say it of some objects only ("run {0}" of a
    dishwasher, not of a candle), read in instructions and never written by the verbaliser.
    ``derived``: made up from the PDDL name, not read from the data."""

    say: tuple[str, ...]
    state: tuple[str, ...]
    deny: tuple[str, ...] = ()
    derived: bool = False
    undo: tuple[str, ...] = ()
    heard: tuple[str, ...] = ()

    def fits(self, arity: int) -> bool:
        """Whether every placeholder names one of ``arity`` arguments."""
        texts = (*self.say, *self.state, *self.deny, *self.undo, *self.heard)
        slots = [int(m.group(2)) for text in texts for m in SLOT.finditer(text)]
        return all(slot < arity for slot in slots)


@dataclass(frozen=True)
class ObjectEntry:
    """An object's entry in the data: bare names (no article), whether they are plural, whether they
    take "the", whether the object is the robot itself (said "you", never checked as named), and
    whether it is a part of other things ("the door" of a fridge: never a thing a world lacks)."""

    names: tuple[str, ...]
    plural: bool = False
    article: bool = True
    agent: bool = False
    part: bool = False


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

    def about_robot(self, atom: Atom) -> bool:
        """Whether ``atom`` is a fact about the robot itself: one of its arguments is the robot (an
        ``agent``), or it is said as a fact about "you" or "your ..." ("you are holding {0}": the
        robot is implicit in the predicate, as in a café world's ``Holding_Coffee``)."""
        if any(self.noun(arg).agent for arg in atom.args):
            return True
        subjects = (match.group(1).lower() for match in map(COPULA.match, self.phrasing(atom).state) if match)
        return any(subject == "you" or subject.startswith("your ") for subject in subjects)

    def named_in(self, text: str) -> frozenset[str]:
        """The objects (the robot aside) that ``text`` calls by one of their names or synonyms: the
        name's words, articles aside, in a row ("the AC" and "the air conditioner" name ``AC``; "tables
        1" names ``Table1``, a plural ``s`` or ``es`` aside), or spells it in up to three words ("kitchen
        cabinet" names ``kitchencabinet``); a numbered name goes on with a list of numbers ("tables 1
        and 2" names ``Table2`` too). The longest names are read first, and
        words read as one name are not read again as part of another ("the AD calcium milk" names
        ``ADMilk``, not ``Milk`` too)."""
        return frozenset(name for _, _, name in self.named_at(text))

    def named_at(self, text: str) -> tuple[tuple[int, int, str], ...]:
        """Where ``text`` names each object of :meth:`named_in`: (first word, words, object) over
        its :func:`spoken_words`, in the order said."""
        said = spoken_words(text)
        spoken = {
            words: name
            for name, noun in self.objects.items()
            if not noun.agent
            for words in {spoken_words(spoken) for spoken in noun.names}
        }
        found = [(start, len(words), name) for words, name in spoken.items() for start in _starts(words, said)]
        found += _listed(said, found, spoken, _breaks(text))
        spelled = {spelling(name): name for name, noun in self.objects.items() if not noun.agent}
        found += [
            (start, width, name) for start in range(len(said)) for width, name in spelled_at(said, start, spelled)
        ]
        taken: set[int] = set()
        named: list[tuple[int, int, str]] = []
        for start, width, name in sorted(found, key=lambda m: (-m[1], m[0], m[2])):
            span = set(range(start, start + width))
            if not span & taken:
                taken |= span
                named.append((start, width, name))
        return tuple(sorted(named))

    def foreign(self) -> list[str]:
        """Things of the words file (nouns said with "the") that this world lacks, and whose names
        share no word with the names of this world's objects (so a text naming one names nothing the
        world has), by key."""
        data = self.data
        if data is None:
            return []
        own = {name.lower() for name in self.objects}
        taken = {w for noun in self.objects.values() for name in noun.names for w in _ALNUM.findall(name.lower())}
        taken -= {"the", "a", "an", "your", "my"}
        foreign = []
        for key, entry in sorted(data.objects.items()):
            spoken = {w for name in entry.names for w in _ALNUM.findall(name.lower())}
            if key not in own and entry.article and not entry.agent and not spoken & taken:
                foreign.append(key)
        return foreign

    def parts(self) -> frozenset[str]:
        """The names of the words file's parts of things ("door"), lower case."""
        data = self.data
        if data is None:
            return frozenset()
        return frozenset(name.lower() for entry in data.objects.values() if entry.part for name in entry.names)

    def lacking_in(self, text: str) -> tuple[str, ...]:
        """The things of :meth:`foreign` that ``text`` names as things: one of their names (or its
        plural) right after a determiner ("bring me the guitar", "some lemons"; not "fan the
        flames"), each as said, in the order said."""
        data = self.data
        if data is None:
            return ()
        words = _ALNUM.findall(text.lower())
        found: list[tuple[int, str]] = []
        for key in self.foreign():
            for name in data.objects[key].names:
                run = tuple(_ALNUM.findall(name.lower()))
                for start in range(1, len(words) - len(run) + 1):
                    if words[start - 1] in _DETERMINERS and _says(words[start : start + len(run)], run):
                        found.append((start, " ".join(words[start : start + len(run)])))
        return tuple(dict.fromkeys(said for _, said in sorted(found)))


def _listed(
    said: tuple[str, ...],
    found: Sequence[tuple[int, int, str]],
    spoken: Mapping[tuple[str, ...], str],
    breaks: frozenset[int] = frozenset(),
) -> list[tuple[int, int, str]]:
    """The objects named by the numbers listed after a numbered name ("tables 1 and 2", "table one,
    two or three"): each number (one word) with the name's other words names an object of
    ``spoken`` (words -> object), as (where, 1, object); not a number that counts the object named
    next ("table 1 and 2 yogurts"), which no punctuation or determiner parts from it (the
    :func:`_breaks` of the text: "tables 1 and 2; a coffee" names table 2)."""
    listed = []
    starts = {start for start, _, _ in found}
    for start, width, _ in found:
        end = start + width
        if not is_number(said[end - 1]):
            continue
        stems = {words[:-1] for words in spoken if len(words) == width and _plural_run(said[start:end], words)}
        at = end
        while at < len(said) and (said[at] in ("and", "or") or is_number(said[at])):
            named = [spoken.get((*stem, said[at])) for stem in stems]
            if said[at] not in ("and", "or") and (not any(named) or (at + 1 in starts and at + 1 not in breaks)):
                break
            listed += [(at, 1, name) for name in named if name is not None]
            at += 1
    return listed


def _plural_run(said: Sequence[str], run: tuple[str, ...]) -> bool:
    """Whether the words ``said`` are ``run``, each maybe in the plural (``s`` or ``es`` added)."""
    if len(said) != len(run):
        return False
    return all(word in (name, name + "s", name + "es") for name, word in zip(run, said, strict=True))


def is_number(word: str) -> bool:
    """Whether ``word`` is a number, in digits or words up to twenty."""
    return word.isdigit() or word in _NUMBERS


def _says(words: Sequence[str], run: tuple[str, ...]) -> bool:
    """Whether ``words`` are the name ``run``, its last word maybe plural (``s`` or ``es``)."""
    if tuple(words[:-1]) != run[:-1]:
        return False
    last, said = run[-1], words[-1]
    return said in (last, last + "s", last + "es")


def _breaks(text: str) -> frozenset[int]:
    """The places in the :func:`spoken_words` of ``text`` that punctuation or a determiner left out
    comes before ("2; a coffee": the coffee's)."""
    breaks: set[int] = set()
    count = 0
    for token in re.findall(r"[a-z0-9]+|[^\sa-z0-9]", text.lower()):
        if token.isalnum() and token not in _DETERMINERS:
            count += 1
        elif token not in ("'", "-"):
            breaks.add(count)
    return frozenset(breaks)


def spoken_words(text: str) -> tuple[str, ...]:
    """The lower-case words of ``text``, determiners ("the", "a", "my", ...) left out."""
    return tuple(w for w in re.findall(r"[a-z0-9]+", text.lower()) if w not in _DETERMINERS)


def spelling(name: str) -> str:
    """How ``name`` is spelled when it is written in words: lower case, letters and digits only."""
    return re.sub(r"[^a-z0-9]", "", name.lower())


def spelled_at(words: Sequence[str], start: int, spelled: Mapping[str, str]) -> list[tuple[int, str]]:
    """The names whose :func:`spelling` (the keys of ``spelled``) the words from ``start`` spell in a
    run of up to three ("kitchen cabinet": ``kitchencabinet``), a plural ``s`` or ``es`` aside: each
    as (words in the run, name), the longest run first."""
    found = []
    for width in (3, 2, 1):
        if start + width > len(words):
            continue
        joined = "".join(words[start : start + width])
        forms = (joined, joined.removesuffix("s"), joined.removesuffix("es"))
        name = next((spelled[form] for form in forms if form in spelled), None)
        if name is not None:
            found.append((width, name))
    return found


def _starts(run: tuple[str, ...], words: tuple[str, ...]) -> list[int]:
    """Where ``run`` (not empty) occurs in ``words`` as consecutive words, each also in the plural
    (an ``s`` or ``es`` added)."""
    width = len(run)
    if not width:
        return []
    return [i for i in range(len(words) - width + 1) if _plural_run(words[i : i + width], run)]


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
    frames need the copula), every ``deny`` holds a negation (never the opposite predicate) and
    every ``undo`` none, with one placeholder, last; ``heard`` holds no negation."""
    keys = ("say", "state", "deny", "undo", "heard")
    if not isinstance(value, dict) or not set(value) <= set(keys):
        raise InputError(f"{where}: expected a table of say, state, deny, undo and heard")
    say, state, deny, undo, heard = (_strings(f"{where}.{key}", value.get(key, [])) for key in keys)
    if not state:
        raise InputError(f'{where}: needs at least one state ("{{0}} is ...")')
    for text in state:
        if not COPULA.match(text):
            raise InputError(f"{where}.state: {text!r} is not 'SUBJECT is COMPLEMENT'")
    for text in deny:
        if not NEGATION.search(text):
            raise InputError(f"{where}.deny: {text!r} holds no negation (not, n't, never, no)")
    for text in undo:
        slots = list(SLOT.finditer(text))
        if NEGATION.search(text) or len(slots) != 1 or text[slots[0].end() :].strip():
            raise InputError(f"{where}.undo: {text!r} must say a deed with no negation, its one object last")
    for text in heard:
        if NEGATION.search(text):
            raise InputError(f"{where}.heard: {text!r} holds a negation (it says the literal, not its negation)")
    return Phrasing(say, state, deny, undo=undo, heard=heard)


_FLAGS = ("plural", "article", "agent", "part")


def _read_entry(where: str, value: Any) -> ObjectEntry:
    """An object's entry: a list of names, or a table of names and flags (article defaults to true)."""
    if isinstance(value, list):
        value = {"names": value}
    if not isinstance(value, dict) or not set(value) <= {"names", *_FLAGS}:
        raise InputError(f"{where}: expected a list of names or a table of names, plural, article, agent and part")
    names = _strings(f"{where}.names", value.get("names", []))
    flags = {key: value.get(key, key == "article") for key in _FLAGS}
    if not names or not all(isinstance(flag, bool) for flag in flags.values()):
        raise InputError(f"{where}: needs names, and plural/article/agent/part must be true or false")
    return ObjectEntry(names, flags["plural"], flags["article"], flags["agent"], flags["part"])


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


__all__ = [
    "COPULA",
    "NEGATION",
    "SLOT",
    "Noun",
    "ObjectEntry",
    "Phrasing",
    "Words",
    "WordsData",
    "is_number",
    "noun_of",
    "parse_words",
    "phrasing_of",
    "shipped_words",
    "spelled_at",
    "spelling",
    "split_name",
    "spoken_words",
    "words_for",
    "words_from",
]
