"""Larger scenarios for scaling experiments: clone objects of a problem with all their facts.

A clone ``apple2`` of ``apple`` gets every static fact and every initial fact that mentions
``apple``, with ``apple`` replaced (facts about two objects are cloned for each of them), so it
belongs to the same categories and roles and starts in the same state. Actions over pairs of
objects grow quadratically: RobotHow with every object cloned once has about four times as many
grounded actions. The original objects, and so every task of the original scenario, are unchanged.
"""

from __future__ import annotations

import dataclasses
import itertools
import math

from hbtp.domains.lifted import AtomFormula, Problem, TypedName
from hbtp.domains.scenarios import Scenario, ScenarioOptions, load_pddl_scenario, load_scenario
from hbtp.errors import InputError


def clone_objects(problem: Problem, factor: float) -> Problem:
    """``problem`` with ``round((factor - 1) * n)`` clones of its n objects, spread over them in turn."""
    if not factor >= 1.0:
        raise InputError(f"the scale factor must be at least 1, not {factor}")
    originals = [o for o in problem.objects]
    extra = round((factor - 1.0) * len(originals))
    names = {o.name for o in originals}
    clones: dict[str, list[str]] = {o.name: [] for o in originals}
    new_objects: list[TypedName] = list(originals)
    for index in range(extra):
        source = originals[index % len(originals)]
        copy = index // len(originals) + 2
        name = f"{source.name}{copy}"
        while name in names:
            copy += 1
            name = f"{source.name}{copy}"
        names.add(name)
        clones[source.name].append(name)
        new_objects.append(TypedName(name, source.types))
    facts: list[AtomFormula] = list(problem.init)
    seen = {(f.predicate, f.terms) for f in facts}
    for fact in problem.init:
        options = [[term, *clones.get(term, [])] for term in fact.terms]
        for terms in itertools.product(*options):
            if (fact.predicate, terms) not in seen:
                seen.add((fact.predicate, terms))
                facts.append(AtomFormula(fact.predicate, terms))
    return dataclasses.replace(
        problem, name=f"{problem.name}-x{factor:g}", objects=tuple(new_objects), init=tuple(facts)
    )


def scaled_scenario(name: str, factor: float, *, keep_self_placements: bool = False) -> Scenario:
    """A shipped scenario with its objects cloned ``factor`` times (``factor`` 1: the scenario itself),
    its self-placements left out unless ``keep_self_placements`` (see :func:`load_scenario`)."""
    base = load_scenario(name, keep_self_placements=keep_self_placements)
    if math.isclose(factor, 1.0):
        return base
    options = dataclasses.replace(
        ScenarioOptions.shipped(name, keep_self_placements=keep_self_placements),
        name=f"{name}-x{factor:g}",
        title=f"{base.title} x{factor:g}",
        description="",
        fewshot=None,
        test_set=None,
    )
    parsed = dataclasses.replace(base.pddl, problem=clone_objects(base.pddl.problem, factor))
    return load_pddl_scenario(base.domain_file, base.problem_file, options, parsed=parsed)
