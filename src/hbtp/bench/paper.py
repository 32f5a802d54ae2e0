"""The paper's action space: the scenarios every experiment of :mod:`hbtp.bench` plans in.

The paper's action lists hold self-placements, actions that put an object on or in itself
(RobotHow's ``LeftPut(chair,chair)``, see :mod:`hbtp.domains.irreflexive`). A user's plans leave
them out; the experiments keep them, so that their tasks, and so their tables and figures, are the
paper's. These loaders are the experiments' only way to a shipped scenario.
"""

from __future__ import annotations

from hbtp.domains.scale import scaled_scenario
from hbtp.domains.scenarios import Scenario, ScenarioOptions, load_scenario

#: The experiments keep the self-placements of the paper's action lists.
KEEP_SELF_PLACEMENTS = True


def paper_scenario(name: str) -> Scenario:
    """The shipped scenario ``name`` with the paper's action space."""
    return load_scenario(name, keep_self_placements=KEEP_SELF_PLACEMENTS)


def paper_options(name: str) -> ScenarioOptions:
    """The options that ground the shipped scenario ``name`` with the paper's action space."""
    return ScenarioOptions.shipped(name, keep_self_placements=KEEP_SELF_PLACEMENTS)


def paper_scaled(name: str, factor: float) -> Scenario:
    """The shipped scenario ``name`` with its objects cloned ``factor`` times, with the paper's
    action space (:func:`hbtp.domains.scale.scaled_scenario`)."""
    return scaled_scenario(name, factor, keep_self_placements=KEEP_SELF_PLACEMENTS)


__all__ = ["KEEP_SELF_PLACEMENTS", "paper_options", "paper_scaled", "paper_scenario"]
