"""Backends by name: ``local`` (default), ``openai``, ``oracle``, ``noisy-oracle``, ``replay:FILE``;
``auto:BACKEND`` (``auto`` alone: ``auto:local``) asks BACKEND only when planning LLM-free is slow
(:func:`hbtp.pipeline.auto.plan_auto`)."""

from __future__ import annotations

from dataclasses import dataclass
from pathlib import Path

from hbtp.domains.scenarios import Scenario
from hbtp.errors import InputError
from hbtp.llm.backend import Backend
from hbtp.llm.backends.oracle import InstructionOracle, NoisyOracleBackend, OracleBackend
from hbtp.llm.backends.replay import RecordingBackend, ReplayBackend

BACKENDS = ("local", "openai", "oracle", "noisy-oracle", "replay:FILE")
#: The prefix of ``auto:BACKEND``.
AUTO = "auto"


def auto_backend(spec: str) -> str | None:
    """The backend of ``auto:BACKEND`` (``auto``: ``local``), or ``None`` when ``spec`` is not auto."""
    if spec == AUTO:
        return "local"
    if not spec.startswith(AUTO + ":"):
        return None
    inner = spec.removeprefix(AUTO + ":")
    known = inner in BACKENDS[:-1] or (inner.startswith("replay:") and inner != "replay:")
    if not known:  # checked now: the backend may never be built
        raise InputError(f"auto needs a backend: auto:BACKEND with one of {', '.join(BACKENDS)}, not {spec!r}")
    return inner


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
    elif auto_backend(spec) is not None:
        raise InputError(f"{spec} is a mode of hbtp plan --llm, not a backend; give the backend alone")
    else:
        raise InputError(f"unknown LLM backend {spec!r}; choose one of: {', '.join(BACKENDS)}")
    if options.record:
        backend = RecordingBackend(backend, options.record)
    return backend


def make_goal_backend(spec: str, scenario: Scenario, options: BackendOptions = BackendOptions()) -> Backend:
    """The backend that turns instructions into goals: ``oracle`` answers the instruction dataset's
    recorded goal; a model backend (``local``, ``openai``, ``replay:FILE``) as :func:`make_backend`."""
    if spec == "noisy-oracle" or auto_backend(spec) is not None:
        raise InputError(
            f"--llm {spec} answers plans, not goals; for --instruction choose local, openai, oracle or replay:FILE"
        )
    if spec != "oracle":
        return make_backend(spec, scenario, options)
    backend: Backend = InstructionOracle(scenario)
    return RecordingBackend(backend, options.record) if options.record else backend
