"""Ground atoms such as ``IsIn(milk,fridge)``: the readable names at the edges of hbtp.

Inside a grounded task atoms are interned to integers; :class:`Atom` is what users read and
write. The same shape names a grounded action (``Walk(apple)``).

Two spellings are accepted everywhere: ``IsIn(milk,fridge)`` and the datasets' ``IsIn_milk_fridge``
(the first ``_`` separates the predicate, the others separate arguments). A leading ``~`` negates a
literal (``~IsOpen_fridge``: the fridge is not open); see :mod:`hbtp.logic.negation` for how a task
plans with negative literals.
"""

from __future__ import annotations

import re
from dataclasses import dataclass

from hbtp.errors import InputError

_NAME = r"[A-Za-z][A-Za-z0-9_\-]*"
_PAREN_FORM = re.compile(rf"^\s*({_NAME})\s*\(\s*([^()]*)\)\s*$")
_BARE_NAME = re.compile(rf"^\s*({_NAME})\s*$")
_SHOWN = 80  # characters of an offending text quoted in an error message
#: The mark of a negated literal, ``~IsOpen(fridge)`` (also in the scenario cache and the grounder's keys).
NEGATION = "~"
#: The mark of the further ground actions of an action whose precondition has a disjunction over
#: fluents: ``move(a,b)``, ``move-alt2(a,b)``, ... one per alternative (see :func:`alternative_name`).
ALTERNATIVE = "-alt"
_ALTERNATIVE_SUFFIX = re.compile(rf"{re.escape(ALTERNATIVE)}[0-9]+$")


def alternative_name(action: str, number: int) -> str:
    """The name of alternative ``number`` (from 0) of ``action``: ``action`` itself, then ``action-alt2``, ..."""
    return action if number == 0 else f"{action}{ALTERNATIVE}{number + 1}"


def declared_action(name: str) -> str:
    """The declared action an alternative's name stands for (``move-alt2`` -> ``move``), else ``name``."""
    return _ALTERNATIVE_SUFFIX.sub("", name)


def _quoted(text: str) -> str:
    """``text`` stripped and quoted for a one-line message, shortened when long."""
    text = text.strip()
    if len(text) <= _SHOWN:
        return repr(text)
    return f"{text[:_SHOWN]!r}... ({len(text)} characters)"


@dataclass(frozen=True, slots=True, order=True)
class Atom:
    """A predicate applied to objects: ``IsIn(milk,fridge)``; also used for action names.

    ``negated`` makes it the literal ``~IsIn(milk,fridge)``, which holds when the atom does not.
    """

    predicate: str
    args: tuple[str, ...] = ()
    negated: bool = False

    def __str__(self) -> str:
        return f"{NEGATION if self.negated else ''}{self.predicate}({','.join(self.args)})"

    @property
    def underscored(self) -> str:
        """The datasets' spelling, ``IsIn_milk_fridge`` (``~IsIn_milk_fridge`` when negated)."""
        return (NEGATION if self.negated else "") + "_".join((self.predicate, *self.args))

    @property
    def positive(self) -> Atom:
        """The atom without its negation."""
        return Atom(self.predicate, self.args) if self.negated else self

    def negate(self) -> Atom:
        """The complementary literal."""
        return Atom(self.predicate, self.args, not self.negated)


def parse_atom(text: str) -> Atom:
    """Read ``IsIn(milk,fridge)``, ``IsIn(milk, fridge)`` or ``IsIn_milk_fridge``, each optionally
    negated by a leading ``~``.

    Raises :class:`InputError` on anything else.
    """
    stripped = text.strip()
    if stripped.startswith(NEGATION):
        positive = stripped[len(NEGATION) :]
        return parse_atom(positive).negate() if not positive.lstrip().startswith(NEGATION) else _malformed(text)
    match = _PAREN_FORM.match(text)
    if match:
        inner = match.group(2).strip()
        args = tuple(a.strip() for a in inner.split(",")) if inner else ()
        if any(not re.fullmatch(_NAME, a) for a in args):
            raise InputError(f"malformed literal {_quoted(text)}")
        return Atom(match.group(1), args)
    match = _BARE_NAME.match(text)
    if match:
        predicate, *rest = match.group(1).split("_")
        if not predicate or any(not a for a in rest):
            raise InputError(f"malformed literal {_quoted(text)}")
        return Atom(predicate, tuple(rest))
    raise InputError(f"malformed literal {_quoted(text)} (expected Pred(a,b) or Pred_a_b)")


def _malformed(text: str) -> Atom:
    raise InputError(f"malformed literal {_quoted(text)} (at most one ~ negates a literal)")


def split_conjunction(text: str) -> list[str]:
    """Split ``A & B & C`` into the texts of its conjuncts (``&`` is the only connective)."""
    parts: list[str] = []
    depth = 0
    start = 0
    for position, char in enumerate(text):
        if char == "(":
            depth += 1
        elif char == ")":
            depth -= 1
        elif char == "&" and depth == 0:
            parts.append(text[start:position])
            start = position + 1
    parts.append(text[start:])
    pieces = [p.strip() for p in parts]
    for number, piece in enumerate(pieces, 1):
        if not piece:
            raise InputError(
                f"malformed conjunction {_quoted(text)}: an empty conjunct (number {number} of {len(pieces)})"
            )
    return pieces


def parse_conjunction(text: str) -> tuple[Atom, ...]:
    """Read a goal such as ``IsIn_milk_fridge & IsClose(fridge)`` into atoms, in order, without repeats."""
    if not text.strip():
        raise InputError("empty goal")
    return tuple(dict.fromkeys(parse_atom(piece) for piece in split_conjunction(text)))
