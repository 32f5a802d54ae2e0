"""One reader for tree files: hbtp JSON or BehaviorTree.CPP v4 XML, told apart by their content.

:func:`read_tree_file` reads a file once and returns a :class:`TreeFile`: the metadata it records
(scenario, goal, whether the tree is complete, and for a tree planned from the user's PDDL the
domain and problem files) and a method that resolves the tree against a task. ``hbtp run``,
``verify`` and ``export`` all read trees through it.

The format comes from the first character after any byte-order mark and white space (``{``: JSON,
``<``: XML), else from the extension (``.json``, ``.xml``).
"""

from __future__ import annotations

import logging
import os
from collections.abc import Mapping
from dataclasses import dataclass, field
from pathlib import Path
from typing import Any, Literal

from hbtp.bt.btcpp import btcpp_metadata, tree_from_btcpp
from hbtp.bt.jsonio import json_document, root_from_document
from hbtp.bt.nodes import Node
from hbtp.errors import InputError
from hbtp.files import InputKind, read_bytes
from hbtp.logic.atoms import Atom, parse_atom, split_conjunction
from hbtp.logic.goals import parse_goal
from hbtp.logic.task import Goal, GroundTask
from hbtp.planning.hints import Hints, hints_from_names

log = logging.getLogger(__name__)


@dataclass(frozen=True)
class PddlFiles:
    """The PDDL a tree was planned from, with the options it was grounded with.

    Read from a tree file, ``folder`` is the tree file's folder: the recorded paths are relative to
    it, and :meth:`confined` refuses any that leaves it (an absolute path, ``..``, a symbolic link
    out of it), so that a tree file cannot make hbtp open ``/etc/shadow``.
    """

    domain: Path
    problem: Path
    objects: tuple[str, ...] = ()
    keep_fluent: tuple[str, ...] = ()
    mutex: Path | None = None
    folder: Path | None = None
    irreflexive: tuple[str, ...] = ()

    def paths(self) -> tuple[Path, ...]:
        return (self.domain, self.problem) if self.mutex is None else (self.domain, self.problem, self.mutex)

    def outside(self, folder: Path) -> list[Path]:
        """The files that do not lie inside ``folder`` (after resolving ``..`` and symbolic links)."""
        root = Path(folder).resolve()
        return [path for path in self.paths() if not Path(path).resolve().is_relative_to(root)]

    def confined(self, source: str) -> PddlFiles:
        """These files, checked to lie inside the tree file's folder (:class:`InputError` if not)."""
        if self.folder is not None:
            outside = self.outside(self.folder)
            if outside:
                raise InputError(
                    f"{source} records the PDDL file {_shown(outside[0], self.folder)}, outside the tree file's "
                    "folder: hbtp opens only files beside the tree; give --pddl DOMAIN PROBLEM"
                )
        return self

    def to_dict(self, relative_to: Path) -> dict[str, Any]:
        """What a JSON tree written into the folder ``relative_to`` records (paths relative to it)."""
        record: dict[str, Any] = {
            "domain": _relative(self.domain, relative_to),
            "problem": _relative(self.problem, relative_to),
        }
        if self.objects:
            record["objects"] = list(self.objects)
        if self.keep_fluent:
            record["keep_fluent"] = list(self.keep_fluent)
        if self.mutex is not None:
            record["mutex"] = _relative(self.mutex, relative_to)
        if self.irreflexive:
            record["irreflexive"] = list(self.irreflexive)
        return record

    @classmethod
    def from_dict(cls, data: Any, folder: Path, source: str) -> PddlFiles:
        """Read a ``"pddl"`` record; relative paths are relative to ``folder`` (the tree file's)."""

        def path(key: str) -> Path:
            value = data.get(key)
            if not isinstance(value, str) or not value or "\0" in value:
                raise InputError(f'{source}: "pddl" needs the {key} file as a string')
            return folder / value

        def names(key: str) -> tuple[str, ...]:
            value = data.get(key, [])
            if not isinstance(value, list) or not all(isinstance(item, str) for item in value):
                raise InputError(f'{source}: "pddl": {key} must be a list of names')
            return tuple(value)

        if not isinstance(data, dict):
            raise InputError(f'{source}: "pddl" must be an object with the domain and problem files')
        return cls(
            path("domain"),
            path("problem"),
            names("objects"),
            names("keep_fluent"),
            path("mutex") if data.get("mutex") is not None else None,
            folder,
            names("irreflexive"),
        )


def _shown(path: Path, folder: Path) -> str:
    """``path`` as the tree file records it (relative to its folder where it can be)."""
    try:
        return repr(Path(path).relative_to(folder).as_posix())
    except ValueError:
        return repr(Path(path).as_posix())


def _relative(path: Path, folder: Path) -> str:
    try:
        return Path(os.path.relpath(Path(path).resolve(), Path(folder).resolve())).as_posix()
    except ValueError:  # another drive (Windows)
        return Path(path).resolve().as_posix()


@dataclass(frozen=True)
class TreeFile:
    """A tree file read from disk, not yet resolved against a task.

    ``goal`` is a tuple of literal texts (JSON trees) or one conjunction (BT.CPP comments and JSON
    trees written before goals were stored as lists), ``None`` when the file states none.
    """

    path: str
    kind: Literal["json", "btcpp"]
    scenario: str | None = None
    goal: tuple[str, ...] | str | None = None
    complete: bool = True
    pddl: PddlFiles | None = None
    content: Any = field(default=None, repr=False)
    #: The hints whose pruned space the tree was planned in (JSON trees that record them).
    hints: Hints | None = None

    def tree(self, task: GroundTask) -> Node:
        """The tree, its names resolved against ``task`` (:class:`InputError` for unknown ones)."""
        if self.kind == "json":
            return root_from_document(self.content, task, self.path)
        return tree_from_btcpp(self.content, task, self.path)

    def resolve_goal(self, task: GroundTask) -> Goal | None:
        """The recorded goal resolved against ``task``; ``None`` when the file states none."""
        text = self.goal_text(task)
        if text is None:
            return None
        try:
            return task.resolve_goal(text)
        except InputError as error:
            raise InputError(f"{self.path}: the recorded goal: {error}") from None

    def goal_text(self, task: GroundTask) -> str | None:
        """The recorded goal as goal text in the ``Pred(a,b)`` form (the datasets' underscored
        literals matched against ``task``); ``None`` when the file states none."""
        if not self.goal:
            return None
        try:
            if isinstance(self.goal, str) and ("|" in self.goal or self.goal.lstrip().startswith("(")):
                return " | ".join(" & ".join(map(str, term)) for term in parse_goal(self.goal))
            texts = split_conjunction(self.goal) if isinstance(self.goal, str) else list(self.goal)
            return " & ".join(str(_literal(task, text)) for text in texts)
        except InputError as error:
            raise InputError(f"{self.path}: the recorded goal: {error}") from None


def _literal(task: GroundTask, text: str) -> Atom:
    """A goal literal: ``Pred(a,b)``, or the underscored ``Pred_a_b`` matched against the task's
    literals (where ``_`` may be part of a name, as in ``have_image(...)``)."""
    try:
        atom = parse_atom(text)
        task.check_literal(atom)
        return atom
    except InputError:
        stripped = text.strip()
        negated = stripped.startswith("~")
        underscored = {candidate.underscored: candidate for candidate in task.atoms}
        found = underscored.get(stripped.lstrip("~").strip())
        if found is None:
            raise
        return found.negate() if negated else found


def read_tree_file(path: str | os.PathLike[str]) -> TreeFile:
    """Read a tree file (hbtp JSON or BehaviorTree.CPP v4 XML); see the module docstring."""
    source = str(path)
    data = read_bytes(path, InputKind.TREE)
    try:
        text = data.decode("utf-8-sig")
    except UnicodeDecodeError:
        raise InputError(f"{source}: not a text file (expected hbtp JSON or BehaviorTree.CPP XML)") from None
    suffix = Path(path).suffix.lower()
    start = text.lstrip()[:1]
    if start == "{" or (start != "<" and suffix == ".json"):
        return _json_file(source, text)
    if start == "<" or suffix == ".xml":
        meta = btcpp_metadata(text)
        return TreeFile(source, "btcpp", meta.get("scenario"), meta.get("goal"), content=text)
    raise InputError(f"{source}: not a tree file (expected hbtp JSON or BehaviorTree.CPP v4 XML)")


def _json_file(source: str, text: str) -> TreeFile:
    document = json_document(text, source)
    scenario = document.get("scenario")
    if scenario is not None and not isinstance(scenario, str):
        raise InputError(f"{source}: the scenario must be a string")
    goal = document.get("goal")
    if isinstance(goal, list):
        if not all(isinstance(item, str) for item in goal):
            raise InputError(f'{source}: the goal must be a list of literals such as "IsIn(milk,fridge)"')
        stored: tuple[str, ...] | str | None = tuple(goal)
    elif goal is None or isinstance(goal, str):
        stored = goal
    else:
        raise InputError(f'{source}: the goal must be a list of literals such as "IsIn(milk,fridge)"')
    complete = document.get("complete", True)
    if not isinstance(complete, bool):
        raise InputError(f'{source}: "complete" must be true or false')
    pddl = document.get("pddl")
    files = PddlFiles.from_dict(pddl, Path(source).parent, source) if pddl is not None else None
    return TreeFile(source, "json", scenario or None, stored, complete, files, document, _hints(document, source))


def _hints(document: Mapping[str, Any], source: str) -> Hints | None:
    """The ``"hints"`` record of a JSON tree (``None`` when it has none)."""
    record = document.get("hints")
    if record is None:
        return None
    lists: list[list[str]] = []
    for key in ("path", "predicates", "objects"):
        names = record.get(key) if isinstance(record, dict) else None
        if not isinstance(names, list) or not all(isinstance(name, str) for name in names):
            raise InputError(f'{source}: "hints" must hold the lists "path", "predicates" and "objects" of names')
        lists.append(names)
    return hints_from_names(*lists)


def pddl_record(
    files: PddlFiles | None, tree_path: str | os.PathLike[str], *, warn: bool = False
) -> Mapping[str, Any] | None:
    """The ``"pddl"`` record of a JSON tree written to ``tree_path`` (``None`` for no PDDL); with
    ``warn``, a warning when the files lie outside its folder (reading the tree back will then
    need ``--pddl``, see :meth:`PddlFiles.confined`)."""
    if files is None:
        return None
    folder = Path(tree_path).parent
    if warn and files.outside(folder):
        log.warning(
            "%s records PDDL files outside its folder: "
            "hbtp run, verify, view and export of it need --pddl DOMAIN PROBLEM",
            tree_path,
        )
    return files.to_dict(folder)


__all__ = ["PddlFiles", "TreeFile", "pddl_record", "read_tree_file"]
