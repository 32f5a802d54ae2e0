"""Backends by name: ``local`` (default), ``openai``, ``oracle``, ``noisy-oracle``, ``replay:FILE``;
``auto:BACKEND`` (``auto`` alone: ``auto:local``) asks BACKEND only when planning LLM-free is slow
(:func:`hbtp.pipeline.auto.plan_auto`)."""

from __future__ import annotations

import enum
from dataclasses import dataclass, field
from pathlib import Path

from hbtp.domains.scenarios import Scenario
from hbtp.errors import InputError
from hbtp.llm.backend import Backend
from hbtp.llm.backends.adapters import AdapterChoice, choose_adapter, instruction_adapter, world_key
from hbtp.llm.backends.oracle import InstructionOracle, NoisyOracleBackend, OracleBackend
from hbtp.llm.backends.replay import RecordingBackend, ReplayBackend

BACKENDS = ("local", "openai", "oracle", "noisy-oracle", "replay:FILE")
#: The prefix of ``auto:BACKEND``.
AUTO = "auto"


class BackendKind(enum.Enum):
    """The backends hbtp can ask."""

    LOCAL = "local"
    OPENAI = "openai"
    ORACLE = "oracle"
    NOISY_ORACLE = "noisy-oracle"
    REPLAY = "replay"

    @property
    def is_model(self) -> bool:
        """A model (or its recorded replies), as opposed to an oracle that plans its answers."""
        return self in (BackendKind.LOCAL, BackendKind.OPENAI, BackendKind.REPLAY)


@dataclass(frozen=True)
class LlmSpec:
    """What ``--llm`` names, read once at the command line: a backend (``replay`` with its file),
    and whether it is asked in auto mode (only when LLM-free planning finds no verdict in time)."""

    kind: BackendKind
    replay_file: Path | None = None
    auto: bool = False

    @classmethod
    def parse(cls, text: str) -> LlmSpec:
        """``local``, ``openai``, ``oracle``, ``noisy-oracle``, ``replay:FILE``, ``auto`` (``auto:local``)
        or ``auto:BACKEND``; anything else is an :class:`InputError`."""
        auto = text == AUTO or text.startswith(AUTO + ":")
        inner = "local" if text == AUTO else text.removeprefix(AUTO + ":") if auto else text
        if inner.startswith("replay:") and inner != "replay:":
            return cls(BackendKind.REPLAY, Path(inner.removeprefix("replay:")), auto)
        if inner in ("replay", "replay:"):
            raise InputError("replay needs a file: --llm replay:FILE")
        try:
            kind = BackendKind(inner)
        except ValueError:
            if auto:
                raise InputError(
                    f"auto needs a backend: auto:BACKEND with one of {', '.join(BACKENDS)}, not {text!r}"
                ) from None
            raise InputError(f"unknown LLM backend {text!r}; choose one of: {', '.join(BACKENDS)}") from None
        return cls(kind, None, auto)

    @property
    def backend(self) -> LlmSpec:
        """The backend alone (not in auto mode)."""
        return LlmSpec(self.kind, self.replay_file)

    def __str__(self) -> str:
        name = f"replay:{self.replay_file}" if self.kind is BackendKind.REPLAY else self.kind.value
        return f"{AUTO}:{name}" if self.auto else name


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
    adapter: AdapterChoice = field(default_factory=AdapterChoice)  # local: the LoRA adapter (auto: the world's own)


def make_backend(
    spec: LlmSpec | str, scenario: Scenario, options: BackendOptions = BackendOptions(), *, instructions: bool = False
) -> Backend:
    """The backend named ``spec`` (see :data:`BACKENDS`), optionally recording to ``options.record``;
    ``instructions``: it will read instructions too (a local model then also loads the companion of
    its adapter that reads them, if it has one)."""
    spec = spec if isinstance(spec, LlmSpec) else LlmSpec.parse(spec)
    if spec.auto:
        raise InputError(f"{spec} is a mode of hbtp plan --llm, not a backend; give the backend alone")
    backend: Backend
    kind = spec.kind
    if kind is BackendKind.ORACLE:
        backend = OracleBackend(scenario)
    elif kind is BackendKind.NOISY_ORACLE:
        backend = NoisyOracleBackend(scenario, drop=options.drop, insert=options.insert, seed=options.seed)
    elif kind is BackendKind.REPLAY:
        assert spec.replay_file is not None
        backend = ReplayBackend(spec.replay_file)
    elif kind is BackendKind.OPENAI:
        from hbtp.llm.backends.openai_backend import OpenAIBackend

        backend = OpenAIBackend(
            model=options.model,
            base_url=options.base_url,
            api_key=options.api_key,
            timeout=options.timeout,
            response_format=options.constrain,
        )
    else:
        from hbtp.llm.backends.local import LocalBackend

        adapter, reader = _adapters_of(scenario, options)
        backend = LocalBackend(
            model_path=options.model_path,
            threads=options.threads,
            seed=options.seed,
            prompt_cache=options.prompt_cache,
            constrain=options.constrain,
            adapter=adapter,
            instruction_adapter=reader if instructions else None,
        )
    if options.record:
        backend = RecordingBackend(backend, options.record)
    return backend


def _adapters_of(scenario: Scenario, options: BackendOptions) -> tuple[Path | None, Path | None]:
    """The adapter the local model uses in ``scenario``, and its companion that reads instructions
    (``None``: the adapter reads them too; see :mod:`hbtp.llm.backends.adapters`)."""
    from hbtp.llm.backends.local import default_model_sha256

    files = (Path(scenario.domain_file), Path(scenario.problem_file))
    world = world_key(*files) if all(path.is_file() for path in files) else None
    base = default_model_sha256() if options.model_path is None else None
    adapter = choose_adapter(options.adapter, scenario=scenario.name, world=world, base_sha256=base)
    return adapter, instruction_adapter(options.adapter, adapter, world=world, base_sha256=base)


def make_goal_backend(spec: LlmSpec | str, scenario: Scenario, options: BackendOptions = BackendOptions()) -> Backend:
    """The backend that turns instructions into goals: ``oracle`` answers the instruction dataset's
    recorded goal; a model backend (``local``, ``openai``, ``replay:FILE``) as :func:`make_backend`.
    ``auto:BACKEND`` reads the instruction with BACKEND (auto mode is about the hints)."""
    spec = (spec if isinstance(spec, LlmSpec) else LlmSpec.parse(spec)).backend
    if spec.kind is BackendKind.NOISY_ORACLE:
        raise InputError(
            f"--llm {spec} answers plans, not goals; for --instruction choose local, openai, oracle or replay:FILE"
        )
    if spec.kind is not BackendKind.ORACLE:
        return make_backend(spec, scenario, options, instructions=True)
    backend: Backend = InstructionOracle(scenario)
    return RecordingBackend(backend, options.record) if options.record else backend
