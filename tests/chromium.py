"""A headless Chromium driven through the DevTools protocol over a pipe: no extra Python package.

Chromium started with ``--remote-debugging-pipe`` reads protocol commands (JSON, each ended by a NUL
byte) from its file descriptor 3 and writes replies and events to its descriptor 4; there is no
listening socket at all. Name resolution is switched off (``--host-resolver-rules``), so a page can
reach nothing but 127.0.0.1. Used by tests/bt/test_view.py (and to measure ``hbtp view`` pages:
``python tests/chromium.py PAGE.html [--steps 10] [--repeat 5] [--screenshot OUT.png]``).
"""

from __future__ import annotations

import argparse
import base64
import contextlib
import fcntl
import json
import logging
import os
import select
import shutil
import signal
import statistics
import tempfile
import time
from pathlib import Path
from types import TracebackType
from typing import Any

#: Where Debian's chromium (CI installs it, like graphviz) or another Chromium may be found.
CANDIDATES = ("chromium", "chromium-browser", "google-chrome", "google-chrome-stable")

FLAGS = (
    "--headless",
    "--no-sandbox",
    "--disable-gpu",
    "--disable-quic",
    "--no-first-run",
    "--no-default-browser-check",
    "--disable-background-networking",
    "--disable-component-update",
    "--disable-sync",
    "--disable-extensions",
    "--disable-dev-shm-usage",
    "--host-resolver-rules=MAP * ~NOTFOUND , EXCLUDE 127.0.0.1",
    "--remote-debugging-pipe",
)

log = logging.getLogger(__name__)


def find_chromium() -> str | None:
    """The Chromium executable: ``$HBTP_CHROMIUM``, else the first of :data:`CANDIDATES` on the PATH."""
    given = os.environ.get("HBTP_CHROMIUM")
    if given:
        return given
    for name in CANDIDATES:
        found = shutil.which(name)
        if found:
            return found
    return None


class BrowserError(RuntimeError):
    """Chromium answered a command with an error, closed the pipe, or did not answer in time."""


def _high(fd: int) -> int:
    """``fd`` moved to a number of at least 10 (close-on-exec), so that the child's 3 and 4 cannot clash."""
    moved = fcntl.fcntl(fd, fcntl.F_DUPFD_CLOEXEC, 10)
    os.close(fd)
    return moved


class Chromium:
    """A headless Chromium process; use it as a context manager (it is closed and killed at exit).

    ``errors`` collects the pages' uncaught JavaScript errors."""

    def __init__(self, executable: str, *, width: int = 1280, height: int = 800) -> None:
        self.width, self.height = width, height
        self._profile = tempfile.TemporaryDirectory(prefix="hbtp-chromium-")
        self._log = Path(self._profile.name) / "stderr.log"
        commands_read, commands_write = os.pipe()
        replies_read, replies_write = os.pipe()
        commands_read, replies_write = _high(commands_read), _high(replies_write)
        args = [executable, *FLAGS, f"--user-data-dir={self._profile.name}", f"--window-size={width},{height}"]
        self.pid = os.posix_spawn(
            executable,
            [*args, "about:blank"],
            dict(os.environ),
            file_actions=[
                (os.POSIX_SPAWN_DUP2, commands_read, 3),
                (os.POSIX_SPAWN_DUP2, replies_write, 4),
                (os.POSIX_SPAWN_OPEN, 0, os.devnull, os.O_RDONLY, 0),
                (os.POSIX_SPAWN_OPEN, 1, os.devnull, os.O_WRONLY, 0),
                (os.POSIX_SPAWN_OPEN, 2, str(self._log), os.O_WRONLY | os.O_CREAT | os.O_TRUNC, 0o600),
            ],
            setsid=True,  # its own process group, so that closing it ends its helper processes too
        )
        os.close(commands_read)
        os.close(replies_write)
        self._write, self._read = commands_write, replies_read
        self._buffer = b""
        self._next_id = 0
        self._exited = False
        #: Uncaught JavaScript errors of the pages (seen while waiting for replies).
        self.errors: list[str] = []

    def __enter__(self) -> Chromium:
        return self

    def __exit__(
        self, kind: type[BaseException] | None, error: BaseException | None, trace: TracebackType | None
    ) -> None:
        self.close()

    # -------------------------------------------------------------- protocol
    def call(
        self, method: str, params: dict[str, Any] | None = None, session: str | None = None, timeout: float = 30
    ) -> Any:
        """Send one command and return its result (events that arrive meanwhile are dropped)."""
        self._next_id += 1
        message: dict[str, Any] = {"id": self._next_id, "method": method, "params": params or {}}
        if session is not None:
            message["sessionId"] = session
        data = json.dumps(message).encode() + b"\0"
        while data:
            data = data[os.write(self._write, data) :]
        deadline = time.monotonic() + timeout
        while True:
            reply = json.loads(self._message(deadline))
            if reply.get("method") == "Runtime.exceptionThrown":
                details = reply["params"]["exceptionDetails"]
                self.errors.append(details.get("exception", {}).get("description") or details.get("text", ""))
            if reply.get("id") == self._next_id:
                if "error" in reply:
                    raise BrowserError(f"{method}: {reply['error']}")
                return reply.get("result", {})

    def _message(self, deadline: float) -> bytes:
        while b"\0" not in self._buffer:
            left = deadline - time.monotonic()
            if left <= 0 or not select.select([self._read], [], [], left)[0]:
                raise BrowserError("Chromium did not answer in time")
            chunk = os.read(self._read, 1 << 16)
            if not chunk:
                raise BrowserError("Chromium closed the pipe: " + self.log()[-1500:])
            self._buffer += chunk
        message, self._buffer = self._buffer.split(b"\0", 1)
        return message

    def log(self) -> str:
        try:
            return self._log.read_text(encoding="utf-8", errors="replace")
        except OSError:
            return ""

    def open(self, url: str | None = None) -> Page:
        """A new tab at the browser's size, showing ``url`` if given."""
        target = self.call("Target.createTarget", {"url": "about:blank"})["targetId"]
        session = self.call("Target.attachToTarget", {"targetId": target, "flatten": True})["sessionId"]
        page = Page(self, session)
        metrics = {"width": self.width, "height": self.height, "deviceScaleFactor": 1, "mobile": False}
        page.call("Emulation.setDeviceMetricsOverride", metrics)
        page.call("Runtime.enable")  # reports uncaught errors (Chromium.errors)
        if url is not None:
            page.goto(url)
        return page

    # -------------------------------------------------------------- ending
    def close(self) -> None:
        if not self._exited:
            with contextlib.suppress(BrowserError, OSError):
                self.call("Browser.close", timeout=5)
            self._wait_or_kill(5.0)
        for fd in (self._write, self._read):
            with contextlib.suppress(OSError):
                os.close(fd)
        self._write = self._read = -1
        self._profile.cleanup()

    def _wait_or_kill(self, seconds: float) -> None:
        deadline = time.monotonic() + seconds
        while time.monotonic() < deadline:
            if os.waitpid(self.pid, os.WNOHANG)[0]:
                break
            time.sleep(0.05)
        else:
            os.kill(self.pid, signal.SIGKILL)
            os.waitpid(self.pid, 0)
        self._exited = True
        with contextlib.suppress(OSError):  # helpers left in its process group (the browser's own group)
            os.killpg(self.pid, signal.SIGKILL)


class Page:
    """One tab of a :class:`Chromium`."""

    def __init__(self, browser: Chromium, session: str) -> None:
        self.browser = browser
        self.session = session

    def call(self, method: str, params: dict[str, Any] | None = None, timeout: float = 30) -> Any:
        return self.browser.call(method, params, self.session, timeout)

    def goto(self, url: str, ready: str = "document.readyState === 'complete'", timeout: float = 30) -> None:
        """Load ``url`` and wait until the expression ``ready`` is true."""
        self.call("Page.navigate", {"url": url})
        self.wait_for(f"location.href !== 'about:blank' && {ready}", timeout)

    def evaluate(self, expression: str, timeout: float = 30) -> Any:
        """The value of a JavaScript expression (promises awaited); a thrown error raises."""
        params = {"expression": expression, "returnByValue": True, "awaitPromise": True}
        result = self.call("Runtime.evaluate", params, timeout)
        if "exceptionDetails" in result:
            details = result["exceptionDetails"]
            raise BrowserError(details.get("exception", {}).get("description") or details.get("text"))
        return result["result"].get("value")

    def wait_for(self, expression: str, timeout: float = 30) -> None:
        deadline = time.monotonic() + timeout
        while not self.evaluate(f"!!({expression})"):
            if time.monotonic() > deadline:
                raise BrowserError(f"timed out waiting for {expression}")
            time.sleep(0.02)

    def press(self, key: str, code: str | None = None) -> None:
        """A real key press (``ArrowRight``, ``End``), as the keyboard sends it."""
        for kind in ("rawKeyDown", "keyUp"):
            self.call("Input.dispatchKeyEvent", {"type": kind, "key": key, "code": code or key})

    def screenshot(self) -> bytes:
        """A PNG of the viewport."""
        return base64.b64decode(self.call("Page.captureScreenshot", {"format": "png"})["data"])


#: Clicks "next" and resolves after the next frame (so the step's layout and paint are counted).
STEP = "document.getElementById('next').click(), new Promise(r => requestAnimationFrame(() => setTimeout(r, 0)))"
READY = "document.body && document.body.dataset.ready === '1'"


def measure(page_file: Path, steps: int = 10) -> tuple[float, float]:
    """Seconds to (start Chromium, load the page and step ``steps`` ticks), and to (load and step) alone."""
    executable = find_chromium()
    if executable is None:
        raise SystemExit("no Chromium found")
    started = time.perf_counter()
    with Chromium(executable) as browser:
        page = browser.open()
        opened = time.perf_counter()
        page.goto(page_file.resolve().as_uri(), READY)
        for _ in range(steps):
            page.evaluate(STEP)
        done = time.perf_counter()
    return done - started, done - opened


def main() -> None:
    parser = argparse.ArgumentParser(description="Time loading an hbtp view page and stepping through it.")
    parser.add_argument("page", type=Path)
    parser.add_argument("--steps", type=int, default=10)
    parser.add_argument("--repeat", type=int, default=5)
    parser.add_argument("--screenshot", type=Path, help="also save a screenshot after the steps")
    parser.add_argument("--size", default="1280x800", help="screenshot size WIDTHxHEIGHT")
    options = parser.parse_args()
    logging.basicConfig(level=logging.INFO, format="%(message)s")
    runs = [measure(options.page, options.steps) for _ in range(options.repeat)]
    with_launch = statistics.median(r[0] for r in runs)
    page_only = statistics.median(r[1] for r in runs)
    log.info(
        "median of %d: load + %d steps %.3f s; with Chromium's start %.3f s",
        options.repeat,
        options.steps,
        page_only,
        with_launch,
    )
    log.info("all (with start, page only): %s", ", ".join(f"({a:.3f}, {b:.3f})" for a, b in runs))
    if options.screenshot:
        width, height = (int(x) for x in options.size.split("x"))
        executable = find_chromium()
        assert executable is not None
        with Chromium(executable, width=width, height=height) as browser:
            page = browser.open(options.page.resolve().as_uri())
            page.wait_for(READY)
            for _ in range(options.steps):
                page.evaluate(STEP)
            options.screenshot.write_bytes(page.screenshot())
        log.info("wrote %s", options.screenshot)


if __name__ == "__main__":
    main()
