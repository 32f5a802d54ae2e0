"""API keys never appear in output, logs or records: a server that echoes the key is redacted
everywhere, and advice never names a missing option.
"""

from __future__ import annotations

import json
import logging
from typing import Any

import pytest
from servers import needs_openai, plan_openai, run

from hbtp.cli import EXIT_OK
from hbtp.errors import BackendError
from hbtp.llm.backend import Message, Request
from hbtp.llm.redact import REDACTED, redact

SECRET = "sk-test-0123456789abcdefSECRET"
PLAIN_SECRET = "my-plain-secret-42"


@needs_openai
@pytest.mark.parametrize("key", [SECRET, PLAIN_SECRET])
def test_a_401_that_echoes_the_key_is_redacted_everywhere(
    json_server: Any, capsys: pytest.CaptureFixture[str], caplog: pytest.LogCaptureFixture, key: str
) -> None:
    message = f"Incorrect API key provided: {key}. Authorization: Bearer {key}"
    server = json_server(lambda path, payload: (401, {"error": {"message": message, "type": "invalid_api_key"}}))
    with caplog.at_level(logging.DEBUG):
        code, out, err, _ = run(capsys, *plan_openai(server.base_url, "--api-key", key, "--json"))
    assert code == EXIT_OK
    for text in (out, err, caplog.text):
        assert key not in text
        assert "0123456789abcdef" not in text
    record = json.loads(out)
    assert REDACTED in record["llm"]["rounds"][0]["error"]
    assert "rejected the API key (HTTP 401" in record["llm"]["rounds"][0]["error"]


def test_redact_key_like_tokens() -> None:
    assert redact("key sk-abcdefghijkl1234 rejected") == f"key {REDACTED} rejected"
    assert redact("Authorization: Bearer abc.def-ghi_jkl") == f"Authorization: Bearer {REDACTED}"
    assert redact("Walk_apple, sk-x") == "Walk_apple, sk-x"  # too short to be a key


@needs_openai
def test_rate_limit_advice_names_no_missing_option(json_server: Any) -> None:
    from hbtp.llm.backends.openai_backend import OpenAIBackend

    server = json_server(lambda path, payload: (429, {"error": {"message": "slow down"}}))
    backend = OpenAIBackend(base_url=server.base_url, model="m", timeout=5.0, max_retries=0)
    with pytest.raises(BackendError) as caught:
        backend.complete(Request((Message("user", "Goals: X"),), ""))
    assert "max_retries" not in str(caught.value)
    backend.close()
