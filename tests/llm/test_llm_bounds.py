"""LLM calls bounded in time and size: a trickling server cut at the call's timeout, a huge reply
refused early, retries stopped at the deadline, and the command's one deadline carried to every call.

Every server here is started by the test itself on 127.0.0.1, in a thread.
"""

from __future__ import annotations

import json
import socket
import threading
import time
from collections.abc import Callable
from typing import Any

import pytest
from servers import GOAL, SLACK, needs_openai, plan_openai, run

from hbtp.cli import EXIT_INPUT, EXIT_NOT_SOLVED, EXIT_OK
from hbtp.deadline import Deadline
from hbtp.domains import Scenario
from hbtp.errors import BackendError
from hbtp.llm.backend import Message, PromptStyle, Reply, Request
from hbtp.llm.backends.oracle import OracleBackend
from hbtp.pipeline import LoopOptions, run_hbtp


def trickle_body(conn: socket.socket, stop: threading.Event) -> None:
    conn.sendall(b"HTTP/1.1 200 OK\r\nContent-Type: application/json\r\nContent-Length: 100000\r\n\r\n")
    while not stop.wait(0.05):
        conn.sendall(b'{"a":')  # a few bytes at a time, never the end


def trickle_headers(conn: socket.socket, stop: threading.Event) -> None:
    conn.sendall(b"HTTP/1.1 200 OK\r\n")
    while not stop.wait(0.05):
        conn.sendall(b"X")  # one endless header line


def huge_reply(conn: socket.socket, stop: threading.Event) -> None:
    size = 27_000_000
    conn.sendall(f"HTTP/1.1 200 OK\r\nContent-Type: application/json\r\nContent-Length: {size}\r\n\r\n".encode())
    block = b" " * 65536
    sent = 0
    while sent < size and not stop.is_set():
        conn.sendall(block[: size - sent])
        sent += len(block)


def huge_chunked_reply(conn: socket.socket, stop: threading.Event) -> None:
    conn.sendall(b"HTTP/1.1 200 OK\r\nContent-Type: application/json\r\nTransfer-Encoding: chunked\r\n\r\n")
    block = b" " * 65536
    for _ in range(27_000_000 // len(block)):
        if stop.is_set():
            return
        conn.sendall(f"{len(block):x}\r\n".encode() + block + b"\r\n")
    conn.sendall(b"0\r\n\r\n")


@needs_openai
@pytest.mark.parametrize("behave", [trickle_body, trickle_headers], ids=["body", "headers"])
def test_a_trickling_server_is_cut_at_the_llm_timeout(
    raw: Any, capsys: pytest.CaptureFixture[str], behave: Callable[[socket.socket, threading.Event], None]
) -> None:
    server = raw(behave)
    code, out, err, elapsed = run(capsys, *plan_openai(server.base_url, "--llm-timeout", "2", "-t", "20", "--json"))
    assert elapsed < 2 + SLACK, elapsed
    assert code == EXIT_OK, err  # the fallback still solves it, within -t
    record = json.loads(out)
    assert record["llm"]["outcome"] == "fallback"
    assert "no answer from the LLM server" in record["llm"]["rounds"][0]["error"]
    assert "--llm-timeout" in record["llm"]["rounds"][0]["error"]
    assert server.requests == 1  # a timeout is not retried


@needs_openai
def test_the_time_limit_bounds_the_whole_llm_loop(raw: Any, capsys: pytest.CaptureFixture[str]) -> None:
    server = raw(trickle_body)
    code, out, _err, elapsed = run(capsys, *plan_openai(server.base_url, "--llm-timeout", "60", "-t", "3", "--json"))
    assert elapsed < 3 + SLACK, elapsed
    assert code == EXIT_NOT_SOLVED  # nothing left for the fallback: a timeout, as documented
    record = json.loads(out)
    assert record["status"] == "timeout"
    assert "s left of the time limit" in record["llm"]["rounds"][0]["error"]


@needs_openai
@pytest.mark.parametrize("behave", [huge_reply, huge_chunked_reply], ids=["content-length", "chunked"])
def test_a_huge_reply_is_refused_early(
    raw: Any, capsys: pytest.CaptureFixture[str], behave: Callable[[socket.socket, threading.Event], None]
) -> None:
    server = raw(behave)
    code, out, err, elapsed = run(capsys, *plan_openai(server.base_url, "--llm-timeout", "30", "-t", "60", "--json"))
    assert elapsed < SLACK, elapsed
    assert code == EXIT_OK, err
    assert "larger than 2 MB" in json.loads(out)["llm"]["rounds"][0]["error"]


@needs_openai
def test_retries_stop_at_the_deadline(json_server: Any) -> None:
    from hbtp.llm.backends.openai_backend import OpenAIBackend

    server = json_server(lambda path, payload: (503, {"error": {"message": "busy"}}))
    backend = OpenAIBackend(base_url=server.base_url, model="m", timeout=1.0, max_retries=20, retry_delay=0.3)
    started = time.monotonic()
    with pytest.raises(BackendError, match="HTTP 503"):
        backend.complete(Request((Message("user", "Goals: X"),), "Goals: X\nOptimal Actions:"))
    assert time.monotonic() - started < 1.0 + 1.0
    backend.close()


def test_every_llm_call_gets_the_time_left(robowaiter: Scenario) -> None:
    class Slow:
        name = "slow"
        prompt_style = PromptStyle.CHAT

        def __init__(self) -> None:
            self.limits: list[float | None] = []

        def complete(self, request: Request) -> Reply:
            left = None if request.deadline is None else request.deadline.remaining()
            self.limits.append(left)
            time.sleep(min(left or 10.0, 10.0))
            raise BackendError("too slow")

        def close(self) -> None:
            pass

    backend = Slow()
    started = time.monotonic()
    loop = run_hbtp(robowaiter, GOAL, backend, (), LoopOptions(), Deadline(1.0))
    assert time.monotonic() - started < 1.0 + SLACK
    assert len(backend.limits) == 1
    assert backend.limits[0] is not None
    assert 0 < backend.limits[0] <= 1.0
    assert loop.outcome.label == "failed"
    assert loop.result.status.value == "timeout"


def test_llm_timeout_must_be_a_positive_finite_number(capsys: pytest.CaptureFixture[str]) -> None:
    for value in ("nan", "inf", "0", "-1"):
        code, _, err, _ = run(capsys, *plan_openai("http://127.0.0.1:9/v1", "--llm-timeout", value))
        assert code == EXIT_INPUT
        assert "--llm-timeout" in err
        assert "positive number of seconds" in err


def test_every_llm_call_gets_the_command_deadline(robowaiter: Scenario) -> None:
    """One deadline from the caller to the innermost call: each request carries the run's own
    :class:`Deadline` (not a number of seconds re-computed on the way)."""
    seen: list[Deadline | None] = []

    class Recording(OracleBackend):
        def complete(self, request: Request) -> Reply:
            seen.append(request.deadline)
            return super().complete(request)

    deadline = Deadline(120.0)
    loop = run_hbtp(robowaiter, GOAL, Recording(robowaiter), (), LoopOptions(), deadline)
    assert loop.result.solved
    assert seen
    assert all(d is deadline for d in seen)
