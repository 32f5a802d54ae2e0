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
"""

from __future__ import annotations

import email.utils
import ipaddress
import logging
import os
import random
import time
from collections.abc import Callable
from types import ModuleType
from typing import Any, TypeVar
from urllib.parse import urlsplit

from hbtp.errors import BackendError
from hbtp.llm.backend import Reply, Request

log = logging.getLogger(__name__)

#: The model used on OpenAI's own API when neither ``model`` nor ``HBTP_LLM_MODEL`` names one.
DEFAULT_OPENAI_MODEL = "gpt-4o-mini"
OPENAI_BASE_URL = "https://api.openai.com/v1"
#: The API key sent to servers on this machine when none is set (they ignore it).
LOCAL_PLACEHOLDER_KEY = "not-needed"
RETRY_STATUSES = frozenset({408, 409, 429, 500, 502, 503, 504})
MAX_RETRY_DELAY = 8.0
MAX_RETRY_AFTER = 60.0

_T = TypeVar("_T")


def is_local_url(url: str) -> bool:
    """Whether ``url`` names a server on this machine (localhost, a loopback address)."""
    host = (urlsplit(url).hostname or "").lower()
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
    line = " ".join(str(text).split())
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


class OpenAIBackend:
    """An OpenAI-compatible chat (or completions) endpoint, with retries and clear errors.

    ``timeout`` bounds each attempt (connect, send, and each wait for data); ``max_retries`` is the
    number of retries after the first attempt; ``retry_delay`` the first backoff in seconds.
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
    ) -> None:
        if timeout <= 0:
            raise BackendError(f"the request timeout must be positive, not {timeout}")
        if max_retries < 0:
            raise BackendError(f"max_retries must be 0 or more, not {max_retries}")
        self._openai = _import_openai()
        self.base_url = (base_url or os.environ.get("OPENAI_BASE_URL") or OPENAI_BASE_URL).rstrip("/")
        if urlsplit(self.base_url).scheme not in ("http", "https"):
            raise BackendError(f"the base URL must start with http:// or https://, not {self.base_url!r}")
        self.official = urlsplit(self.base_url).hostname == urlsplit(OPENAI_BASE_URL).hostname
        key = api_key or os.environ.get("OPENAI_API_KEY")
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
        self.name = f"openai:{self.model or 'auto'}@{self.base_url}"
        self._max_tokens_field = "max_tokens"
        # The client's own retries are off: they would repeat timeouts too (see the module's doc).
        self._client = self._openai.OpenAI(api_key=key, base_url=self.base_url, timeout=timeout, max_retries=0)

    # ------------------------------------------------------------------ public API
    def complete(self, request: Request) -> Reply:
        """Ask the server; the reply's ``seconds`` include retries, its ``meta`` the model and retry count."""
        model = self._resolve_model()
        started = time.perf_counter()
        if self.use_completions:
            if not request.completion_prompt.strip():
                raise BackendError("use_completions needs request.completion_prompt, but it is empty")
            arguments: dict[str, Any] = {"model": model, "prompt": request.completion_prompt}
            create: Callable[..., Any] = self._client.completions.create
        else:
            messages = [{"role": m.role, "content": m.content} for m in request.messages]
            if not messages:
                if not request.completion_prompt.strip():
                    raise BackendError("the request has neither messages nor a completion prompt")
                messages = [{"role": "user", "content": request.completion_prompt}]
            arguments = {"model": model, "messages": messages}
            create = self._client.chat.completions.create
        arguments["temperature"] = request.temperature
        arguments["seed"] = request.seed
        if request.stop:
            arguments["stop"] = list(request.stop)

        def send() -> Any:
            return create(**arguments, **{self._max_tokens_field: request.max_tokens})

        response, retries = self._call(send, what=f"model {model!r}")
        text, finish = self._extract(response)
        usage = getattr(response, "usage", None)
        return Reply(
            text=text,
            seconds=time.perf_counter() - started,
            prompt_tokens=_int_or_none(getattr(usage, "prompt_tokens", None)),
            completion_tokens=_int_or_none(getattr(usage, "completion_tokens", None)),
            meta={
                "model": getattr(response, "model", None) or model,
                "endpoint": "completions" if self.use_completions else "chat",
                "finish_reason": finish,
                "retries": retries,
            },
        )

    def close(self) -> None:
        """Close the HTTP connections."""
        self._client.close()

    # ------------------------------------------------------------------ internals
    def _resolve_model(self) -> str:
        """The configured model, else the first one the server lists (asked once)."""
        if self.model is None:
            openai = self._openai

            def list_models() -> Any:
                try:
                    return self._client.models.list()
                except openai.NotFoundError:  # a server without /models: it serves whatever it has
                    return None

            listing, _ = self._call(list_models, what="the model list")
            data = getattr(listing, "data", None) or []
            first = getattr(data[0], "id", None) if data else None
            self.model = str(first) if first else "default"
            log.info("using model %r, the first one %s lists", self.model, self.base_url)
            self.name = f"openai:{self.model}@{self.base_url}"
        return self.model

    def _call(self, send: Callable[[], _T], *, what: str) -> tuple[_T, int]:
        """``send()`` with retries; every failure becomes a :class:`BackendError`."""
        openai = self._openai
        retries = 0
        while True:
            try:
                return send(), retries
            except openai.APITimeoutError:
                raise BackendError(
                    f"no answer from the LLM server at {self.base_url} within {self.timeout:g} s; "
                    "the server may be overloaded or the model too slow: raise --timeout or use a smaller model"
                ) from None
            except openai.APIConnectionError as error:
                if _is_refused(error):
                    raise BackendError(
                        f"cannot reach the LLM server at {self.base_url}: connection refused; "
                        "is it running? set --base-url (or OPENAI_BASE_URL)"
                    ) from None
                if retries >= self.max_retries:
                    raise BackendError(
                        f"cannot reach the LLM server at {self.base_url}: {_root_reason(error)}"
                        f"{self._after(retries)}; check the address and the server, or set --base-url"
                    ) from None
                delay = self._backoff(retries, None)
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
                    log.warning("%s answered HTTP %d; retry %d in %.1f s", self.base_url, status, retries + 1, delay)
                elif status == 400 and self._max_tokens_field == "max_tokens" and "max_completion_tokens" in str(error):
                    self._max_tokens_field = "max_completion_tokens"  # newer OpenAI models renamed it
                    continue
                else:
                    raise self._status_error(error, what, retries) from None
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

    def _after(self, retries: int) -> str:
        return f" (after {retries} {'retry' if retries == 1 else 'retries'})" if retries else ""

    def _status_error(self, error: Any, what: str, retries: int) -> BackendError:
        status = int(error.status_code)
        detail = _status_detail(error)
        where = self.base_url
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
                f"the server at {where} is rate-limiting requests (HTTP 429: {detail}){self._after(retries)}; "
                "wait and try again, or raise max_retries"
            )
        if status >= 500:
            return BackendError(
                f"the LLM server at {where} failed with HTTP {status}{self._after(retries)}: {detail}; "
                "check the server's log and try again"
            )
        return BackendError(f"the LLM server at {where} refused the request with HTTP {status}: {detail}")

    def _extract(self, response: Any) -> tuple[str, str | None]:
        """The first choice's text and finish reason; :class:`BackendError` for anything else."""
        where = self.base_url
        choices = getattr(response, "choices", None)
        if not isinstance(choices, list):
            raise BackendError(
                f"the LLM server at {where} sent a response that is not a completion "
                f"(got {_one_line(repr(response), 80)}); is the base URL an OpenAI-compatible /v1 endpoint?"
            )
        if not choices:
            raise BackendError(f"the LLM server at {where} sent a completion with no choices")
        choice = choices[0]
        if self.use_completions:
            text = getattr(choice, "text", None)
        else:
            text = getattr(getattr(choice, "message", None), "content", None)
        if not isinstance(text, str):
            raise BackendError(f"the LLM server at {where} sent a choice without text")
        finish = getattr(choice, "finish_reason", None)
        if not text:
            log.warning("the LLM server at %s sent an empty text (finish reason %s)", where, finish)
        return text, finish if isinstance(finish, str) else None


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
    return value if isinstance(value, int) else None
