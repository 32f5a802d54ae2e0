"""The reply block: the three lines in which a record, a demonstration and an LLM answer give hints.

::

    Optimal Actions: Walk_milk, RightGrab_milk, Walk_fridge
    Vital Action Predicates: Walk, RightGrab
    Vital Objects: milk, fridge

The one home of these lines: the dataset text format writes them (and reads them with these
titles), the prompts show them in the demonstrations and ask for them, the oracle backends answer
with them, and the grammar checker names a missing one by its title. The tolerant reading of an
LLM's reply is :func:`hbtp.llm.parse.parse_reply`.
"""

from __future__ import annotations

from collections.abc import Iterable

ACTIONS = "Optimal Actions"
PREDICATES = "Vital Action Predicates"
OBJECTS = "Vital Objects"

#: The hints' field each line gives (p̂, Q̂, Ô), in the order of the block.
TITLES: dict[str, str] = {"path": ACTIONS, "predicates": PREDICATES, "objects": OBJECTS}


def reply_lines(actions: Iterable[str], predicates: Iterable[str], objects: Iterable[str]) -> list[str]:
    """The block's three lines, items comma-separated (an empty list leaves the line's value empty)."""
    return [
        f"{title}: {', '.join(items)}"
        for title, items in zip(TITLES.values(), (actions, predicates, objects), strict=True)
    ]


def format_reply(actions: Iterable[str], predicates: Iterable[str], objects: Iterable[str]) -> str:
    """The block as one text (no trailing newline)."""
    return "\n".join(reply_lines(actions, predicates, objects))
