"""Words for messages about names: the closest known names, and short listings."""

from __future__ import annotations

import difflib
from collections.abc import Iterable


def did_you_mean(name: str, known: Iterable[str]) -> str:
    """`` (did you mean 'a' or 'b'?)`` with the closest of ``known`` names (case-insensitively), or ''."""
    spelling: dict[str, str] = {}
    for k in sorted(known):
        spelling.setdefault(k.lower(), k)
    close = difflib.get_close_matches(name.lower(), spelling, n=3)
    if not close:
        return ""
    return " (did you mean " + " or ".join(repr(spelling[c]) for c in close) + "?)"


def listing(names: Iterable[str], most: int = 10) -> str:
    """``a, b, c`` for a message: at most ``most`` names, then how many more there are."""
    shown = list(names)
    if len(shown) <= most:
        return ", ".join(shown)
    return ", ".join(shown[:most]) + f" and {len(shown) - most} more"


__all__ = ["did_you_mean", "listing"]
