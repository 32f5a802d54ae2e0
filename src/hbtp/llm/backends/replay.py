"""Record real replies and replay them offline: a JSONL file of ``{"key": request hash, "reply": text}``.

``ReplayBackend`` answers from the file (a missing key is a :class:`BackendError` that names it);
``RecordingBackend`` wraps any backend and appends each new exchange to the file, so a run with a
real model can be repeated exactly, offline and in tests.
"""

from __future__ import annotations

import json
import time
from pathlib import Path

from hbtp.errors import BackendError, InputError
from hbtp.files import InputKind, open_output, read_text
from hbtp.llm.backend import Backend, PromptStyle, Reply, Request
from hbtp.llm.spelling import Spelling


def _read(path: Path) -> dict[str, str]:
    return _read_lines(path)[0]


def _read_lines(path: Path) -> tuple[dict[str, str], bool, Spelling]:
    """The replies of a record file by key, whether they were a taught model's (a line says so), and
    how it spelled its plans' actions."""
    table: dict[str, str] = {}
    taught, spelling = False, Spelling.UNDERSCORED
    if not path.exists():
        return table, taught, spelling
    try:
        text = read_text(path, InputKind.RECORD)
    except InputError as error:
        raise BackendError(f"{error}; give a JSONL file written by --record") from None
    for number, line in enumerate(text.splitlines(), 1):
        if not line.strip():
            continue
        try:
            entry = json.loads(line)
            table[str(entry["key"])] = str(entry["reply"])
            taught = taught or entry.get("taught") is True
            if "spelling" in entry:
                spelling = Spelling[str(entry["spelling"]).upper()]
        except (json.JSONDecodeError, KeyError, TypeError, AttributeError):
            raise BackendError(f'{path}:{number}: not a replay line (expected {{"key": ..., "reply": ...}})') from None
    return table, taught, spelling


class ReplayBackend:
    name = "replay"
    #: A request's key leaves out what the style changes (``max_tokens``), so any style replays.
    prompt_style = PromptStyle.CHAT

    def __init__(self, path: str | Path) -> None:
        self.path = Path(path)
        if not self.path.exists():
            raise BackendError(f"replay file {self.path} does not exist (record one with --record)")
        #: ``taught``: the file recorded a model taught the world, so the loop asks the taught
        #: model's questions again (their keys are the recorded ones), in its ``spelling``.
        self.table, self.taught, self.spelling = _read_lines(self.path)

    def complete(self, request: Request) -> Reply:
        started = time.perf_counter()
        key = request.key()
        if key not in self.table:
            raise BackendError(
                f"replay file {self.path} has no reply for this prompt (key {key[:12]}…, goal {request.goal!r}, "
                f"round {request.round}); record it first"
            )
        return Reply(self.table[key], time.perf_counter() - started, meta={"replayed": True})

    def close(self) -> None:
        return None


class RecordingBackend:
    """Wraps ``inner`` and appends every exchange it has not seen yet to ``path``."""

    def __init__(self, inner: Backend, path: str | Path) -> None:
        self.inner = inner
        self.name = f"record:{inner.name}"
        self.path = Path(path)
        self.table = _read(self.path)
        self._append("")  # fail now, not after the first (maybe slow) answer, when the file cannot be written

    @property
    def prompt_style(self) -> PromptStyle:
        return self.inner.prompt_style

    @property
    def taught(self) -> bool:
        """Whether the inner backend is a model taught the world (it is asked as such, recorded or not)."""
        return bool(getattr(self.inner, "taught", False))

    @property
    def spelling(self) -> Spelling:
        """How the inner backend's taught model spells its plans' actions."""
        spelling: Spelling = getattr(self.inner, "spelling", Spelling.UNDERSCORED)
        return spelling

    @property
    def filled_predicates(self) -> tuple[str, ...]:
        """The action predicates the inner backend's taught plans leave to the check."""
        return tuple(getattr(self.inner, "filled_predicates", ()))

    def complete(self, request: Request) -> Reply:
        key = request.key()
        if key in self.table:
            return Reply(self.table[key], 0.0, meta={"replayed": True})
        reply = self.inner.complete(request)
        line: dict[str, object] = {"key": key, "goal": request.goal, "round": request.round, "reply": reply.text}
        if request.taught:
            line["taught"] = True
            if request.spelling is not Spelling.UNDERSCORED:
                line["spelling"] = request.spelling.name.lower()
        self._append(json.dumps(line) + "\n")
        self.table[key] = reply.text
        return reply

    def _append(self, line: str) -> None:
        try:
            with open_output(self.path, append=True) as handle:
                handle.write(line)
        except InputError as error:
            raise BackendError(f"{error}; give a writable path to --record") from None
        except OSError as error:
            raise BackendError(
                f"cannot write the record file {self.path}: {error.strerror or error}; give a writable path to --record"
            ) from None

    def close(self) -> None:
        self.inner.close()
