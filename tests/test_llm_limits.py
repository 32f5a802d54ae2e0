"""Issue 14: LLM calls bounded in time and size, keys kept secret, record/replay across backends,
no wasted round, hints files that must match the goal, and bad LLM input as one-line errors.

Every server here is started by the test itself on 127.0.0.1, in a thread.
"""

from __future__ import annotations

import ast
import importlib.util
import json
import logging
import socket
import threading
import time
from collections.abc import Callable, Iterator
from http.server import BaseHTTPRequestHandler
from pathlib import Path
from typing import Any

import pytest

from hbtp.cli import EXIT_INPUT, EXIT_NOT_SOLVED, EXIT_OK, main
from hbtp.cli.hints_file import HintsSource, load_hints
from hbtp.datasets import load_dataset
from hbtp.deadline import Deadline
from hbtp.domains import Scenario
from hbtp.errors import BackendError, InputError
from hbtp.llm.backend import Message, PromptStyle, Reply, Request
from hbtp.llm.backends.oracle import OracleBackend
from hbtp.llm.parse import hints_from_record
from hbtp.llm.pool import example_pool
from hbtp.llm.redact import REDACTED, redact
from hbtp.pipeline import LoopOptions, RoundStatus, run_hbtp
from hbtp.pipeline import loop as loop_module
from hbtp.planning import Limits
from helpers import LoopbackHTTP, send_json_bytes

GOAL = "On_Coffee_Table1"  # robowaiter: the full-space fallback solves it in milliseconds
SLACK = 5.0  # generous: the bound asserted is the limit plus this


@pytest.fixture(autouse=True)
def _no_openai_environment(monkeypatch: pytest.MonkeyPatch) -> None:
    for name in ("OPENAI_API_KEY", "OPENAI_BASE_URL", "HBTP_LLM_MODEL", "OPENAI_ORG_ID", "OPENAI_PROJECT_ID"):
        monkeypatch.delenv(name, raising=False)


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


# ---------------------------------------------------------------------------------- servers
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


@pytest.fixture
def raw() -> Iterator[Callable[[Callable[[socket.socket, threading.Event], None]], RawServer]]:
    servers: list[RawServer] = []

    def start(behave: Callable[[socket.socket, threading.Event], None]) -> RawServer:
        servers.append(RawServer(behave))
        return servers[-1]

    yield start
    for server in servers:
        server.stop()


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


@pytest.fixture
def json_server() -> Iterator[Callable[[Callable[[str, dict[str, Any]], tuple[int, Any]]], JsonServer]]:
    servers: list[JsonServer] = []

    def start(respond: Callable[[str, dict[str, Any]], tuple[int, Any]]) -> JsonServer:
        servers.append(JsonServer(respond))
        return servers[-1]

    yield start
    for server in servers:
        server.stop()


def plan_openai(base_url: str, *extra: str) -> list[str]:
    return ["plan", "-s", "robowaiter", "-g", GOAL, "--llm", "openai", "--base-url", base_url, "--model", "m", *extra]


# ---------------------------------------------------------------------------------- 4: slow and huge replies
needs_openai = pytest.mark.skipif(importlib.util.find_spec("openai") is None, reason="the openai extra")


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


# ---------------------------------------------------------------------------------- F: keys stay secret
SECRET = "sk-test-0123456789abcdefSECRET"
PLAIN_SECRET = "my-plain-secret-42"


@needs_openai
@pytest.mark.parametrize("key", [SECRET, PLAIN_SECRET])
def test_a_401_that_echoes_the_key_is_redacted_everywhere(
    json_server: Any, capsys: pytest.CaptureFixture[str], caplog: pytest.LogCaptureFixture, key: str
) -> None:
    message = f"Incorrect API key provided: {key}. Authorization: Bearer {key}"
    server = json_server(lambda path, payload: (401, {"error": {"message": message, "type": "invalid_api_key"}}))
    with caplog.at_level(logging.DEBUG):
        code, out, err, _ = run(capsys, *plan_openai(server.base_url, "--api-key", key, "--json"))
    assert code == EXIT_OK
    for text in (out, err, caplog.text):
        assert key not in text
        assert "0123456789abcdef" not in text
    record = json.loads(out)
    assert REDACTED in record["llm"]["rounds"][0]["error"]
    assert "rejected the API key (HTTP 401" in record["llm"]["rounds"][0]["error"]


def test_redact_key_like_tokens() -> None:
    assert redact("key sk-abcdefghijkl1234 rejected") == f"key {REDACTED} rejected"
    assert redact("Authorization: Bearer abc.def-ghi_jkl") == f"Authorization: Bearer {REDACTED}"
    assert redact("Walk_apple, sk-x") == "Walk_apple, sk-x"  # too short to be a key


@needs_openai
def test_rate_limit_advice_names_no_missing_option(json_server: Any) -> None:
    from hbtp.llm.backends.openai_backend import OpenAIBackend

    server = json_server(lambda path, payload: (429, {"error": {"message": "slow down"}}))
    backend = OpenAIBackend(base_url=server.base_url, model="m", timeout=5.0, max_retries=0)
    with pytest.raises(BackendError) as caught:
        backend.complete(Request((Message("user", "Goals: X"),), ""))
    assert "max_retries" not in str(caught.value)
    backend.close()


# ---------------------------------------------------------------------------------- E: bad LLM input, exit 2
def test_bad_llm_inputs_are_one_line_errors(capsys: pytest.CaptureFixture[str], tmp_path: Path) -> None:
    binary = tmp_path / "replies.jsonl"
    binary.write_bytes(b"\xff\xfe\x00garbage")
    base = ["plan", "-s", "robowaiter", "-g", GOAL]
    cases = [
        ([*base, "--llm", f"replay:{binary}"], "not UTF-8"),
        ([*base, "--llm", f"replay:{tmp_path}"], "it is a folder"),
        ([*base, "--llm", "oracle", "--record", "/proc/x/rec.jsonl"], "the folder /proc/x does not exist"),
        ([*base, "--llm", "openai", "--base-url", "http://[::1"], "malformed"),
    ]
    for argv, expected in cases:
        code, _, err, _ = run(capsys, *argv)
        assert code == EXIT_INPUT, argv
        assert expected in one_line(err), argv


# ---------------------------------------------------------------------------------- 6: record / replay
def _replay_matches(capsys: pytest.CaptureFixture[str], argv: list[str], record_file: Path) -> None:
    code, out, err, _ = run(capsys, *argv, "--record", str(record_file), "--json")
    assert code == EXIT_OK, err
    recorded = json.loads(out)
    plan = argv[: argv.index("--llm")]
    code, out, err, _ = run(capsys, *plan, "--llm", f"replay:{record_file}", "--json")
    assert code == EXIT_OK, err
    replayed = json.loads(out)
    assert "no reply" not in err
    assert replayed["llm"]["outcome"] == recorded["llm"]["outcome"]
    assert [r["replies"] for r in replayed["llm"]["rounds"]] == [r["replies"] for r in recorded["llm"]["rounds"]]
    assert all(not r["error"] for r in replayed["llm"]["rounds"])


def test_record_then_replay_noisy_oracle(capsys: pytest.CaptureFixture[str], tmp_path: Path) -> None:
    goal = load_dataset("table2_robothow_small_50")[0].goal
    argv = ["plan", "-s", "robothow-small", "-g", goal, "--llm", "noisy-oracle", "--noise-drop", "0.6"]
    _replay_matches(capsys, argv, tmp_path / "noisy.jsonl")


@needs_openai
def test_record_then_replay_openai(
    json_server: Any, capsys: pytest.CaptureFixture[str], tmp_path: Path, robowaiter: Scenario
) -> None:
    oracle = OracleBackend(robowaiter)

    def respond(path: str, payload: dict[str, Any]) -> tuple[int, Any]:
        goal = payload["messages"][-1]["content"].rsplit("Goals: ", 1)[1].split("\n", 1)[0]
        text = oracle.complete(Request((), "", goal=goal)).text
        choice = {"index": 0, "finish_reason": "stop", "message": {"role": "assistant", "content": text}}
        return 200, {"id": "x", "object": "chat.completion", "created": 0, "model": "m", "choices": [choice]}

    server = json_server(respond)
    _replay_matches(capsys, plan_openai(server.base_url), tmp_path / "openai.jsonl")


def test_record_then_replay_local(
    capsys: pytest.CaptureFixture[str], tmp_path: Path, monkeypatch: pytest.MonkeyPatch, robowaiter: Scenario
) -> None:
    """The local backend (completion prompts, 160 tokens) replays under the chat defaults (256)."""
    from hbtp.llm.backends import local

    oracle = OracleBackend(robowaiter)

    class FakeLlama:
        def handle_completions(self, body: dict[str, Any], callback: Callable[[Any], bool]) -> None:
            goal = body["prompt"].rsplit("Goals: ", 1)[1].split("\n", 1)[0]
            text = oracle.complete(Request((), "", goal=goal)).text.removeprefix("Optimal Actions:")
            callback({"choices": [{"text": text, "finish_reason": "stop"}], "usage": {}})

    def load(self: Any) -> None:
        self._server = FakeLlama()

    find_spec = importlib.util.find_spec
    monkeypatch.setattr(
        importlib.util, "find_spec", lambda name, *a: object() if name == "xllamacpp" else find_spec(name, *a)
    )
    monkeypatch.setattr(local.LocalBackend, "load", load)
    argv = ["plan", "-s", "robowaiter", "-g", GOAL, "--llm", "local"]
    _replay_matches(capsys, argv, tmp_path / "local.jsonl")


@pytest.mark.llm
def test_record_then_replay_the_real_local_model(capsys: pytest.CaptureFixture[str], tmp_path: Path) -> None:
    pytest.importorskip("xllamacpp")
    argv = ["plan", "-s", "robowaiter", "-g", GOAL, "--llm", "local", "--feedback-rounds", "1"]
    _replay_matches(capsys, argv, tmp_path / "gemma.jsonl")


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


def test_the_key_ignores_style_defaults() -> None:
    base = Request((Message("user", "Goals: X"),), "Goals: X\nOptimal Actions:", goal="X")
    for changed in (
        Request(base.messages, base.completion_prompt, goal="X", max_tokens=160),
        Request(base.messages, base.completion_prompt, goal="X", stop=("\n\n",), deadline=Deadline(3.0), round=1),
    ):
        assert changed.key() == base.key()
    assert Request(base.messages, "other", goal="X").key() != base.key()
    assert Request(base.messages, base.completion_prompt, goal="X", temperature=0.7).key() != base.key()


# ---------------------------------------------------------------------------------- 7: no wasted round
MISSING = "Optimal Actions: Walk_Coffee\nVital Action Predicates: Walk\nVital Objects: Coffee"


def test_a_failed_feedback_round_does_not_search_again(robowaiter: Scenario, monkeypatch: pytest.MonkeyPatch) -> None:
    searches: list[int] = []
    search = getattr(loop_module, "search")  # noqa: B009 (not re-exported: mypy)

    def counting(*args: Any, **kwargs: Any) -> Any:
        searches.append(1)
        return search(*args, **kwargs)

    monkeypatch.setattr(loop_module, "search", counting)

    class Failing:
        name = "failing"
        prompt_style = PromptStyle.CHAT

        def __init__(self) -> None:
            self.calls = 0

        def complete(self, request: Request) -> Reply:
            self.calls += 1
            if self.calls == 1:
                return Reply(MISSING)
            raise BackendError("HTTP 503")

        def close(self) -> None:
            pass

    loop = run_hbtp(robowaiter, GOAL, Failing(), example_pool(robowaiter), LoopOptions(grammar_retries=0))
    assert len(searches) == 1  # round 0 only: round 1 got no answer, so its space is round 0's
    assert loop.outcome.label == "fallback"
    assert [r.status for r in loop.rounds][1] is RoundStatus.SKIPPED
    assert loop.to_dict()["rounds"][1]["status"] == "skipped"
    assert loop.rounds[1].error == "HTTP 503"


# ---------------------------------------------------------------------------------- 5: hints files
def _robowaiter_text() -> str:
    from hbtp.datasets import dataset_path

    return dataset_path("fewshot_robowaiter_100").read_text(encoding="utf-8")


def test_a_multi_record_file_with_a_malformed_record_gives_the_goals_record(
    tmp_path: Path, robowaiter: Scenario, caplog: pytest.LogCaptureFixture
) -> None:
    records = load_dataset("fewshot_robowaiter_100")
    wanted = records[10]
    blocks = _robowaiter_text().split("\n\n")
    blocks[3] = blocks[3].replace("Environment:1", "Environment:").replace("Vital Objects:", "Vital Objects :: ::")
    path = tmp_path / "RW_llm_data.txt"
    path.write_text("\n\n".join(blocks), encoding="utf-8")
    goal = robowaiter.task.resolve_goal(wanted.goal)
    with caplog.at_level(logging.WARNING):
        hints = load_hints(HintsSource(file=path), robowaiter, goal, Limits(time_s=10))
    assert hints == hints_from_record(wanted)
    assert hints != hints_from_record(records[0])
    assert "not a valid dataset file" in caplog.text


def test_a_hints_file_without_the_goal_is_rejected(
    tmp_path: Path, robowaiter: Scenario, capsys: pytest.CaptureFixture[str]
) -> None:
    records = load_dataset("fewshot_robowaiter_100")
    goals = {r.goal.strip() for r in records}
    absent = next(g for g in ("RobotNear_BrightTable2", "RobotNear_Bar", "RobotNear_Table1") if g not in goals)
    malformed = tmp_path / "malformed.txt"
    malformed.write_text(_robowaiter_text().replace("Environment:1", "Environment:", 1), encoding="utf-8")
    single = tmp_path / "single.txt"
    single.write_text(_robowaiter_text().split("\n\n")[0] + "\n", encoding="utf-8")
    for path in (malformed, single):
        code, _, err, _ = run(capsys, "plan", "-s", "robowaiter", "-g", absent, "--hints", str(path))
        assert code == EXIT_INPUT
        assert f"the goal {absent}" in one_line(err)
    with pytest.raises(InputError, match="its only record is not for the goal"):
        load_hints(HintsSource(file=single), robowaiter, robowaiter.task.resolve_goal(absent), Limits(time_s=10))


def test_a_non_utf8_hints_file_is_one_line(tmp_path: Path, capsys: pytest.CaptureFixture[str]) -> None:
    path = tmp_path / "hints.txt"
    path.write_bytes(b"Optimal Actions: Walk_\xff\xfe\n")
    code, _, err, _ = run(capsys, "plan", "-s", "robowaiter", "-g", GOAL, "--hints", str(path))
    assert code == EXIT_INPUT
    assert "not UTF-8" in one_line(err)


def test_a_raw_reply_without_a_goal_still_works(
    tmp_path: Path, capsys: pytest.CaptureFixture[str], robowaiter: Scenario
) -> None:
    path = tmp_path / "reply.txt"
    reply = OracleBackend(robowaiter).complete(Request((), "", goal=GOAL)).text
    path.write_text(f"Sure!\n{reply}\n", encoding="utf-8")
    code, _, err, _ = run(capsys, "plan", "-s", "robowaiter", "-g", GOAL, "--hints", str(path))
    assert code == EXIT_OK, err


# ---------------------------------------------------------------------------------- 13: quiet tests
def test_tests_do_not_print() -> None:
    offenders = []
    for path in sorted(Path(__file__).parent.glob("*.py")):
        for node in ast.walk(ast.parse(path.read_text(encoding="utf-8"))):
            if isinstance(node, ast.Call) and isinstance(node.func, ast.Name) and node.func.id == "print":
                offenders.append(f"{path.name}:{node.lineno}")
    assert offenders == []
