"""OpenAIBackend against a scripted fake OpenAI-compatible server on 127.0.0.1: answers, retries and faults.

Each test tells the fake server what to answer, request by request; every failure must become one
clear :class:`BackendError` saying what went wrong and how to fix it, within a bounded time.
"""

from __future__ import annotations

import dataclasses
import json
import socket
import sys
import threading
import time
from collections.abc import Iterator
from dataclasses import dataclass, field
from http.server import BaseHTTPRequestHandler, ThreadingHTTPServer
from typing import Any

import pytest

pytest.importorskip("openai")

from hbtp.errors import BackendError
from hbtp.llm.backend import Message, Request
from hbtp.llm.backends.openai_backend import OpenAIBackend, is_local_url

HANG_LIMIT = 10.0  # a hanging handler gives up after this long, so no test can hang on it


@dataclass
class Answer:
    """One scripted answer: a status and a JSON (or raw) body, or no answer at all (``hang``)."""

    status: int = 200
    body: Any = None
    headers: dict[str, str] = field(default_factory=dict)
    hang: bool = False


class FakeServer:
    """A stdlib HTTP server that answers from ``script`` (the last answer repeats) and records requests."""

    def __init__(self) -> None:
        self.script: list[Answer] = []
        self.requests: list[dict[str, Any]] = []
        self.release = threading.Event()
        fake = self

        class Handler(BaseHTTPRequestHandler):
            def log_message(self, format: str, *args: Any) -> None:  # keep the test output quiet
                pass

            def do_GET(self) -> None:
                self._answer(None)

            def do_POST(self) -> None:
                length = int(self.headers.get("Content-Length") or 0)
                raw = self.rfile.read(length) if length else b""
                self._answer(json.loads(raw) if raw else None)

            def _answer(self, payload: Any) -> None:
                fake.requests.append(
                    {"path": self.path, "json": payload, "authorization": self.headers.get("Authorization")}
                )
                answer = fake.script[min(len(fake.requests), len(fake.script)) - 1] if fake.script else Answer()
                if answer.hang:
                    fake.release.wait(HANG_LIMIT)
                    return
                body = answer.body if isinstance(answer.body, bytes) else json.dumps(answer.body).encode()
                self.send_response(answer.status)
                headers = {"Content-Type": "application/json", **answer.headers}
                for name, value in headers.items():
                    self.send_header(name, value)
                self.send_header("Content-Length", str(len(body)))
                self.end_headers()
                self.wfile.write(body)

        self.httpd = ThreadingHTTPServer(("127.0.0.1", 0), Handler)
        self.httpd.daemon_threads = True
        self.httpd.block_on_close = False
        self.port = self.httpd.server_address[1]
        self.base_url = f"http://127.0.0.1:{self.port}/v1"
        self.thread = threading.Thread(target=self.httpd.serve_forever, kwargs={"poll_interval": 0.05}, daemon=True)
        self.thread.start()

    def stop(self) -> None:
        self.release.set()
        self.httpd.shutdown()
        self.httpd.server_close()
        self.thread.join(5)


def chat_body(text: str | None = "Optimal Actions: Walk_apple", **extra: Any) -> dict[str, Any]:
    return {
        "id": "chatcmpl-1",
        "object": "chat.completion",
        "created": 0,
        "model": "fake-model",
        "choices": [{"index": 0, "message": {"role": "assistant", "content": text}, "finish_reason": "stop"}],
        "usage": {"prompt_tokens": 12, "completion_tokens": 5, "total_tokens": 17},
        **extra,
    }


def error_body(message: str, kind: str = "invalid_request_error") -> dict[str, Any]:
    return {"error": {"message": message, "type": kind, "code": None}}


REQUEST = Request(
    messages=(Message("system", "You plan for a robot."), Message("user", "Goals: IsIn_apple_fridge")),
    completion_prompt="Goals: IsIn_apple_fridge\nOptimal Actions:",
    max_tokens=64,
    temperature=0.0,
    seed=7,
    stop=("\n\n",),
)


@pytest.fixture(autouse=True)
def _clean_environment(monkeypatch: pytest.MonkeyPatch) -> None:
    for name in ("OPENAI_API_KEY", "OPENAI_BASE_URL", "HBTP_LLM_MODEL", "OPENAI_ORG_ID", "OPENAI_PROJECT_ID"):
        monkeypatch.delenv(name, raising=False)


@pytest.fixture
def fake() -> Iterator[FakeServer]:
    server = FakeServer()
    yield server
    server.stop()


def backend_for(fake: FakeServer, **options: Any) -> OpenAIBackend:
    settings: dict[str, Any] = {"model": "fake-model", "timeout": 5.0, "max_retries": 3, "retry_delay": 0.01}
    settings.update(options)
    return OpenAIBackend(base_url=fake.base_url, **settings)


def failure(backend: OpenAIBackend, request: Request = REQUEST) -> str:
    with pytest.raises(BackendError) as caught:
        backend.complete(request)
    message = str(caught.value)
    assert "\n" not in message
    return message


def closed_port() -> int:
    with socket.socket() as probe:
        probe.bind(("127.0.0.1", 0))
        return int(probe.getsockname()[1])


# ---------------------------------------------------------------------------------- answers
def test_normal_chat_answer(fake: FakeServer) -> None:
    fake.script = [Answer(body=chat_body("Optimal Actions: Walk_apple, RightGrab_apple"))]
    backend = backend_for(fake)
    reply = backend.complete(REQUEST)
    assert reply.text == "Optimal Actions: Walk_apple, RightGrab_apple"
    assert (reply.prompt_tokens, reply.completion_tokens) == (12, 5)
    assert reply.seconds > 0
    assert reply.meta["retries"] == 0
    assert reply.meta["finish_reason"] == "stop"
    (sent,) = fake.requests
    assert sent["path"] == "/v1/chat/completions"
    body = sent["json"]
    assert body["model"] == "fake-model"
    assert body["messages"] == [
        {"role": "system", "content": "You plan for a robot."},
        {"role": "user", "content": "Goals: IsIn_apple_fridge"},
    ]
    assert (body["temperature"], body["seed"], body["max_tokens"], body["stop"]) == (0.0, 7, 64, ["\n\n"])
    assert sent["authorization"] == "Bearer not-needed"  # a local server needs no key
    backend.close()


def test_completions_endpoint_sends_the_completion_prompt(fake: FakeServer) -> None:
    fake.script = [
        Answer(
            body={
                "id": "cmpl-1",
                "object": "text_completion",
                "created": 0,
                "model": "fake-model",
                "choices": [{"index": 0, "text": " Walk_apple, RightGrab_apple", "finish_reason": "stop"}],
                "usage": {"prompt_tokens": 30, "completion_tokens": 9, "total_tokens": 39},
            }
        )
    ]
    reply = backend_for(fake, use_completions=True).complete(REQUEST)
    assert reply.text == " Walk_apple, RightGrab_apple"
    assert reply.completion_tokens == 9
    assert fake.requests[0]["path"] == "/v1/completions"
    assert fake.requests[0]["json"]["prompt"] == REQUEST.completion_prompt


def test_settings_come_from_the_environment(fake: FakeServer, monkeypatch: pytest.MonkeyPatch) -> None:
    monkeypatch.setenv("OPENAI_BASE_URL", fake.base_url)
    monkeypatch.setenv("OPENAI_API_KEY", "sk-test")
    monkeypatch.setenv("HBTP_LLM_MODEL", "env-model")
    fake.script = [Answer(body=chat_body("ok"))]
    backend = OpenAIBackend(timeout=5.0)
    assert backend.complete(REQUEST).text == "ok"
    assert fake.requests[0]["json"]["model"] == "env-model"
    assert fake.requests[0]["authorization"] == "Bearer sk-test"


def test_without_a_model_the_first_listed_model_is_used(fake: FakeServer) -> None:
    fake.script = [
        Answer(
            body={"object": "list", "data": [{"id": "served-model", "object": "model", "created": 0, "owned_by": "x"}]}
        ),
        Answer(body=chat_body("ok")),
    ]
    backend = backend_for(fake, model=None)
    assert backend.complete(REQUEST).text == "ok"
    assert [r["path"] for r in fake.requests] == ["/v1/models", "/v1/chat/completions"]
    assert fake.requests[1]["json"]["model"] == "served-model"


def test_a_server_without_a_model_list_gets_a_default_name(fake: FakeServer) -> None:
    fake.script = [Answer(404, error_body("no such route")), Answer(body=chat_body("ok"))]
    assert backend_for(fake, model=None).complete(REQUEST).text == "ok"
    assert fake.requests[1]["json"]["model"] == "default"


# ---------------------------------------------------------------------------------- retries
def test_429_twice_then_success_is_retried(fake: FakeServer) -> None:
    limited = Answer(429, error_body("Rate limit reached", "rate_limit_exceeded"))
    fake.script = [limited, limited, Answer(body=chat_body("after the wait"))]
    reply = backend_for(fake).complete(REQUEST)
    assert reply.text == "after the wait"
    assert reply.meta["retries"] == 2
    assert len(fake.requests) == 3


def test_500_then_success_is_retried(fake: FakeServer) -> None:
    fake.script = [Answer(500, error_body("internal error", "server_error")), Answer(body=chat_body("fine"))]
    reply = backend_for(fake).complete(REQUEST)
    assert reply.text == "fine"
    assert len(fake.requests) == 2


def test_retry_after_header_is_honoured(fake: FakeServer) -> None:
    fake.script = [Answer(503, error_body("busy"), headers={"Retry-After": "0.3"}), Answer(body=chat_body("ok"))]
    started = time.monotonic()
    assert backend_for(fake).complete(REQUEST).text == "ok"
    assert time.monotonic() - started >= 0.3


def test_persistent_503_gives_up_after_max_retries(fake: FakeServer) -> None:
    fake.script = [Answer(503, error_body("model is loading"))]
    message = failure(backend_for(fake, max_retries=2))
    assert len(fake.requests) == 3
    assert "HTTP 503" in message
    assert "after 2 retries" in message
    assert "model is loading" in message


def test_persistent_429_says_rate_limited(fake: FakeServer) -> None:
    fake.script = [Answer(429, error_body("slow down"))]
    message = failure(backend_for(fake, max_retries=1))
    assert "rate-limiting" in message
    assert "HTTP 429" in message
    assert len(fake.requests) == 2


# ---------------------------------------------------------------------------------- faults
@pytest.mark.parametrize("status", [401, 403])
def test_rejected_key_is_clear_and_not_retried(fake: FakeServer, status: int) -> None:
    fake.script = [Answer(status, error_body("Incorrect API key provided", "invalid_api_key"))]
    message = failure(backend_for(fake, api_key="sk-wrong"))
    assert f"the server at {fake.base_url} rejected the API key" in message
    assert "set OPENAI_API_KEY or --api-key" in message
    assert "Incorrect API key provided" in message
    assert len(fake.requests) == 1


def test_unknown_model_is_named(fake: FakeServer) -> None:
    fake.script = [Answer(404, error_body("The model `nope` does not exist", "model_not_found"))]
    message = failure(backend_for(fake, model="nope"))
    assert "model 'nope' not found on the server" in message
    assert "does not exist" in message
    assert "--model" in message
    assert len(fake.requests) == 1


def test_other_status_errors_are_reported_once(fake: FakeServer) -> None:
    fake.script = [Answer(400, error_body("messages must not be empty"))]
    message = failure(backend_for(fake))
    assert "refused the request with HTTP 400: messages must not be empty" in message
    assert len(fake.requests) == 1


def test_no_answer_times_out_without_retrying(fake: FakeServer) -> None:
    fake.script = [Answer(hang=True)]
    backend = backend_for(fake, timeout=1.0)
    started = time.monotonic()
    message = failure(backend)
    elapsed = time.monotonic() - started
    assert elapsed < 1.0 + 3.0
    assert f"no answer from the LLM server at {fake.base_url} within 1 s" in message
    assert "--llm-timeout" in message
    assert len(fake.requests) == 1


def test_garbage_json_is_reported(fake: FakeServer) -> None:
    fake.script = [Answer(body=b"{this is not json")]
    message = failure(backend_for(fake))
    assert f"the LLM server at {fake.base_url} sent a response that is not" in message


def test_html_page_instead_of_json_is_reported(fake: FakeServer) -> None:
    fake.script = [Answer(body=b"<html>hello</html>", headers={"Content-Type": "text/html"})]
    message = failure(backend_for(fake))
    assert "not a completion" in message or "not a valid completion" in message


def test_empty_choices_are_reported(fake: FakeServer) -> None:
    fake.script = [Answer(body=chat_body() | {"choices": []})]
    assert "sent a completion with no choices" in failure(backend_for(fake))


def test_choice_without_text_is_reported(fake: FakeServer) -> None:
    fake.script = [Answer(body=chat_body(None))]
    assert "sent a choice without text" in failure(backend_for(fake))


def test_server_down_is_reported_at_once() -> None:
    port = closed_port()
    backend = OpenAIBackend(base_url=f"http://127.0.0.1:{port}/v1", model="m", timeout=5.0, retry_delay=0.01)
    started = time.monotonic()
    message = failure(backend)
    assert time.monotonic() - started < 3.0
    assert message == (
        f"cannot reach the LLM server at http://127.0.0.1:{port}/v1: connection refused; "
        "is it running? set --base-url (or OPENAI_BASE_URL)"
    )


# ---------------------------------------------------------------------------------- set-up errors
def test_openai_api_without_a_key_fails_before_any_request() -> None:
    with pytest.raises(BackendError, match="no API key for the OpenAI API; set OPENAI_API_KEY or --api-key"):
        OpenAIBackend()


def test_missing_openai_package_says_how_to_install(monkeypatch: pytest.MonkeyPatch) -> None:
    monkeypatch.setitem(sys.modules, "openai", None)
    with pytest.raises(BackendError, match=r"pip install -e '\.\[openai\]'"):
        OpenAIBackend(base_url="http://127.0.0.1:9/v1")


@pytest.mark.parametrize(
    ("url", "local"),
    [
        ("http://127.0.0.1:8080/v1", True),
        ("http://localhost:11434/v1", True),
        ("http://[::1]:8000/v1", True),
        ("https://api.openai.com/v1", False),
        ("http://10.0.0.5:8000/v1", False),
    ],
)
def test_local_urls(url: str, local: bool) -> None:
    assert is_local_url(url) is local


# ------------------------------------------------------------------ constrained decoding
def constrained_request() -> Request:
    from hbtp.domains.scenarios import load_scenario
    from hbtp.llm.constrain import constraint_of

    return dataclasses.replace(REQUEST, constraint=constraint_of(load_scenario("robothow-small").task))


def test_the_schema_goes_as_response_format_and_json_comes_back_as_lines(fake: FakeServer) -> None:
    answer = {"optimal_actions": ["Walk_apple"], "vital_action_predicates": ["Walk"], "vital_objects": ["apple"]}
    fake.script = [Answer(body=chat_body(json.dumps(answer)))]
    reply = backend_for(fake).complete(constrained_request())
    sent = fake.requests[-1]["json"]
    assert sent["response_format"]["json_schema"]["schema"]["required"][0] == "optimal_actions"
    assert reply.text == "Optimal Actions: Walk_apple\nVital Action Predicates: Walk\nVital Objects: apple"
    assert reply.meta["constrained"]


def test_a_server_that_rejects_the_schema_is_asked_again_without(fake: FakeServer) -> None:
    fake.script = [Answer(400, error_body("response_format is not supported")), Answer(body=chat_body())]
    backend = backend_for(fake)
    reply = backend.complete(constrained_request())
    assert reply.text == "Optimal Actions: Walk_apple"
    assert "response_format" in fake.requests[-2]["json"]
    assert "response_format" not in fake.requests[-1]["json"]
    assert not backend.response_format  # not sent again
    backend.complete(constrained_request())
    assert "response_format" not in fake.requests[-1]["json"]


def test_no_constraints_sends_no_schema_and_a_server_ignoring_it_is_read_as_text(fake: FakeServer) -> None:
    fake.script = [Answer(body=chat_body())]
    reply = backend_for(fake, response_format=False).complete(constrained_request())
    assert "response_format" not in fake.requests[-1]["json"]
    assert reply.text == "Optimal Actions: Walk_apple"
    assert backend_for(fake).complete(constrained_request()).text == "Optimal Actions: Walk_apple"  # ignored
