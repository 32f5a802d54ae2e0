"""The on-disk scenario cache gives back the same scenario, and is rebuilt when it is unreadable."""

from __future__ import annotations

from pathlib import Path

import pytest

from hbtp.domains import scenarios


def _fresh(name: str) -> scenarios.Scenario:
    scenarios._load_shipped.cache_clear()
    return scenarios.load_scenario(name)


def test_cache_round_trip_and_rebuild(tmp_path: Path, monkeypatch: pytest.MonkeyPatch) -> None:
    monkeypatch.delenv("HBTP_NO_CACHE", raising=False)
    monkeypatch.setenv("HBTP_CACHE_DIR", str(tmp_path))
    built = _fresh("robothow-small")
    files = list(tmp_path.glob("robothow-small-*.pickle"))
    assert len(files) == 1
    cached = _fresh("robothow-small")
    assert cached.task.actions == built.task.actions
    assert cached.task.atoms == built.task.atoms
    assert cached.mutexes.groups == built.mutexes.groups
    files[0].write_bytes(b"not a pickle")
    rebuilt = _fresh("robothow-small")
    assert rebuilt.task.actions == built.task.actions
    scenarios._load_shipped.cache_clear()


def test_no_cache_when_disabled(tmp_path: Path, monkeypatch: pytest.MonkeyPatch) -> None:
    monkeypatch.setenv("HBTP_NO_CACHE", "1")
    monkeypatch.setenv("HBTP_CACHE_DIR", str(tmp_path))
    _fresh("robowaiter")
    assert not list(tmp_path.iterdir())
    scenarios._load_shipped.cache_clear()
