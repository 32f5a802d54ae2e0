"""Shared fixtures: the shipped scenarios (loaded once per session) and the reference data files."""

from __future__ import annotations

import json
import os
from pathlib import Path
from typing import Any

import pytest

from hbtp.domains import Scenario, load_scenario
from helpers import SCENARIOS

# The tests build every scenario from its PDDL; they never read or write the user's scenario cache
# (tests/domains/test_scenario_cache.py checks the cache on its own, in a temporary folder).
os.environ["HBTP_NO_CACHE"] = "1"

DATA_DIR = Path(__file__).parent / "data"


@pytest.fixture(scope="session")
def data_dir() -> Path:
    """``tests/data``: copies of the reference facts, so tests never read outside the repository."""
    return DATA_DIR


@pytest.fixture(scope="session")
def domains_samples() -> dict[str, Any]:
    """Grounded examples, s0 and action lists extracted once from the reference notes (domains.md)."""
    with (DATA_DIR / "domains_samples.json").open(encoding="utf-8") as handle:
        return json.load(handle)


@pytest.fixture(scope="session", params=SCENARIOS)
def scenario(request: pytest.FixtureRequest) -> Scenario:
    """Each shipped scenario in turn (a test using it runs four times)."""
    return load_scenario(request.param)


@pytest.fixture(scope="session")
def robowaiter() -> Scenario:
    return load_scenario("robowaiter")


@pytest.fixture(scope="session")
def virtualhome() -> Scenario:
    return load_scenario("virtualhome")


@pytest.fixture(scope="session")
def robothow_small() -> Scenario:
    return load_scenario("robothow-small")


@pytest.fixture(scope="session")
def robothow() -> Scenario:
    return load_scenario("robothow")
