"""The grammar checker of the paper's reflective feedback: names outside the domain are found,
repaired when the repair is unambiguous, and otherwise put on a blacklist for the model to avoid.

Every repair is recorded (``walk_apple`` -> ``Walk_apple``, ``RightPutIn_apple_fridg`` ->
``RightPutIn_apple_fridge``); nothing unknown ever reaches the planner.
"""

from __future__ import annotations

import difflib
from dataclasses import dataclass

from hbtp.datasets.reply import TITLES
from hbtp.errors import InputError
from hbtp.llm.parse import ParsedReply, underscored
from hbtp.llm.vocabulary import as_names
from hbtp.logic.atoms import Atom, parse_atom
from hbtp.logic.names import ActionNames
from hbtp.logic.tables import TaskTable
from hbtp.logic.task import GroundTask
from hbtp.planning.hints import Hints

CUTOFF = 0.85
AMBIGUITY = 0.15


@dataclass(frozen=True)
class GrammarCheck:
    """The checked hints, what was repaired, what is unknown, and which sections were missing."""

    hints: Hints
    repairs: tuple[str, ...]
    unknown: tuple[str, ...]
    missing_sections: tuple[str, ...]

    @property
    def problems(self) -> list[str]:
        found = [f"{name} is not in the domain" for name in self.unknown]
        found += [f"the '{section}' line is missing" for section in self.missing_sections]
        return found

    @property
    def clean(self) -> bool:
        return not self.unknown and not self.missing_sections


#: The reply's line titles, by hints field (the missing ones are named by these).
SECTION_TITLES = TITLES


class _Matcher:
    """Exact, case-insensitive, then unambiguous close matches against a set of names."""

    def __init__(self, names: frozenset[str]) -> None:
        self.names = names
        self.folded: dict[str, list[str]] = {}
        for name in names:
            self.folded.setdefault(name.lower(), []).append(name)
        self.ordered = sorted(names)
        self.memo: dict[str, str | None] = {}

    def match(self, name: str) -> str | None:
        if name not in self.memo:
            self.memo[name] = self._match(name)
        return self.memo[name]

    def _match(self, name: str) -> str | None:
        if name in self.names:
            return name
        folded = self.folded.get(name.lower())
        if folded is not None and len(folded) == 1:
            return folded[0]
        # A runner-up anywhere near the cutoff makes the best match ambiguous (pea: pear 0.857,
        # peach 0.750; cutlery: cutleryfork, cutleryknife), so look AMBIGUITY below it.
        close = difflib.get_close_matches(name, self.ordered, n=2, cutoff=CUTOFF - AMBIGUITY)
        if not close or difflib.SequenceMatcher(None, name, close[0]).ratio() < CUTOFF:
            return None
        return close[0] if len(close) == 1 else None


_MATCHERS: TaskTable[tuple[_Matcher, _Matcher]] = TaskTable("the predicate and object matchers")


def _matchers(names: ActionNames) -> tuple[_Matcher, _Matcher]:
    """The predicate and object matchers (kept with the names: their memos grow as names are met)."""

    def build() -> tuple[_Matcher, _Matcher]:
        return _Matcher(frozenset(names.action_predicates)), _Matcher(names.symbols)

    return _MATCHERS.of(names, build)


def _match_action(name: str, predicates: _Matcher, objects: _Matcher, actions: frozenset[Atom]) -> Atom | None:
    try:
        atom = parse_atom(name)
    except InputError:
        return None
    predicate = predicates.match(atom.predicate)
    args = [objects.match(arg) for arg in atom.args]
    if predicate is None or any(arg is None for arg in args):
        return None
    candidate = Atom(predicate, tuple(a for a in args if a is not None))
    return candidate if candidate in actions else None


def check_reply(parsed: ParsedReply, task: GroundTask | ActionNames, *, path_only: bool = False) -> GrammarCheck:
    """Check every name of a parsed reply against a task (or its action names).

    ``path_only``: the reply owes the path alone (a taught model's); the other lines are not missing.

    An action name is repaired part by part: its predicate and each object must match on their own
    (exactly, up to case, or as an unambiguous close match) and together name a grounded action, so
    a repair never swaps the verb or the object (``Put_apple`` is not taken for ``Cut_apple``).
    """
    names = as_names(task)
    predicates, objects = _matchers(names)
    repairs: list[str] = []
    unknown: list[str] = []

    def resolve(matcher: _Matcher, name: str) -> str | None:
        found = matcher.match(name)
        if found is None:
            unknown.append(name)
        elif found != name:
            repairs.append(f"{name} -> {found}")
        return found

    path: list[str] = []
    for name in parsed.hints.path:
        written = underscored(name)  # the datasets' spelling, as the model was asked to write it
        action = _match_action(name, predicates, objects, names.signatures)
        if action is None:
            unknown.append(written)
            continue
        if action.underscored != written:
            repairs.append(f"{written} -> {action.underscored}")
        path.append(str(action))
    kept_predicates = [p for p in (resolve(predicates, n) for n in parsed.hints.predicates) if p]
    kept_objects = [o for o in (resolve(objects, n) for n in parsed.hints.objects) if o]
    owed = ("path",) if path_only else tuple(TITLES)
    missing = tuple(TITLES[section] for section in owed if section not in parsed.found)
    hints = Hints(tuple(path), tuple(dict.fromkeys(kept_predicates)), tuple(dict.fromkeys(kept_objects)))
    return GrammarCheck(hints, tuple(repairs), tuple(dict.fromkeys(unknown)), missing)
