"""Things said again by a shorter name, and parts said with their thing: "put the hair product in
the bathroom cabinet and shut the cabinet", "store the milk in the kitchen cabinet and shut the
cabinet door".

A world may have a ``cabinet`` beside a ``bathroomcabinet``; an instruction that has named the
bathroom cabinet and then says "the cabinet" means the one it named, and a taught model now and then
reads the short name as the other thing. A thing is *said short* for another when every time the
instruction names it, it does so by one word (not a number) that ends a longer name of one other
thing said before it ("cabinet" after "the bathroom cabinet"), and not as one more item of a list
("the spring water and the water" are two things). As the world has both things, a short name may
still mean the other one ("the Bernachon coffee ... and the coffee"): a literal about a thing said
short is read about the thing meant only when its conjunction holds that literal already (the model
wrote it twice: ``IsClose_bathroomcabinet & IsClose_cabinet``). A part of things (an object whose
entry in the words file says ``part``, as ``door``) named right after a thing ("the fridge door", nothing between) is
that thing's part: a literal about it is about the thing, and a thing said short only as the owner of
a part ("the kitchen cabinet ... the cabinet door") is the thing meant (``IsClose_door`` and
``IsClose_cabinet`` become ``IsClose_kitchencabinet``). A literal is read so only when that makes a
literal of the world; one that becomes another of its conjunction is kept once.
"""

from __future__ import annotations

import re
from collections.abc import Mapping
from itertools import pairwise

from hbtp.domains.scenarios import Scenario
from hbtp.domains.words import Words, is_number, spoken_words, words_for
from hbtp.logic.atoms import Atom
from hbtp.pipeline.clauses import LISTING, world_objects
from hbtp.pipeline.mend import known, literals_replaced


def referents_read(scenario: Scenario, text: str, goal: str) -> str:
    """``goal`` with each literal about a thing ``text`` says short for another, or about a part it
    says with its thing, read about the thing meant (see the module docstring); a goal that does not
    parse is returned as it is."""
    words = words_for(scenario)
    short, owned = said_short(words, text, world_objects(scenario))
    if not short and not owned:
        return goal

    def read(literal: Atom, term: tuple[Atom, ...]) -> Atom | None:
        made = Atom(literal.predicate, tuple(owned.get(x, x) for x in literal.args), literal.negated)
        twin = Atom(made.predicate, tuple(short.get(x, x) for x in made.args), made.negated)
        made = twin if twin in term else made
        return made if made != literal and known(scenario, made) else None

    return literals_replaced(goal, read, "a thing said short or by a part")


def said_short(words: Words, text: str, world: frozenset[str]) -> tuple[Mapping[str, str], Mapping[str, str]]:
    """The things ``text`` says short for another, each with the thing meant; and the parts it says
    with a thing and the things it says short only as the owners of parts, each with the thing
    meant."""
    said = spoken_words(text)
    plain = " ".join(re.findall(r"[a-z0-9]+|[^a-z0-9\s]", text.lower()))  # words and marks, spaced
    named = [(start, width, name) for start, width, name in words.named_at(text) if name in world]
    found: dict[str, str | None] = {}
    ends = [0, *(start + width for start, width, _ in named)]
    for (start, width, name), end in zip(named, ends, strict=False):
        head = said[start : start + width]
        listed = end > 0 and set(said[end:start]) <= LISTING  # "the spring water and the water": two things
        longer = {
            other
            for before, wide, other in named
            if before < start and wide > width and other != name and said[before + wide - width : before + wide] == head
        }
        one = next(iter(longer)) if len(longer) == 1 and width == 1 and not is_number(head[0]) else None
        one = None if listed else one
        found[name] = one if found.get(name, one) == one else None
    short = {name: other for name, other in found.items() if other is not None}
    parts = words.parts()
    owned: dict[str, str] = {}
    owners: dict[str, bool] = {}
    for (start, width, name), (after, wide, part) in pairwise([*named, (len(said) + 1, 0, "")]):
        compound = " ".join(said[start : after + wide])  # "cabinet door", not "bookshelf. The door"
        owns = start + width == after and " ".join(said[after : after + wide]) in parts and part != name
        owns = owns and re.search(rf"\b{compound}\b", plain) is not None
        owners[name] = owners.get(name, True) and owns
        if owns:
            owned[part] = short.get(name, name)
    owned |= {name: short[name] for name, only in owners.items() if only and name in short}
    return short, owned


__all__ = ["referents_read", "said_short"]
