"""Any OpenAI-compatible server: OpenAI, vLLM, Ollama's ``/v1``, llama.cpp (and :func:`serve_local`).

Settings come from the arguments, else the environment: ``OPENAI_API_KEY``, ``OPENAI_BASE_URL``
and ``HBTP_LLM_MODEL``. A server on this machine (localhost, 127.0.0.0/8, ::1) needs no key: a
placeholder is sent. With no model named, OpenAI's own API gets :data:`DEFAULT_OPENAI_MODEL` and any
other server the first model it lists at ``/models``.

Requests go to ``chat.completions`` with ``request.messages``, or, with ``use_completions``, to the
legacy ``completions`` endpoint with ``request.completion_prompt`` (for base models).

Retries are done here, not by the openai client (whose own retries would also repeat timeouts, so a
hung server would take ``(max_retries + 1) * timeout``): HTTP 408, 409, 429 and 5xx, and dropped
connections, are retried up to ``max_retries`` times with exponential backoff (``retry_delay``,
doubled each time, at most 8 s, with jitter; a ``Retry-After`` of up to 60 s is honoured). A refused
connection, a timeout and every other HTTP error fail at once with a one-line :class:`BackendError`
that says what happened and how to fix it.

Constrained decoding: a request's ``constraint`` goes to chat endpoints as ``response_format``
(a JSON schema of the three lists; llama.cpp's server, vLLM and OpenAI enforce it) and to the
completions endpoint as llama.cpp's ``grammar``; a JSON answer is turned back into the three lines.
A server that refuses it (HTTP 400 or 422) is asked again at once without it, and not sent one
again; ``response_format=False`` (``--no-response-format``) never sends one. A server that ignores
it answers in text, which the grammar checker reads as before.

Bounds: ``timeout`` (or the request's ``deadline``, when sooner) bounds the *whole* call: the
model list, every attempt, the backoff between them and the reading of the reply. Each attempt runs
in a helper thread that is abandoned (and its connections closed) at the deadline, so a server that
trickles its reply a few bytes at a time cannot hold the call past it. A reply body larger than
:data:`MAX_REPLY_BYTES` is refused as soon as it grows past that size.

The API key never appears in a message or a log line: it is remembered by :mod:`hbtp.llm.redact`,
and every server text quoted is redacted (a 401 reply often echoes the key).
"""

from __future__ import annotations

import email.utils
import ipaddress
import json
import logging
import math
import os
import random
import re
import threading
import time
from collections.abc import Callable, Iterable
from types import ModuleType
from typing import Any, TypeVar
from urllib.parse import urlsplit

from hbtp.deadline import Deadline, seconds_left, within
from hbtp.errors import BackendError
from hbtp.llm.backend import PromptStyle, Reply, Request
from hbtp.llm.constrain import reply_from_json, response_format
from hbtp.llm.redact import redact, remember_secret

log = logging.getLogger(__name__)

#: The model used on OpenAI's own API when neither ``model`` nor ``HBTP_LLM_MODEL`` names one.
DEFAULT_OPENAI_MODEL = "gpt-4o-mini"
OPENAI_BASE_URL = "https://api.openai.com/v1"
#: The API key sent to servers on this machine when none is set (they ignore it).
LOCAL_PLACEHOLDER_KEY = "not-needed"
RETRY_STATUSES = frozenset({408, 409, 429, 500, 502, 503, 504})
MAX_RETRY_DELAY = 8.0
MAX_RETRY_AFTER = 60.0
#: The largest reply body accepted (a completion of a few hundred tokens is a few kilobytes).
MAX_REPLY_BYTES = 2_000_000

_T = TypeVar("_T")
#: The arguments that carry a request's constraint.
_CONSTRAINT_FIELDS = frozenset({"response_format", "extra_body"})
#: A server's refusal of a constraint it does not support (HTTP 400 or 422 from the server).
_REFUSALS = re.compile(r"HTTP (400|422)")


class _Deadline(Exception):
    """The call's time is up (raised while reading a reply)."""


class _TooLarge(Exception):
    """The reply body grew past :data:`MAX_REPLY_BYTES`."""


def is_local_url(url: str) -> bool:
    """Whether ``url`` names a server on this machine (localhost, a loopback address)."""
    try:
        host = (urlsplit(url).hostname or "").lower()
    except ValueError:  # a malformed address such as http://[::1
        return False
    if host == "localhost" or host.endswith(".localhost"):
        return True
    try:
        return ipaddress.ip_address(host).is_loopback
    except ValueError:
        return False


def _import_openai() -> ModuleType:
    try:
        import openai
    except ImportError:
        raise BackendError(
            "the openai backend needs the openai package; install the openai extra: pip install -e '.[openai]'"
        ) from None
    return openai


def _one_line(text: object, limit: int = 200) -> str:
    line = redact(" ".join(str(text).split()))
    return line if len(line) <= limit else line[: limit - 1] + "…"


def _is_refused(error: BaseException) -> bool:
    seen: set[int] = set()
    current: BaseException | None = error
    while current is not None and id(current) not in seen:
        seen.add(id(current))
        if isinstance(current, ConnectionRefusedError) or "connection refused" in str(current).lower():
            return True
        current = current.__cause__ or current.__context__
    return False


def _root_reason(error: BaseException) -> str:
    """The innermost message of an exception chain (the openai client wraps the useful one)."""
    reason = str(error)
    seen: set[int] = set()
    current: BaseException | None = error
    while current is not None and id(current) not in seen:
        seen.add(id(current))
        if str(current):
            reason = str(current)
        current = current.__cause__ or current.__context__
    return _one_line(reason)


def _retry_after(headers: Any) -> float | None:
    """Seconds from ``Retry-After`` (seconds or an HTTP date) or ``retry-after-ms``, if present."""
    if headers is None:
        return None
    try:
        milliseconds = headers.get("retry-after-ms")
        if milliseconds:
            return float(milliseconds) / 1000.0
        value = headers.get("retry-after")
        if not value:
            return None
        try:
            return float(value)
        except ValueError:
            when = email.utils.parsedate_to_datetime(value)
            return when.timestamp() - time.time()
    except (TypeError, ValueError, AttributeError):
        return None


def _read_capped(chunks: Iterable[bytes], deadline: Deadline, limit: int = MAX_REPLY_BYTES) -> bytes:
    """The body from ``chunks``; :class:`_Deadline` past ``deadline``, :class:`_TooLarge` past ``limit``."""
    parts: list[bytes] = []
    size = 0
    for chunk in chunks:
        size += len(chunk)
        if size > limit:
            raise _TooLarge
        parts.append(chunk)
        if deadline.expired():
            raise _Deadline
    return b"".join(parts)


def _parse_url(url: str) -> tuple[str, str | None]:
    """``url``'s scheme and host; :class:`BackendError` for a malformed address."""
    try:
        parts = urlsplit(url)
        return parts.scheme, parts.hostname
    except ValueError as error:
        raise BackendError(
            f"the base URL {url!r} is malformed ({error}); give one like http://127.0.0.1:8080/v1"
        ) from None


class OpenAIBackend:
    """An OpenAI-compatible chat (or completions) endpoint, with retries and clear errors.

    ``timeout`` bounds the whole of one :meth:`complete` (retries, backoff and reading included);
    ``max_retries`` is the number of retries after the first attempt; ``retry_delay`` the first
    backoff in seconds.
    """

    def __init__(
        self,
        model: str | None = None,
        base_url: str | None = None,
        api_key: str | None = None,
        timeout: float = 60.0,
        max_retries: int = 3,
        use_completions: bool = False,
        *,
        retry_delay: float = 0.5,
        response_format: bool = True,
    ) -> None:
        if not (timeout > 0 and math.isfinite(timeout)):
            raise BackendError(f"the LLM timeout (--llm-timeout) must be a positive number of seconds, not {timeout}")
        if max_retries < 0:
            raise BackendError(f"max_retries must be 0 or more, not {max_retries}")
        self._openai = _import_openai()
        self.base_url = (base_url or os.environ.get("OPENAI_BASE_URL") or OPENAI_BASE_URL).rstrip("/")
        scheme, host = _parse_url(self.base_url)
        if scheme not in ("http", "https") or not host:
            raise BackendError(
                f"the base URL must start with http:// or https:// and name a host, not {self.base_url!r}"
            )
        self.official = host == urlsplit(OPENAI_BASE_URL).hostname
        key = api_key or os.environ.get("OPENAI_API_KEY")
        remember_secret(key)
        if not key:
            if self.official:
                raise BackendError(
                    "no API key for the OpenAI API; set OPENAI_API_KEY or --api-key, "
                    "or point --base-url at a local server"
                )
            key = LOCAL_PLACEHOLDER_KEY
            if not is_local_url(self.base_url):
                log.info("no API key set for %s; sending a placeholder key", self.base_url)
        self.model: str | None = model or os.environ.get("HBTP_LLM_MODEL") or None
        if self.model is None and self.official:
            self.model = DEFAULT_OPENAI_MODEL
        self.timeout = timeout
        self.max_retries = max_retries
        self.retry_delay = retry_delay
        self.use_completions = use_completions
        #: Send a request's constraint (chat: ``response_format`` with the JSON schema; completions:
        #: llama.cpp's ``grammar``); turned off after a server refuses one with HTTP 400 or 422.
        self.response_format = response_format
        self.name = f"openai:{self.model or 'auto'}@{self.base_url}"
        self._max_tokens_field = "max_tokens"
        self._key = key
        self._client: Any = self._new_client()

    # ------------------------------------------------------------------ public API
    @property
    def prompt_style(self) -> PromptStyle:
        """Completion with ``use_completions`` (a base model), else chat."""
        return PromptStyle.COMPLETION if self.use_completions else PromptStyle.CHAT

    def complete(self, request: Request) -> Reply:
        """Ask the server; the reply's ``seconds`` include retries, its ``meta`` the model and retry count.

        The whole call ends within ``timeout`` (or by ``request.deadline`` when that is sooner)."""
        started = time.perf_counter()
        limit = max(0.0, min(self.timeout, seconds_left(request.deadline)))
        deadline = within(request.deadline, self.timeout) or Deadline(self.timeout, started)
        model = self._resolve_model(deadline, limit)
        arguments, endpoint = request_arguments(
            request, model, completions=self.use_completions, constrain=self.response_format
        )

        def send(client: Any, seconds: float) -> Any:
            resource = client.completions if self.use_completions else client.chat.completions
            with resource.with_streaming_response.create(
                **arguments, **{self._max_tokens_field: request.max_tokens}, timeout=seconds
            ) as response:
                return self._body(response, deadline)

        try:
            response, retries = self._call(send, what=f"model {model!r}", deadline=deadline, limit=limit)
        except BackendError as error:
            if not _CONSTRAINT_FIELDS & arguments.keys() or not _REFUSALS.search(str(error)):
                raise
            log.warning("%s; asking again without constraints (--no-response-format)", error)
            self.response_format = False
            for name in _CONSTRAINT_FIELDS:
                arguments.pop(name, None)
            response, retries = self._call(send, what=f"model {model!r}", deadline=deadline, limit=limit)
        text, finish = extract_choice(response, self.base_url, self.use_completions)
        usage = _dict(response.get("usage"))
        constrained = bool(_CONSTRAINT_FIELDS & arguments.keys())
        return Reply(
            text=(reply_from_json(text) or text) if constrained else text,
            seconds=time.perf_counter() - started,
            prompt_tokens=_int_or_none(usage.get("prompt_tokens")),
            completion_tokens=_int_or_none(usage.get("completion_tokens")),
            meta={
                "model": response.get("model") or model,
                "endpoint": endpoint,
                "finish_reason": finish,
                "retries": retries,
                "constrained": constrained,
            },
        )

    def close(self) -> None:
        """Close the HTTP connections."""
        self._client.close()

    # ------------------------------------------------------------------ internals
    def _new_client(self) -> Any:
        # The client's own retries are off: they would repeat timeouts too (see the module's doc).
        return self._openai.OpenAI(api_key=self._key, base_url=self.base_url, timeout=self.timeout, max_retries=0)

    def _body(self, response: Any, deadline: Deadline) -> Any:
        """The JSON of a streamed 2xx response, read within ``deadline`` and :data:`MAX_REPLY_BYTES`."""
        declared = response.headers.get("content-length")
        if declared and declared.isdigit() and int(declared) > MAX_REPLY_BYTES:
            raise _TooLarge
        body = _read_capped(response.iter_bytes(), deadline)
        try:
            return json.loads(body)
        except ValueError as error:  # also a body that is not UTF-8
            raise BackendError(
                f"the LLM server at {self.base_url} sent a response that is not a valid completion "
                f"(not JSON: {_one_line(error, 80)}); is the base URL an OpenAI-compatible /v1 endpoint?"
            ) from None

    def _resolve_model(self, deadline: Deadline, limit: float) -> str:
        """The configured model, else the first one the server lists (asked once)."""
        if self.model is None:
            openai = self._openai

            def list_models(client: Any, seconds: float) -> Any:
                try:
                    with client.models.with_streaming_response.list(timeout=seconds) as response:
                        return self._body(response, deadline)
                except openai.NotFoundError:  # a server without /models: it serves whatever it has
                    return None

            listing, _ = self._call(list_models, what="the model list", deadline=deadline, limit=limit)
            data = _dict(listing).get("data")
            first = _dict(data[0]).get("id") if isinstance(data, list) and data else None
            self.model = str(first) if first else "default"
            log.info("using model %r, the first one %s lists", self.model, self.base_url)
            self.name = f"openai:{self.model}@{self.base_url}"
        return self.model

    def _attempt(self, send: Callable[[Any, float], _T], deadline: Deadline, limit: float) -> _T:
        """``send(client, seconds left)`` in a helper thread, abandoned at ``deadline``."""
        remaining = deadline.remaining()
        if remaining <= 0:
            raise self._timeout(limit)
        client = self._client
        outcome: list[Any] = []
        failure: list[BaseException] = []

        def work() -> None:
            try:
                outcome.append(send(client, remaining))
            except BaseException as error:  # handed to the caller's thread
                failure.append(error)

        worker = threading.Thread(target=work, name="hbtp-openai-request", daemon=True)
        worker.start()
        worker.join(remaining)
        if worker.is_alive():  # still connecting or reading: give up and cut its connections
            self._client = self._new_client()
            try:
                client.close()
            except Exception as error:  # closing under a running request may complain; it is gone anyway
                log.debug("closing an abandoned connection: %s", redact(str(error)))
            raise self._timeout(limit)
        if failure:
            raise failure[0]
        result: _T = outcome[0]
        return result

    def _timeout(self, limit: float) -> BackendError:
        if limit < self.timeout:  # the caller's budget (hbtp plan -t) ran out first
            return BackendError(
                f"no answer from the LLM server at {self.base_url} in the {limit:.1f} s left of the time limit; "
                "raise the time limit (-t) or use a faster server"
            )
        return BackendError(
            f"no answer from the LLM server at {self.base_url} within {limit:g} s; "
            "the server may be overloaded or the model too slow: raise --llm-timeout or use a smaller model"
        )

    def _call(self, send: Callable[[Any, float], _T], *, what: str, deadline: Deadline, limit: float) -> tuple[_T, int]:
        """``send`` with retries, all within ``deadline``; every failure becomes a :class:`BackendError`."""
        openai = self._openai
        retries = 0
        while True:
            try:
                return self._attempt(send, deadline, limit), retries
            except (openai.APITimeoutError, _Deadline):
                raise self._timeout(limit) from None
            except _TooLarge:
                raise BackendError(
                    f"the LLM server at {self.base_url} sent a reply larger than {MAX_REPLY_BYTES // 1_000_000} MB; "
                    "is the base URL an OpenAI-compatible /v1 endpoint?"
                ) from None
            except openai.APIConnectionError as error:
                if _is_refused(error):
                    raise BackendError(
                        f"cannot reach the LLM server at {self.base_url}: connection refused; "
                        "is it running? set --base-url (or OPENAI_BASE_URL)"
                    ) from None
                failed = BackendError(
                    f"cannot reach the LLM server at {self.base_url}: {_root_reason(error)}"
                    f"{after_retries(retries)}; check the address and the server, or set --base-url"
                )
                if retries >= self.max_retries:
                    raise failed from None
                delay = self._backoff(retries, None)
                if delay >= deadline.remaining():
                    raise failed from None  # no time left to retry
                log.warning(
                    "connection to %s failed (%s); retry %d in %.1f s",
                    self.base_url,
                    _root_reason(error),
                    retries + 1,
                    delay,
                )
            except openai.APIStatusError as error:
                status = error.status_code
                if status in RETRY_STATUSES and retries < self.max_retries:
                    delay = self._backoff(retries, getattr(error.response, "headers", None))
                    if delay >= deadline.remaining():
                        raise status_error(error, what, retries, self.base_url) from None  # no time left to retry
                    log.warning("%s answered HTTP %d; retry %d in %.1f s", self.base_url, status, retries + 1, delay)
                elif status == 400 and self._max_tokens_field == "max_tokens" and "max_completion_tokens" in str(error):
                    self._max_tokens_field = "max_completion_tokens"  # newer OpenAI models renamed it
                    continue
                else:
                    raise status_error(error, what, retries, self.base_url) from None
            except (openai.OpenAIError, ValueError) as error:
                raise BackendError(
                    f"the LLM server at {self.base_url} sent a response that is not a valid completion: "
                    f"{_one_line(error)}"
                ) from None
            time.sleep(delay)
            retries += 1

    def _backoff(self, retries: int, headers: Any) -> float:
        server_says = _retry_after(headers)
        if server_says is not None and 0 < server_says <= MAX_RETRY_AFTER:
            return server_says
        return min(self.retry_delay * 2.0**retries, MAX_RETRY_DELAY) * (1.0 - 0.25 * random.random())


def request_arguments(
    request: Request, model: str, *, completions: bool, constrain: bool
) -> tuple[dict[str, Any], str]:
    """The request's arguments for the client (and the endpoint's name): the prompt, sampling,
    stop strings and, with ``response_format``, the reply's constraint."""
    if completions:
        if not request.completion_prompt.strip():
            raise BackendError("use_completions needs request.completion_prompt, but it is empty")
        arguments: dict[str, Any] = {"model": model, "prompt": request.completion_prompt}
        endpoint = "completions"
    else:
        messages = [{"role": m.role, "content": m.content} for m in request.messages]
        if not messages:
            if not request.completion_prompt.strip():
                raise BackendError("the request has neither messages nor a completion prompt")
            messages = [{"role": "user", "content": request.completion_prompt}]
        arguments = {"model": model, "messages": messages}
        endpoint = "chat"
    arguments["temperature"] = request.temperature
    arguments["seed"] = request.seed
    if request.stop:
        arguments["stop"] = list(request.stop)
    if request.constraint is not None and constrain:
        if completions:  # llama.cpp's own field: a base model continues the three lines
            arguments["extra_body"] = {"grammar": request.constraint.gbnf}
        else:
            arguments["response_format"] = response_format(request.constraint)
    return arguments, endpoint


def extract_choice(response: Any, where: str, completions: bool) -> tuple[str, str | None]:
    """The first choice's text and finish reason; :class:`BackendError` for anything else."""
    choices = response.get("choices") if isinstance(response, dict) else None
    if not isinstance(choices, list):
        raise BackendError(
            f"the LLM server at {where} sent a response that is not a completion "
            f"(got {_one_line(repr(response), 80)}); is the base URL an OpenAI-compatible /v1 endpoint?"
        )
    if not choices:
        raise BackendError(f"the LLM server at {where} sent a completion with no choices")
    choice = _dict(choices[0])
    text = choice.get("text") if completions else _dict(choice.get("message")).get("content")
    if not isinstance(text, str):
        raise BackendError(f"the LLM server at {where} sent a choice without text")
    finish = choice.get("finish_reason")
    if not text:
        log.warning("the LLM server at %s sent an empty text (finish reason %s)", where, finish)
    return text, finish if isinstance(finish, str) else None


def status_error(error: Any, what: str, retries: int, where: str) -> BackendError:
    """The one-line error of an HTTP error status, with what to do."""
    status = int(error.status_code)
    detail = _status_detail(error)
    if status in (401, 403):
        return BackendError(
            f"the server at {where} rejected the API key (HTTP {status}: {detail}); set OPENAI_API_KEY or --api-key"
        )
    if status == 404:
        return BackendError(
            f"{what} not found on the server at {where} (HTTP 404: {detail}); choose one it lists at "
            f"{where}/models with --model or HBTP_LLM_MODEL, and check that the base URL ends in /v1"
        )
    if status == 429:
        return BackendError(
            f"the server at {where} is rate-limiting requests (HTTP 429: {detail}){after_retries(retries)}; "
            "wait a while and try again"
        )
    if status >= 500:
        return BackendError(
            f"the LLM server at {where} failed with HTTP {status}{after_retries(retries)}: {detail}; "
            "check the server's log and try again"
        )
    return BackendError(f"the LLM server at {where} refused the request with HTTP {status}: {detail}")


def after_retries(retries: int) -> str:
    return f" (after {retries} {'retry' if retries == 1 else 'retries'})" if retries else ""


def _status_detail(error: Any) -> str:
    """The server's own words from an HTTP error: ``{"error": {"message": ...}}`` or the raw message."""
    body = getattr(error, "body", None)
    if isinstance(body, dict):
        inner = body.get("error", body)
        if isinstance(inner, dict) and inner.get("message"):
            return _one_line(inner["message"])
        if isinstance(inner, str) and inner:
            return _one_line(inner)
    return _one_line(getattr(error, "message", None) or error)


def _int_or_none(value: Any) -> int | None:
    return value if isinstance(value, int) and not isinstance(value, bool) else None


def _dict(value: Any) -> dict[str, Any]:
    return value if isinstance(value, dict) else {}
