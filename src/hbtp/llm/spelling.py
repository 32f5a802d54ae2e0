"""How a taught model spells an action in the plan it answers: ``Walk_milk`` or ``Walk milk``.

Gemma's tokenizer reads ``Walk_milk, Open_fridge`` as eight tokens (`` Walk``, ``_``, ``milk``,
``,``, `` Open``, ``_``, ``fr``, ``idge``) and ``Walk milk, Open fridge`` as five: an object's name
after a space is mostly one word token, after an underscore a separate ``_`` and often a split
word. The model writes one token at a time, and a plan spelled with spaces has about three
quarters of the tokens (the Table II sets' optimal plans: 3.9-4.9 tokens per action against
5.1-6.6). An adapter records the spelling it was taught (its prompt format,
:data:`hbtp.llm.backends.adapters.SPELLINGS`); the local backend asks in that spelling and gives
the reply back in the datasets' (:func:`read_plan`), so nothing else in hbtp sees the other.
"""

from __future__ import annotations

import re
from collections.abc import Iterable
from enum import Enum

from hbtp.logic.atoms import Atom

#: A run of spaces between two characters of one name (not after a list's comma).
_INNER_SPACES = re.compile(r"(?<=[^\s,]) +(?=[^\s,])")


class Spelling(Enum):
    """The separator between an action's predicate and its arguments in a taught plan."""

    #: ``RightPutIn_milk_fridge``: the datasets' spelling (adapters of prompt format 2).
    UNDERSCORED = "_"
    #: ``RightPutIn milk fridge``: about a quarter fewer Gemma tokens (prompt format 3).
    SPACED = " "

    def write(self, action: Atom) -> str:
        """``action``'s name in this spelling."""
        return self.value.join((action.predicate, *action.args))

    def plan(self, actions: Iterable[Atom]) -> str:
        """A plan as a taught reply's list: a space, then the names, comma-separated."""
        return " " + ", ".join(self.write(action) for action in actions)


def read_plan(text: str) -> str:
    """A taught reply's ``text``, in either spelling, in the datasets' (the spaces inside each name
    made underscores; the list's own spaces and line breaks kept)."""
    return _INNER_SPACES.sub("_", text)


__all__ = ["Spelling", "read_plan"]
