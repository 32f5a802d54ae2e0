"""The goal of ``hbtp plan -g``: the text itself, or ``@FILE`` read from a file (``@-``: standard input)."""

from __future__ import annotations

import sys
from pathlib import Path

from hbtp.errors import InputError

GOAL_HELP = 'Goal, e.g. "IsIn_milk_fridge & IsClose_fridge"; @FILE reads it from a UTF-8 file, @- from standard input.'


def read_goal(text: str) -> str:
    """``text``, or the contents of the file it names after ``@`` (``@-``: standard input).

    A goal literal starts with a letter, so a leading ``@`` is never part of a goal. An unreadable
    or non-UTF-8 file is an :class:`InputError` (one line); a byte order mark is dropped.
    """
    if not text.startswith("@"):
        return text
    name = text[1:]
    if not name:
        raise InputError("-g @FILE: the file name is missing (use @- for standard input)")
    label = "standard input" if name == "-" else name
    try:
        data = _read_stdin() if name == "-" else Path(name).read_bytes()
    except OSError as error:
        raise InputError(f"{label}: cannot read the goal: {error.strerror or error}") from None
    try:
        return data.decode("utf-8-sig")
    except UnicodeDecodeError as error:
        raise InputError(f"{label}: the goal is not UTF-8 text (byte {error.start})") from None


def _read_stdin() -> bytes:
    stream = sys.stdin
    if stream is None:
        raise OSError(0, "no standard input")
    buffer = getattr(stream, "buffer", None)
    if buffer is not None:
        data: bytes = buffer.read()
        return data
    return stream.read().encode("utf-8")
