"""Backends by name: ``local`` (default), ``openai``, ``oracle``, ``noisy-oracle``, ``replay:FILE``."""

from __future__ import annotations

from dataclasses import dataclass
from pathlib import Path

from hbtp.domains.scenarios import Scenario
from hbtp.errors import InputError
from hbtp.llm.backend import Backend
from hbtp.llm.backends.oracle import NoisyOracleBackend, OracleBackend
from hbtp.llm.backends.replay import RecordingBackend, ReplayBackend

BACKENDS = ("local", "openai", "oracle", "noisy-oracle", "replay:FILE")


@dataclass(frozen=True)
class BackendOptions:
    model: str | None = None
    base_url: str | None = None
    api_key: str | None = None
    timeout: float = 60.0
    model_path: str | None = None
    threads: int | None = None
    drop: float = 0.3
    insert: float = 0.3
    seed: int = 0
    record: str | None = None  # wrap the backend and record every exchange to this JSONL file
    prompt_cache: bool = False  # local: reuse llama.cpp's prompt cache (faster, answers depend on order)
    constrain: bool = True  # send the reply's grammar (local) or JSON schema (openai)


def make_backend(spec: str, scenario: Scenario, options: BackendOptions = BackendOptions()) -> Backend:
    """The backend named ``spec`` (see :data:`BACKENDS`), optionally recording to ``options.record``."""
    backend: Backend
    if spec == "oracle":
        backend = OracleBackend(scenario)
    elif spec == "noisy-oracle":
        backend = NoisyOracleBackend(scenario, drop=options.drop, insert=options.insert, seed=options.seed)
    elif spec.startswith("replay:"):
        backend = ReplayBackend(Path(spec.removeprefix("replay:")))
    elif spec == "replay":
        raise InputError("replay needs a file: --llm replay:FILE")
    elif spec == "openai":
        from hbtp.llm.backends.openai_backend import OpenAIBackend

        backend = OpenAIBackend(
            model=options.model,
            base_url=options.base_url,
            api_key=options.api_key,
            timeout=options.timeout,
            response_format=options.constrain,
        )
    elif spec == "local":
        from hbtp.llm.backends.local import LocalBackend

        backend = LocalBackend(
            model_path=options.model_path,
            threads=options.threads,
            seed=options.seed,
            prompt_cache=options.prompt_cache,
            constrain=options.constrain,
        )
    else:
        raise InputError(f"unknown LLM backend {spec!r}; choose one of: {', '.join(BACKENDS)}")
    if options.record:
        backend = RecordingBackend(backend, options.record)
    return backend
