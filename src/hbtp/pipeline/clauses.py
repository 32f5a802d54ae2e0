"""An instruction read as clauses of words, and the words that say a literal: what the checks of a
taught model's answer (:mod:`hbtp.pipeline.polarity`, :mod:`hbtp.pipeline.strangers`,
:mod:`hbtp.pipeline.own_state`) compare."""

from __future__ import annotations

import re
from collections.abc import Iterable, Sequence

from hbtp.domains.scenarios import Scenario
from hbtp.domains.words import COPULA, SLOT, Phrasing, Words, spoken_words
from hbtp.llm.goal_prompt import PLACEHOLDERS
from hbtp.logic.atoms import Atom

_PUNCTUATION = r"[,;:.!?()\u2014\u2013\"]| - "
_CLAUSES = re.compile(_PUNCTUATION + r"|\b(?:and|but|then|or|so|while)\b")
_SPANS = re.compile(_PUNCTUATION + r"|\b(?:but|then|so|while)\b")
_PARTS = re.compile(_PUNCTUATION)
#: A part that starts with "not" and one of these sets its things aside ("..., not the juice").
_ARTICLES = frozenset(("the", "a", "an", "any", "my", "your"))
_TOKEN = re.compile(r"[a-z0-9]+(?:'[a-z]+)?")
#: Words that only frame a state or a deed ("leave it on", "keep it shut"), left out of its words.
_FRAMES = frozenset(("don't", "do", "not", "never", "leave", "keep", "let", "be", "have", "want"))
#: Symbols named like particles ("on", "down") are not counted as named: in a clause they say a state.
_PARTICLES = frozenset(("on", "off", "up", "down", "in", "out"))
#: Words too plain to say a state or a deed on their own ("the tv is on", "bring it to the bar").
PLAIN = frozenset(("on", "in", "to", "at", "of", "up", "off", "into", "onto", "by", "with", "from", "for", "top"))
PRONOUNS = frozenset(("it", "them", "they"))
#: Words that may stand between two things listed ("the rug and the toaster"; articles and
#: punctuation are not words here, :func:`hbtp.domains.words.spoken_words`).
LISTING = frozenset(("and", "or", "both", "either"))
#: Words that ask for a state of what the rest of their sentence says ("make sure the X is on the Y",
#: "the X must be on the Y", "I'd like the X on the Y"): a thing there is wanted where it is placed.
_WANTED = (("make", "sure"), ("ensure",), ("see", "to", "it"), ("should",), ("must",), ("need", "to"),
           ("needs", "to"), ("has", "to"), ("have", "to"), ("ought", "to"), ("end", "up"), ("i", "want"),
           ("i'd", "like"), ("i", "would", "like"), ("i", "need"), ("we", "want"), ("we", "need"))  # fmt: skip
_SENTENCES = re.compile(r"[.!?;:]")
#: Words that negate, whatever they govern.
_NEGATING = frozenset(("not", "no", "never", "nothing", "without", "neither", "nor", "none", "nobody", "nowhere"))


def clauses(text: str) -> list[tuple[str, ...]]:
    """The clauses of ``text`` (cut at punctuation and at "and", "but", "then", "or", "so",
    "while"), each as its lower-case words, apostrophes kept ("don't"); empty ones left out."""
    cut = (tokens(part) for part in _CLAUSES.split(text) if part)
    return [said for said in cut if said]


def negating(said: Iterable[str]) -> bool:
    """Whether a word of ``said`` negates, whatever it governs (:data:`_NEGATING`, or ends in "n't")."""
    return any(word in _NEGATING or word.endswith("n't") for word in said)


def wanted(text: str) -> list[bool]:
    """For each clause of ``text`` (:func:`clauses`), whether words that ask for a state (``_WANTED``)
    stand in it or in a clause before it in its sentence."""
    found: list[bool] = []
    for sentence in _SENTENCES.split(text):
        asked = False
        for clause in clauses(sentence):
            asked = asked or any(_contains(clause, run) for run in _WANTED)
            found.append(asked)
    return found


def _contains(said: Sequence[str], run: tuple[str, ...]) -> bool:
    """Whether the words of ``run`` stand in ``said`` one after the other."""
    width = len(run)
    return any(tuple(said[at : at + width]) == run for at in range(len(said) - width + 1))


def spans(text: str) -> list[tuple[str, ...]]:
    """The clauses of ``text`` with their lists kept whole: cut at punctuation and at "but", "then",
    "so", "while", not at "and" or "or" ("pick up the cup and the plate" keeps its verb)."""
    cut = (tokens(part) for part in _SPANS.split(text) if part)
    return [said for said in cut if said]


def ends_naming(words: Words, said: Sequence[str]) -> str | None:
    """The thing whose name the words ``said`` end with, if they do."""
    text = " ".join(said)
    named = words.named_at(text)
    return named[-1][2] if named and sum(named[-1][:2]) == len(spoken_words(text)) else None


def starts_naming(words: Words, said: Sequence[str]) -> bool:
    """Whether the words ``said`` begin with a name of a thing (articles aside)."""
    named = words.named_at(" ".join(said))
    return bool(named) and named[0][0] == 0


def list_spans(words: Words, text: str) -> list[tuple[str, ...]]:
    """The :func:`spans` of ``text``, a list cut by commas kept whole too: a span after a comma that
    begins with a name of a thing joins the one before when that ends with one ("put the bread, the
    book and the glass on the desk")."""
    pieces = re.split(f"({_SPANS.pattern})", text)  # pieces and their cuts, one after the other
    joined: list[tuple[str, ...]] = []
    comma = False
    for at, part in enumerate(pieces):
        said = tokens(part or "") if at % 2 == 0 else ()
        if at % 2:
            comma = comma or part == ","
        elif said and comma and joined and ends_naming(words, joined[-1]) is not None and starts_naming(words, said):
            joined[-1] += said
            comma = False
        elif said:
            joined.append(said)
            comma = False
    return joined


def readings(named: frozenset[str], said: Sequence[str], before: frozenset[str]) -> list[frozenset[str]]:
    """The objects words that name ``named`` may be about: those, and, when they say "it" or "them",
    those and one of ``before`` (named in the last clause that named any)."""
    if not PRONOUNS & set(said):
        return [named]
    return [named, *(named | {one} for one in sorted(before))]


def tokens(text: str) -> tuple[str, ...]:
    """The lower-case words of ``text``, apostrophes kept ("don't")."""
    return tuple(_TOKEN.findall(text.lower().replace("\u2019", "'")))


def phrasing_runs(phrasing: Phrasing) -> list[tuple[str, ...]]:
    """The words that say a literal of ``phrasing`` without its objects: each state's complement
    ("switched on"), each deed ("turn on"), each unwanted deed ("leave on") and each of those heard
    of some objects only ("run", "running"), framing words aside."""
    texts = [*phrasing.say, *phrasing.deny]
    for state in (*phrasing.state, *phrasing.heard):
        match = COPULA.match(state)
        texts.append(match.group(3) if match else state)
    runs = [tuple(w for w in tokens(SLOT.sub(" ", text)) if w not in _FRAMES) for text in texts]
    return list(dict.fromkeys(run for run in runs if run))


def says(words: Words, literal: Atom, said: Iterable[str]) -> bool:
    """Whether the words ``said`` hold, in order, a run of words of ``literal``'s phrasing
    (:func:`phrasing_runs`)."""
    return any(in_order(run, said) for run in phrasing_runs(words.phrasing(literal)))


def in_order(run: tuple[str, ...], said: Iterable[str]) -> bool:
    """Whether the words of ``run`` come in ``said`` in this order (others may stand between)."""
    rest = iter(said)
    return bool(run) and all(word in rest for word in run)


def world_objects(scenario: Scenario) -> frozenset[str]:
    """The world's objects and constants that a clause can name (those named like particles aside:
    a café world's ``On`` and ``Down`` are states said, not things)."""
    return frozenset(name for name in scenario.task.symbols if name.lower() not in _PARTICLES)


def objects_of(words: Words, literal: Atom) -> set[str]:
    """The objects ``literal`` is about: its arguments but the robot and placeholders."""
    return {x for x in literal.args if x.lower() not in PLACEHOLDERS and not words.noun(x).agent}


def spoken_objects(words: Words, text: str) -> frozenset[str]:
    """The objects ``text`` calls by one of the world's ``words`` for them or spells (the robot and
    placeholders aside), but those it names only to set them aside: in a part between punctuation
    that starts with "not" and an article ("the plain milk, not the AD milk or the milk drink")."""
    named: set[str] = set()
    aside: set[str] = set()
    for part in _PARTS.split(text):
        said = tokens(part)
        (aside if said[:1] == ("not",) and said[1:2] and said[1] in _ARTICLES else named).update(words.named_in(part))
    return frozenset(name for name in named | (words.named_in(text) - aside) if name.lower() not in PLACEHOLDERS)


def twin_at(literal: Atom, other: Atom) -> int | None:
    """The one place where ``other`` is ``literal`` but for its argument (same predicate, sign and
    arity, every other argument the same), or ``None``."""
    if (literal.predicate, literal.negated, len(literal.args)) != (other.predicate, other.negated, len(other.args)):
        return None
    differ = [at for at, (x, y) in enumerate(zip(literal.args, other.args, strict=True)) if x != y]
    return differ[0] if len(differ) == 1 else None


def has_twin(words: Words, literal: Atom, term: Sequence[Atom], spoken: frozenset[str]) -> bool:
    """Whether another literal of ``term`` is ``literal`` but for one argument (:func:`twin_at`),
    which ``spoken`` holds there and not in ``literal`` (``On_Juice_Table1`` beside
    ``On_Juice_Table2``, table 2 named)."""
    about = objects_of(words, literal)
    for other in term:
        at = twin_at(literal, other)
        if at is not None and literal.args[at] in about - spoken and other.args[at] in spoken:
            return True
    return False
