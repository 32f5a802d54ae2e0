"""Serve the local model over an OpenAI-compatible HTTP API on 127.0.0.1 (llama.cpp's own server).

``xllamacpp.Server(params)`` loads the model and starts llama.cpp's HTTP listener on
``params.hostnames``/``params.port`` (port 0 picks a free one; ``server.listening_address`` tells
which). It serves ``/v1/completions``, ``/v1/chat/completions``, ``/v1/models`` and ``/health``,
and deleting the ``Server`` stops the listener and frees the model.

Example::

    with serve_local() as base_url:  # "http://127.0.0.1:PORT/v1"
        backend = OpenAIBackend(base_url=base_url, use_completions=True)
        print(backend.complete(request).text)

Gemma-3 270M is a base model without a chat template: use the completions endpoint
(``use_completions=True``); chat requests get an answer, but not a useful one.
"""

from __future__ import annotations

import gc
import logging
import threading
import time
import urllib.error
import urllib.request
from collections.abc import Iterator
from contextlib import contextmanager
from pathlib import Path
from typing import Any

from hbtp.errors import BackendError
from hbtp.llm.backends.local import (
    DEFAULT_MODEL_ALIAS,
    import_xllamacpp,
    make_params,
    resolve_model_path,
    resolve_threads,
    start_server,
)

log = logging.getLogger(__name__)


@contextmanager
def serve_local(
    model_path: str | Path | None = None,
    host: str = "127.0.0.1",
    port: int = 0,
    threads: int | None = None,
    context: int = 4096,
    *,
    api_key: str | None = None,
    alias: str = DEFAULT_MODEL_ALIAS,
    startup_timeout: float = 120.0,
) -> Iterator[str]:
    """Run llama.cpp's OpenAI-compatible server on ``host:port`` and yield its base URL (``.../v1``).

    ``model_path`` defaults to the Gemma-3 270M GGUF (see :mod:`hbtp.llm.backends.local`); ``port`` 0
    picks a free port; ``threads`` defaults like :class:`~hbtp.llm.backends.local.LocalBackend`'s;
    ``api_key``, when given, is required from clients; the model is listed as ``alias``. Loading and
    the first health check must finish within ``startup_timeout`` seconds, else :class:`BackendError`.
    The server stops when the ``with`` block ends.
    """
    if not 0 <= port <= 65535:
        raise BackendError(f"port must be between 0 and 65535, not {port}")
    if startup_timeout <= 0:
        raise BackendError(f"startup_timeout must be positive, not {startup_timeout}")
    xllamacpp = import_xllamacpp()
    path = resolve_model_path(model_path)
    params = make_params(
        xllamacpp,
        path,
        threads=resolve_threads(threads),
        context=context,
        host=host,
        port=port,
        api_key=api_key,
        alias=alias,
    )
    deadline = time.monotonic() + startup_timeout
    holder = _start_in_thread(xllamacpp, params, path, startup_timeout)
    try:
        address = str(holder["server"].listening_address).rstrip("/")
        _wait_healthy(address, deadline, startup_timeout)
        log.info("serving %s at %s/v1", path.name, address)
        yield f"{address}/v1"
    finally:
        holder.clear()  # the last reference: llama.cpp's destructor stops the listener, frees the model
        gc.collect()
        log.info("stopped the local LLM server")


def _start_in_thread(xllamacpp: Any, params: Any, path: Path, timeout: float) -> dict[str, Any]:
    """``Server(params)`` in a worker thread, so a load that never ends cannot hang the caller."""
    holder: dict[str, Any] = {}
    lock = threading.Lock()
    abandoned = threading.Event()

    def start() -> None:
        try:
            server = start_server(xllamacpp, params, what=f"the local LLM server for {path}")
        except BackendError as error:
            holder["error"] = error
            return
        with lock:
            if abandoned.is_set():  # the caller gave up: free what came too late
                del server
                return
            holder["server"] = server

    worker = threading.Thread(target=start, name="hbtp-llm-server-start", daemon=True)
    worker.start()
    worker.join(timeout)
    with lock:
        if "server" in holder:
            return holder
        if "error" in holder:
            raise holder.pop("error")
        abandoned.set()
    raise BackendError(
        f"the local LLM server did not start within {timeout:g} s (loading {path}); "
        "the machine may be busy: retry, use fewer threads, or raise startup_timeout"
    )


def _wait_healthy(address: str, deadline: float, timeout: float) -> None:
    """Poll ``GET /health`` until it answers 200 (llama.cpp answers 503 while loading)."""
    last = "no answer"
    while True:
        remaining = deadline - time.monotonic()
        if remaining <= 0:
            raise BackendError(
                f"the local LLM server at {address} was not healthy within {timeout:g} s ({last}); "
                "retry, or raise startup_timeout"
            )
        try:
            with urllib.request.urlopen(f"{address}/health", timeout=min(5.0, remaining)) as response:
                if response.status == 200:
                    return
                last = f"HTTP {response.status}"
        except urllib.error.HTTPError as error:
            last = f"HTTP {error.code}"
        except OSError as error:
            last = str(error)
        time.sleep(min(0.1, max(0.0, deadline - time.monotonic())))
