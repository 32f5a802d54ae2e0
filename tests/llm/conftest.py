"""Fixtures of the LLM tests: no OpenAI settings from the environment, and servers started (and
stopped) by the test itself on 127.0.0.1.
"""

from __future__ import annotations

import socket
import threading
from collections.abc import Callable, Iterator
from typing import Any

import pytest
from servers import JsonServer, RawServer


@pytest.fixture(autouse=True)
def _no_openai_environment(monkeypatch: pytest.MonkeyPatch) -> None:
    for name in ("OPENAI_API_KEY", "OPENAI_BASE_URL", "HBTP_LLM_MODEL", "OPENAI_ORG_ID", "OPENAI_PROJECT_ID"):
        monkeypatch.delenv(name, raising=False)


@pytest.fixture
def raw() -> Iterator[Callable[[Callable[[socket.socket, threading.Event], None]], RawServer]]:
    servers: list[RawServer] = []

    def start(behave: Callable[[socket.socket, threading.Event], None]) -> RawServer:
        servers.append(RawServer(behave))
        return servers[-1]

    yield start
    for server in servers:
        server.stop()


@pytest.fixture
def json_server() -> Iterator[Callable[[Callable[[str, dict[str, Any]], tuple[int, Any]]], JsonServer]]:
    servers: list[JsonServer] = []

    def start(respond: Callable[[str, dict[str, Any]], tuple[int, Any]]) -> JsonServer:
        servers.append(JsonServer(respond))
        return servers[-1]

    yield start
    for server in servers:
        server.stop()
