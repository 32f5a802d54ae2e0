"""Build a grounded domain directly from Python, without PDDL.

>>> task = (
...     DomainBuilder("kitchen")
...     .constants(["self"])
...     .action("Walk(fridge)", pre=["IsStanding(self)"], add=["IsNear(self,fridge)"], cost=15)
...     .action("Open(fridge)", pre=["IsNear(self,fridge)", "IsClose(fridge)"],
...             add=["IsOpen(fridge)"], delete=["IsClose(fridge)"], cost=3)
...     .initial(["IsStanding(self)", "IsClose(fridge)"])
...     .build()
... )
>>> len(task.actions), sorted(task.objects)
(2, ['fridge'])
"""

from __future__ import annotations

from collections.abc import Iterable

from hbtp.domains.lifted import MAX_ACTION_COST
from hbtp.errors import InputError
from hbtp.logic.atoms import Atom, parse_atom
from hbtp.logic.task import GroundAction, GroundTask


class DomainBuilder:
    """Collects grounded actions and an initial state, then builds a :class:`GroundTask`."""

    def __init__(self, name: str) -> None:
        self.name = name
        self._actions: dict[Atom, tuple[list[Atom], list[Atom], list[Atom], int]] = {}
        self._initial: list[Atom] = []
        self._constants: list[str] = []

    def action(
        self,
        name: str,
        *,
        pre: Iterable[str] = (),
        add: Iterable[str] = (),
        delete: Iterable[str] = (),
        cost: int = 1,
    ) -> DomainBuilder:
        signature = parse_atom(name)
        if signature in self._actions:
            raise InputError(f"action {signature} is defined twice")
        if cost < 0:
            raise InputError(f"action {signature}: cost must not be negative")
        if cost > MAX_ACTION_COST:
            raise InputError(f"action {signature}: cost {cost} is larger than the maximum {MAX_ACTION_COST}")
        self._actions[signature] = (
            [parse_atom(a) for a in pre],
            [parse_atom(a) for a in add],
            [parse_atom(a) for a in delete],
            int(cost),
        )
        return self

    def initial(self, atoms: Iterable[str]) -> DomainBuilder:
        self._initial.extend(parse_atom(a) for a in atoms)
        return self

    def constants(self, names: Iterable[str]) -> DomainBuilder:
        """Symbols that are not objects of the task (``self``); they are left out of O."""
        self._constants.extend(names)
        return self

    def build(self, objects: Iterable[str] | None = None) -> GroundTask:
        """The task; its objects are ``objects`` or every argument that is not a constant."""
        all_atoms: set[Atom] = set(self._initial)
        for pre, add, delete, _ in self._actions.values():
            all_atoms.update(pre, add, delete)
        arities: dict[str, int] = {}
        for atom in sorted(all_atoms):
            if arities.setdefault(atom.predicate, len(atom.args)) != len(atom.args):
                raise InputError(f"predicate {atom.predicate!r} is used with different numbers of arguments")
        atoms = tuple(sorted(all_atoms))
        ids = {atom: i for i, atom in enumerate(atoms)}
        ordered = sorted(self._actions.items(), key=lambda item: str(item[0]))
        actions = tuple(
            GroundAction(
                index,
                signature,
                frozenset(ids[a] for a in pre),
                frozenset(ids[a] for a in add),
                frozenset(ids[a] for a in delete) - frozenset(ids[a] for a in add),
                cost,
            )
            for index, (signature, (pre, add, delete, cost)) in enumerate(ordered)
        )
        symbols = {arg for atom in all_atoms for arg in atom.args}
        symbols |= {arg for signature in self._actions for arg in signature.args}
        constants = tuple(sorted(dict.fromkeys(self._constants)))
        chosen = sorted(objects) if objects is not None else sorted(symbols - set(constants))
        rest = tuple(sorted(symbols - set(chosen) - set(constants)))
        return GroundTask(
            name=self.name,
            atoms=atoms,
            actions=actions,
            initial_state=frozenset(ids[a] for a in self._initial),
            objects=tuple(chosen),
            constants=constants + rest,
            predicates=arities,
        )
