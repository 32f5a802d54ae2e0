"""Keep API keys out of messages, logs and JSON records.

A server that rejects a key often echoes it (``Incorrect API key provided: sk-abc…``), and that
text would otherwise reach the warning, the error line and ``--json``. :func:`redact` replaces

* every secret handed to :func:`remember_secret` (the OpenAI backend remembers the key it sends),
* anything that looks like a key: ``sk-…`` tokens and the token after ``Bearer``,

with ``[redacted]``. Secrets shorter than :data:`MIN_SECRET` characters are not remembered: replacing
such a short string everywhere would mangle ordinary text.
"""

from __future__ import annotations

import re
import threading

REDACTED = "[redacted]"
#: The shortest remembered secret; shorter ones (placeholders such as ``x``) are left alone.
MIN_SECRET = 6

_PATTERNS = (
    re.compile(r"\bsk-[A-Za-z0-9_\-*.]{6,}"),  # OpenAI-style keys (also partly masked ones: sk-ab***cd)
    re.compile(r"(?i)(\bbearer\s+)[A-Za-z0-9_\-.~+/=]{6,}"),
)
#: The most secrets remembered; the oldest is forgotten past it (a process meets one or two keys).
MAX_SECRETS = 16
#: The secrets remembered, oldest first (a process-wide, bounded table: keys must be redacted from
#: any message, whichever backend or thread produced it).
_secrets: dict[str, None] = {}
_lock = threading.Lock()


def remember_secret(secret: str | None) -> None:
    """Redact ``secret`` from every later :func:`redact` (for the rest of the process, among the
    last :data:`MAX_SECRETS` secrets remembered)."""
    if secret and len(secret) >= MIN_SECRET:
        with _lock:
            _secrets.pop(secret, None)
            _secrets[secret] = None
            while len(_secrets) > MAX_SECRETS:
                del _secrets[next(iter(_secrets))]


def redact(text: str) -> str:
    """``text`` with remembered secrets and key-like tokens replaced by ``[redacted]``."""
    with _lock:
        secrets = sorted(_secrets, key=len, reverse=True)
    for secret in secrets:
        if secret in text:
            text = text.replace(secret, REDACTED)
    for pattern in _PATTERNS:
        text = pattern.sub(lambda match: (match.group(1) if match.groups() else "") + REDACTED, text)
    return text
