"""Read hints out of an LLM reply or a dataset record, tolerating formatting noise; write hints as a reply.

Accepted headings (any case, with or without bullets, bold markers or numbering):
``Optimal Actions`` / ``Heuristic Path`` / ``Actions`` for p̂, ``Vital Action Predicates`` /
``Relevant Action Predicates`` / ``Action Predicates`` for Q̂, ``Vital Objects`` /
``Relevant Objects`` / ``Objects`` for Ô. Items may be separated by commas, semicolons or new
lines and written ``Walk(apple)``, ``Walk_apple``, ``[Walk_apple]``, ``"Walk_apple"`` or ``1. Walk_apple``.
"""

from __future__ import annotations

import re
from dataclasses import dataclass

from hbtp.datasets.records import Record
from hbtp.datasets.reply import format_reply
from hbtp.errors import InputError
from hbtp.logic.atoms import parse_atom
from hbtp.planning.hints import Hints, hints_from_names

_HEADINGS: tuple[tuple[str, str], ...] = (
    ("path", r"(?:optimal\s+actions?|heuristic\s+path|optimal\s+path|actions?|plan)"),
    ("predicates", r"(?:vital|relevant|key)?\s*action\s+predicates?"),
    ("objects", r"(?:vital|relevant|key)?\s*objects?"),
)
_HEADING = re.compile(
    r"^[\s>*#\-•\d.)]*+\**\s*(?P<name>"
    + "|".join(f"(?P<{key}>{pattern})" for key, pattern in _HEADINGS)
    + r")\s*+\**+\s*+[:：]\s*\**(?P<rest>.*)$",
    re.IGNORECASE,
)
_OTHER_KEY = re.compile(r"^[\s*#\-•]*[A-Za-z][A-Za-z _-]{0,40}\**\s*:")
_ITEM_SPLIT = re.compile(r"[,;\n]|\s{2,}|(?<=\))\s+(?=[A-Za-z])")
_STRIP = " \t\r\"'`[]{}*•-.>"


@dataclass(frozen=True)
class ParsedReply:
    """What was found in a reply: the hints and which sections were present."""

    hints: Hints
    found: frozenset[str]

    @property
    def complete(self) -> bool:
        return {"path", "predicates", "objects"} <= self.found


def _items(text: str) -> list[str]:
    items: list[str] = []
    for raw in _ITEM_SPLIT.split(text):
        item = re.sub(r"^\s*\d+[.)]\s*", "", raw).strip(_STRIP)
        item = re.sub(r"\s*\(\s*", "(", item)
        item = re.sub(r"\s*\)\s*", ")", item)
        item = re.sub(r"\s*,\s*", ",", item)
        if item and item.lower() not in ("none", "n/a", "-"):
            items.append(item)
    return items


def parse_reply(text: str) -> ParsedReply:
    """Find the three sections in ``text`` (a section may continue on the following lines)."""
    sections: dict[str, list[str]] = {}
    current: str | None = None
    for line in text.splitlines():
        match = _HEADING.match(line)
        if match:
            current = next(key for key, _ in _HEADINGS if match.group(key))
            if current in sections:
                current = None  # keep the first occurrence of a section; ignore repeats
                continue
            sections[current] = [match.group("rest")]
            continue
        if current is not None:
            if not line.strip() or _OTHER_KEY.match(line):
                current = None
                continue
            sections[current].append(line)
    # Items of a paren-form action contain commas: re-join "RightPut(apple" + "table)".
    found = {key: _rejoin(_items("\n".join(lines))) for key, lines in sections.items()}
    hints = hints_from_names(found.get("path", ()), found.get("predicates", ()), found.get("objects", ()))
    return ParsedReply(hints, frozenset(found))


def _rejoin(items: list[str]) -> list[str]:
    out: list[str] = []
    for item in items:
        if out and out[-1].count("(") > out[-1].count(")"):
            out[-1] = f"{out[-1]},{item}"
        else:
            out.append(item)
    return out


def hints_from_record(record: Record) -> Hints:
    """A dataset record's plan, vital predicates and objects as hints (the oracle of the benchmarks)."""
    return hints_from_names(record.optimal_actions, record.vital_predicates, record.vital_objects)


def underscored(name: str) -> str:
    """An action name in the datasets' spelling (``Walk(apple)`` -> ``Walk_apple``); unparsable names as they are."""
    try:
        return parse_atom(name).underscored
    except InputError:
        return name


def hints_reply(hints: Hints) -> str:
    """``hints`` as the reply block a perfect model would write (actions in the datasets' spelling)."""
    return format_reply(map(underscored, hints.path), hints.predicates, hints.objects)
