"""hbtp's optional C extensions (hbtp.compiled): which are built, and what hbtp says when one is not."""

from __future__ import annotations

import logging

import pytest

from hbtp import compiled
from hbtp.errors import PlanningError
from hbtp.logic import subsets
from hbtp.logic.subsets import SubsetIndex
from hbtp.planning import flow, lmcut, pairs
from hbtp.planning.flow import StateEquation
from hbtp.planning.heuristics import LandmarkSum, analyse_space
from hbtp.planning.lmcut import LmCut
from hbtp.planning.pairs import PairCosts
from helpers import random_case


def test_built_names_each_extension_as_its_module_says() -> None:
    assert compiled.built() == {
        compiled.LMCUT: lmcut.COMPILED,
        compiled.SUBSETS: subsets.COMPILED,
        compiled.CHEAP: pairs.COMPILED,
        compiled.SIMPLEX: flow.COMPILED,
    }


def test_a_missing_extension_is_said_once_per_process_and_only_at_first_use(
    monkeypatch: pytest.MonkeyPatch, caplog: pytest.LogCaptureFixture
) -> None:
    monkeypatch.setattr(compiled, "_warned", set())
    monkeypatch.setattr(subsets, "_compiled", None)
    monkeypatch.setattr(lmcut, "_compiled", None)
    monkeypatch.setattr(pairs, "_compiled", None)
    task = random_case(0).task
    analysis = analyse_space(task, task.actions)
    with caplog.at_level(logging.WARNING, logger="hbtp.compiled"):
        assert not caplog.records
        for _ in range(3):
            SubsetIndex(compiled=False).add(frozenset({1}))
            LmCut(task, task.actions, compiled=False)
            PairCosts([], compiled=False)
            LandmarkSum(analysis.landmarks, analysis.shares, frozenset(), analysis.pre_landmarks, compiled=False)
    said = [r.getMessage() for r in caplog.records]
    assert len(said) == 3, said
    assert "the subset index runs in Python" in said[0]
    assert "hbtp.logic._subsets was not built" in said[0]
    assert "LM-cut runs in Python" in said[1]
    assert "install a C compiler" in said[1]
    assert "(h² and the landmark sum) runs in Python" in said[2]


def test_without_the_simplex_in_c_highs_solves_and_that_is_said_once(
    monkeypatch: pytest.MonkeyPatch, caplog: pytest.LogCaptureFixture
) -> None:
    monkeypatch.setattr(compiled, "_warned", set())
    monkeypatch.setattr(flow, "_compiled", None)
    task = random_case(0).task
    with caplog.at_level(logging.WARNING, logger="hbtp.compiled"):
        made = [StateEquation(task, task.actions, None, compiled=False) for _ in range(3)]
    said = [r.getMessage() for r in caplog.records]
    assert len(said) == 1, said
    assert "the state equation is solved by HiGHS, several times slower" in said[0]
    assert all(equation.program is None for equation in made)
    with pytest.raises(PlanningError, match=r"_simplex is not built here \(the state equation is solved by HiGHS\)"):
        StateEquation(task, task.actions, None, compiled=True)


def test_c_asked_for_where_it_is_not_built_is_refused_with_what_runs_instead() -> None:
    with pytest.raises(PlanningError, match=r"hbtp\.logic\._subsets is not built here \(the subset index runs"):
        compiled.kernel(None, compiled.SUBSETS, compiled=True, slower="the subset index")
    assert compiled.kernel(None, compiled.SUBSETS, compiled=False, slower="the subset index") is None
    assert compiled.extension("logic._no_such_extension") is None
