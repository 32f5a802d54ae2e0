"""Constrained decoding: the reply block as a grammar (GBNF) and as a JSON schema, from the task itself.

A constrained reply is exactly the three lines of :mod:`hbtp.datasets.reply` (heuristic path, vital
action predicates, vital objects), each list bounded in length and made only of names that exist.
An action is its predicate followed by objects, composed from shared rules rather than listed
whole: the grounded actions of a predicate form a trie over their objects, and a set of objects
that several branches share is one rule (named after its category when it is one). So a
predicate whose actions are every combination of its argument categories
(``RightPutIn_<GRABBABLE>_<CONTAINER>``) costs one rule per category, and one whose grounding is
sparser is still exact: the grammar admits the grounded action names and nothing else.

* :attr:`Constraint.gbnf` is llama.cpp's grammar (``grammar`` in a completion request, for the
  local model): it continues a prompt that ends in ``Optimal Actions:``, so it starts with a space
  and ends after the last object, where decoding stops.
* :attr:`Constraint.schema` is a JSON schema (``response_format`` of OpenAI-compatible servers):
  ``{"optimal_actions": [...], "vital_action_predicates": [...], "vital_objects": [...]}``, actions
  checked by a regular expression built from the same trie; :func:`reply_from_json` turns such an
  answer back into the three lines. Servers that ignore the schema answer in text, which the
  grammar checker reads as before.

A constraint only narrows what a reply can be; it is not part of :meth:`Request.key` (replay).
"""

from __future__ import annotations

import json
import re
from collections.abc import Iterable, Mapping
from dataclasses import dataclass
from typing import Any

from hbtp.datasets.reply import OBJECTS, PREDICATES, format_reply
from hbtp.llm.spelling import Spelling
from hbtp.llm.vocabulary import as_names
from hbtp.logic.atoms import Atom
from hbtp.logic.names import ActionNames
from hbtp.logic.tables import TaskTable
from hbtp.logic.task import GroundTask

#: The largest bounds of the three lists (the longest path of the shipped example pools has 17 actions).
MAX_ACTIONS = 16
MAX_PREDICATES = 8
MAX_OBJECTS = 8
#: Items a reply may have beyond the longest list of the demonstrations it was shown.
SLACK = 2

#: The JSON keys of the three lists, in the order of the block.
JSON_KEYS = ("optimal_actions", "vital_action_predicates", "vital_objects")


@dataclass(frozen=True)
class Bounds:
    """The most items each list of a reply may have."""

    actions: int = MAX_ACTIONS
    predicates: int = MAX_PREDICATES
    objects: int = MAX_OBJECTS

    @classmethod
    def after(cls, lists: Iterable[tuple[int, int, int]]) -> Bounds:
        """:data:`SLACK` more than the longest lists shown (the lengths of each demonstration's
        three lists), within the largest bounds; the largest bounds when nothing was shown.

        A greedy base model that starts repeating itself runs to the bound, so the bound is what a
        looping reply costs: the demonstrations tell how long a sensible one is."""
        longest = [max(column) + SLACK for column in zip(*lists, strict=True)]
        if not longest:
            return cls()
        return cls(*(min(n, cap) for n, cap in zip(longest, (MAX_ACTIONS, MAX_PREDICATES, MAX_OBJECTS), strict=True)))


@dataclass(frozen=True)
class Constraint:
    """The reply block of one task as a GBNF grammar and as a JSON schema (its text)."""

    gbnf: str
    schema_json: str
    name: str = "hints"  # the schema's name in ``response_format``

    @property
    def schema(self) -> dict[str, Any]:
        value: dict[str, Any] = json.loads(self.schema_json)
        return value


_NAME_RULES: TaskTable[tuple[str, str]] = TaskTable("the grammar rules of the names")


def constraint_of(
    source: GroundTask | ActionNames,
    bounds: Bounds = Bounds(),
    *,
    path_only: bool = False,
    first: Iterable[Atom] | None = None,
    spelling: Spelling = Spelling.UNDERSCORED,
) -> Constraint:
    """The constraint of the replies for a task (or its action names) with lists of at most ``bounds`` items.

    ``path_only``: the reply is the first line alone (a taught model's, :func:`hbtp.llm.prompt.taught_reply`).
    ``first``: the path's first action is one of these (a plan continued where they apply,
    :mod:`hbtp.llm.checked`), the others any action.
    ``spelling``: how the path's actions are spelled (a taught model's, :mod:`hbtp.llm.spelling`).
    The rules of the names are built once per task (kept with its names); only the first lines,
    which hold the bounds and ``first``, change from request to request."""
    task = as_names(source)
    rules, action_pattern = _NAME_RULES.of(task, lambda: _names(task, spelling), key=spelling)
    predicates, objects = task.action_predicates, task.symbols
    lists = f'" " {_bounded("action" if first is None else "first", bounds.actions, then="action")}'
    if first is not None:
        spelled = sorted(spelling.write(action) for action in first)
        rules = f"first ::= {' | '.join(gbnf_literal(name) for name in spelled)}\n" + rules
    if not path_only:
        lists += (
            f' "\\n{PREDICATES}: " {_bounded("predicate", _at_most(bounds.predicates, predicates))}'
            f' "\\n{OBJECTS}: " {_bounded("object", _at_most(bounds.objects, objects))}'
        )
    root = (
        f"root ::= {lists} end\n"
        # The reply may end the way a demonstration does (a blank line): a base model that wants to
        # stop after the last object is not made to go on listing objects up to the bound.
        'end ::= ( "\\n" "\\n"? )?\n'
    )
    schema = _schema(task, action_pattern, bounds)
    return Constraint(root + rules, json.dumps(schema, sort_keys=True))


def gbnf_literal(text: str) -> str:
    return '"' + text.replace("\\", "\\\\").replace('"', '\\"').replace("\n", "\\n") + '"'


def _bounded(item: str, bound: int, then: str | None = None) -> str:
    """``item``, then up to ``bound - 1`` more (of ``then``, else ``item`` again), comma-separated."""
    return f'{item} (", " {then or item}){{0,{bound - 1}}}'


class NameRules:
    """GBNF rules and the equivalent regular expressions, shared by the sets of suffixes they match."""

    def __init__(self, categories: Mapping[str, Iterable[str]], separator: str = "_") -> None:
        self.separator = separator
        self.names: dict[frozenset[str], str] = {frozenset(m): name.lower() for name, m in categories.items()}
        self.rules: dict[str, str] = {}
        self.regex: dict[frozenset[tuple[str, ...]], str] = {}
        self.by_suffixes: dict[frozenset[tuple[str, ...]], str] = {}
        self.by_values: dict[frozenset[str], str] = {}

    def alternatives(self, values: frozenset[str]) -> str:
        """A rule matching one of ``values`` (named after the category with exactly those members)."""
        if values not in self.by_values:
            category = self.names.get(values)
            name = "c-" + re.sub(r"[^a-z0-9]+", "-", category) if category else f"o{len(self.by_values)}"
            self.rules[name] = " | ".join(gbnf_literal(v) for v in sorted(values))
            self.by_values[values] = name
        return self.by_values[values]

    def suffixes(self, tuples: frozenset[tuple[str, ...]]) -> tuple[str, str]:
        """A GBNF expression and a regex matching ``sep + sep.join(t)`` for exactly the ``tuples``
        (``sep``: the separator, ``_`` unless the names are spelled otherwise)."""
        if tuples == frozenset({()}):
            return '""', ""
        if tuples not in self.by_suffixes:
            rests: dict[str, set[tuple[str, ...]]] = {}
            for head_tail in sorted(tuples):
                rests.setdefault(head_tail[0], set()).add(head_tail[1:])
            groups: dict[frozenset[tuple[str, ...]], set[str]] = {}
            for first, after in rests.items():
                groups.setdefault(frozenset(after), set()).add(first)
            grammar, regex = [], []
            for tails, firsts in sorted(groups.items(), key=lambda item: sorted(item[1])):
                tail, tail_regex = self.suffixes(tails)
                head = self.alternatives(frozenset(firsts))
                grammar.append(f"{gbnf_literal(self.separator)} {head}" + ("" if tail == '""' else f" {tail}"))
                alternatives = "|".join(re.escape(v) for v in sorted(firsts))
                regex.append(f"{re.escape(self.separator)}(?:{alternatives})" + tail_regex)
            name = f"s{len(self.by_suffixes)}"
            self.rules[name] = " | ".join(f"( {g} )" for g in grammar)
            self.by_suffixes[tuples] = name
            self.regex[tuples] = "(?:" + "|".join(regex) + ")"
        return self.by_suffixes[tuples], self.regex[tuples]


def _names(task: ActionNames, spelling: Spelling = Spelling.UNDERSCORED) -> tuple[str, str]:
    """The GBNF rules of ``action``, ``predicate`` and ``object``, and the regex of an action name."""
    rules = NameRules(task.categories, spelling.value)
    objects_of: dict[str, set[tuple[str, ...]]] = {}
    for action in task.actions:
        objects_of.setdefault(action.predicate, set()).add(action.args)
    grammar, patterns = [], []
    for predicate in task.action_predicates:
        tail, tail_regex = rules.suffixes(frozenset(objects_of[predicate]))
        grammar.append(gbnf_literal(predicate) + ("" if tail == '""' else f" {tail}"))
        patterns.append(re.escape(predicate) + tail_regex)
    lines = [
        "action ::= " + " | ".join(f"( {g} )" for g in grammar),
        f"predicate ::= {rules.alternatives(frozenset(task.action_predicates))}",
        f"object ::= {rules.alternatives(frozenset(task.symbols))}",
        *(f"{name} ::= {body}" for name, body in rules.rules.items()),
    ]
    return "\n".join(lines) + "\n", "^(?:" + "|".join(patterns) + ")$"


def _at_most(bound: int, names: Iterable[str]) -> int:
    return max(1, min(bound, len(set(names))))


def _schema(task: ActionNames, action_pattern: str, bounds: Bounds) -> dict[str, Any]:
    def array(items: dict[str, Any], bound: int) -> dict[str, Any]:
        return {"type": "array", "items": items, "minItems": 1, "maxItems": bound}

    properties = {
        JSON_KEYS[0]: array({"type": "string", "pattern": action_pattern}, bounds.actions),
        JSON_KEYS[1]: array(
            {"type": "string", "enum": list(task.action_predicates)},
            _at_most(bounds.predicates, task.action_predicates),
        ),
        JSON_KEYS[2]: array({"type": "string", "enum": sorted(task.symbols)}, _at_most(MAX_OBJECTS, task.symbols)),
    }
    return {"type": "object", "properties": properties, "required": list(JSON_KEYS), "additionalProperties": False}


def response_format(constraint: Constraint) -> dict[str, Any]:
    """The OpenAI ``response_format`` asking for :attr:`Constraint.schema`."""
    return {
        "type": "json_schema",
        "json_schema": {"name": constraint.name, "strict": True, "schema": constraint.schema},
    }


def reply_from_json(text: str) -> str | None:
    """The three lines of a JSON answer in the schema's shape, or ``None`` when ``text`` is not one.

    An answer cut off by the token limit is read as far as it goes (each list up to where it
    stops), so the names a truncated reply did give are not lost."""
    start = text.find("{")
    if start < 0 or not re.search(rf'"{JSON_KEYS[0]}"\s*:\s*\[', text):
        return None
    lists = [_json_list(text[start:], key) for key in JSON_KEYS]
    return format_reply(*lists)


def _json_list(text: str, key: str) -> list[str]:
    """The strings of the list ``"key": [...]`` in ``text`` (to its end when the list is cut off)."""
    found = re.search(rf'"{re.escape(key)}"\s*:\s*\[((?:\s*"(?:[^"\\]|\\.)*"\s*,?)*)', text)
    if found is None:
        return []
    return [json.loads(item) for item in re.findall(r'"(?:[^"\\]|\\.)*"', found.group(1))]
