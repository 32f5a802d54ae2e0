"""The goal of ``hbtp plan -g``: the text itself, or ``@FILE`` read from a file (``@-``: standard input)."""

from __future__ import annotations

from hbtp.errors import InputError
from hbtp.files import InputKind, read_text

GOAL_HELP = 'Goal, e.g. "IsIn_milk_fridge & IsClose_fridge"; @FILE reads it from a UTF-8 file, @- from standard input.'


def read_goal(text: str, kind: InputKind = InputKind.GOAL) -> str:
    """``text``, or the contents of the file it names after ``@`` (``@-``: standard input).

    A goal literal starts with a letter, so a leading ``@`` is never part of a goal. A file that is
    not a regular one, is larger than ``kind``'s cap, or is not UTF-8 is an :class:`InputError`
    (one line); a byte order mark is dropped.
    """
    if not text.startswith("@"):
        return text
    name = text[1:]
    if not name:
        raise InputError(f"@FILE: the file name is missing for the {kind.label} (use @- for standard input)")
    return read_text(name, kind)
