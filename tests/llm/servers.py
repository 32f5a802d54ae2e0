"""What the LLM tests share: servers on 127.0.0.1 (raw sockets, or an OpenAI-compatible JSON API),
the command run in process, and its one-line error.
"""

from __future__ import annotations

import importlib.util
import json
import socket
import threading
import time
from collections.abc import Callable
from http.server import BaseHTTPRequestHandler
from typing import Any

import pytest

from hbtp.cli import main
from helpers import LoopbackHTTP, send_json_bytes

GOAL = "On_Coffee_Table1"  # robowaiter: the full-space fallback solves it in milliseconds
SLACK = 5.0  # generous: the bound asserted is the limit plus this


needs_openai = pytest.mark.skipif(importlib.util.find_spec("openai") is None, reason="the openai extra")


def run(capsys: pytest.CaptureFixture[str], *argv: str) -> tuple[int, str, str, float]:
    started = time.monotonic()
    code = main(list(argv))
    elapsed = time.monotonic() - started
    captured = capsys.readouterr()
    assert "Traceback" not in captured.err
    return code, captured.out, captured.err, elapsed


def one_line(err: str) -> str:
    lines = [line for line in err.splitlines() if line.strip()]
    assert len(lines) == 1, err
    assert "internal error" not in lines[0]
    return lines[0]


class RawServer:
    """A socket server on 127.0.0.1: reads one HTTP request per connection, then ``behave(conn, stop)``."""

    def __init__(self, behave: Callable[[socket.socket, threading.Event], None]) -> None:
        self.behave = behave
        self.stop_event = threading.Event()
        self.requests = 0
        self.listener = socket.socket()
        self.listener.bind(("127.0.0.1", 0))
        self.listener.listen(8)
        self.listener.settimeout(0.1)
        self.base_url = f"http://127.0.0.1:{self.listener.getsockname()[1]}/v1"
        self.thread = threading.Thread(target=self._accept, daemon=True)
        self.thread.start()

    def _accept(self) -> None:
        while not self.stop_event.is_set():
            try:
                conn, _ = self.listener.accept()
            except OSError:
                continue
            threading.Thread(target=self._serve, args=(conn,), daemon=True).start()

    def _serve(self, conn: socket.socket) -> None:
        with conn:
            conn.settimeout(5)
            data = b""
            try:
                while b"\r\n\r\n" not in data:
                    chunk = conn.recv(65536)
                    if not chunk:
                        return
                    data += chunk
                head, _, body = data.partition(b"\r\n\r\n")
                length = 0
                for line in head.split(b"\r\n"):
                    if line.lower().startswith(b"content-length:"):
                        length = int(line.split(b":")[1])
                while len(body) < length:
                    body += conn.recv(65536)
                self.requests += 1
                self.behave(conn, self.stop_event)
            except OSError:
                return

    def stop(self) -> None:
        self.stop_event.set()
        self.thread.join(5)
        self.listener.close()


class JsonServer:
    """An OpenAI-compatible server on 127.0.0.1: ``respond(path, payload)`` gives (status, JSON body)."""

    def __init__(self, respond: Callable[[str, dict[str, Any]], tuple[int, Any]]) -> None:
        self.requests: list[dict[str, Any]] = []
        server = self

        class Handler(BaseHTTPRequestHandler):
            def log_message(self, format: str, *args: Any) -> None:
                pass

            def do_GET(self) -> None:
                self._answer({})

            def do_POST(self) -> None:
                length = int(self.headers.get("Content-Length") or 0)
                self._answer(json.loads(self.rfile.read(length) or b"{}"))

            def _answer(self, payload: dict[str, Any]) -> None:
                server.requests.append({"path": self.path, "json": payload})
                status, body = respond(self.path, payload)
                data = json.dumps(body).encode()
                send_json_bytes(self, status, data)

        self.http = LoopbackHTTP(Handler)
        self.base_url = self.http.base_url

    def stop(self) -> None:
        self.http.close()


def plan_openai(base_url: str, *extra: str) -> list[str]:
    return ["plan", "-s", "robowaiter", "-g", GOAL, "--llm", "openai", "--base-url", base_url, "--model", "m", *extra]
