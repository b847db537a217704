"""Headless Chromium driven over the DevTools protocol: for the browser tests and the README screenshot.

:func:`chromium` starts it on a fresh profile with a free debugging port and
yields a :class:`Page` showing a URL; the process is stopped by its PID
afterwards (SIGTERM, then SIGKILL). Nothing but the standard library and
``websockets`` is needed.
"""

from __future__ import annotations

import base64
import itertools
import json
import shutil
import subprocess
import tempfile
import time
from collections.abc import Iterator
from contextlib import contextmanager
from pathlib import Path
from typing import Any

from websockets.sync.client import ClientConnection, connect

CHROMIUM = "/usr/bin/chromium"
FLAGS = [
    "--headless",
    "--no-sandbox",
    "--disable-gpu",
    "--disable-quic",
    "--no-first-run",
    "--disable-background-networking",
    "--disable-component-update",
    "--disable-sync",
    "--remote-debugging-port=0",
]
LISTENING = "DevTools listening on "


class ChromiumError(RuntimeError):
    """Chromium is missing, did not start, or a DevTools call failed or timed out."""


def available() -> bool:
    return Path(CHROMIUM).exists()


class Page:
    """One tab: evaluate JavaScript, wait for a condition, and take screenshots."""

    def __init__(self, browser: ClientConnection, session: str) -> None:
        self._ws = browser
        self._session = session
        self._ids = itertools.count(1)

    def call(self, method: str, **params: Any) -> dict[str, Any]:
        ident = next(self._ids)
        self._ws.send(json.dumps({"id": ident, "sessionId": self._session, "method": method, "params": params}))
        while True:
            message = json.loads(self._ws.recv(timeout=30))
            if message.get("id") == ident:
                if "error" in message:
                    raise ChromiumError(f"{method}: {message['error']}")
                result: dict[str, Any] = message["result"]
                return result

    def eval(self, expression: str) -> Any:
        result = self.call("Runtime.evaluate", expression=expression, returnByValue=True)
        if "exceptionDetails" in result:
            raise ChromiumError(f"{expression}: {result['exceptionDetails'].get('exception', {}).get('description')}")
        return result["result"].get("value")

    def wait_for(self, expression: str, timeout: float, what: str, step: float = 0.1) -> Any:
        """Poll a JavaScript expression until it is truthy (one that throws counts as false); returns its value."""
        deadline = time.monotonic() + timeout
        while True:
            try:
                if value := self.eval(expression):
                    return value
            except ChromiumError as exc:
                last = f" (last: {exc})"
            else:
                last = ""
            if time.monotonic() > deadline:
                raise TimeoutError(f"timed out after {timeout} s waiting for {what}{last}")
            time.sleep(step)

    def screenshot_png(self) -> bytes:
        return base64.b64decode(self.call("Page.captureScreenshot", format="png")["data"])

    def screenshot(self, path: Path) -> Path:
        path.parent.mkdir(parents=True, exist_ok=True)
        path.write_bytes(self.screenshot_png())
        return path


@contextmanager
def chromium(url: str, *, width: int = 1400, height: int = 900, scale: float = 1.0) -> Iterator[Page]:
    """A headless Chromium showing ``url`` in a ``width`` x ``height`` window (``scale`` device pixels per CSS pixel)."""
    if not available():
        raise ChromiumError(f"{CHROMIUM} is missing: `make system-deps` installs Debian's chromium (needs root)")
    profile = Path(tempfile.mkdtemp(prefix="wm-chromium-"))
    log = profile / "chromium.log"
    with log.open("wb") as out:
        argv = [
            CHROMIUM,
            *FLAGS,
            f"--window-size={width},{height}",
            f"--force-device-scale-factor={scale:g}",
            f"--user-data-dir={profile}",
            "about:blank",
        ]
        proc = subprocess.Popen(argv, stdin=subprocess.DEVNULL, stdout=out, stderr=subprocess.STDOUT)
    try:
        endpoint = _endpoint(proc, log, 30.0)
        with connect(endpoint, max_size=None, open_timeout=10) as browser:
            browser.send(json.dumps({"id": 1, "method": "Target.createTarget", "params": {"url": url}}))
            target = _reply(browser, 1)["targetId"]
            browser.send(
                json.dumps(
                    {"id": 2, "method": "Target.attachToTarget", "params": {"targetId": target, "flatten": True}}
                )
            )
            yield Page(browser, _reply(browser, 2)["sessionId"])
    finally:
        _stop(proc)
        shutil.rmtree(profile, ignore_errors=True)


def _endpoint(proc: subprocess.Popen[bytes], log: Path, timeout: float) -> str:
    """The browser's DevTools websocket, from the line Chromium prints once it listens."""
    deadline = time.monotonic() + timeout
    while True:
        text = log.read_text(errors="replace")
        for line in text.splitlines():
            if line.startswith(LISTENING):
                return line.split()[-1]
        if proc.poll() is not None:
            raise ChromiumError(f"chromium exited with status {proc.returncode}:\n{text[-2000:]}")
        if time.monotonic() > deadline:
            raise ChromiumError(f"chromium did not listen within {timeout:g} s:\n{text[-2000:]}")
        time.sleep(0.05)


def _stop(proc: subprocess.Popen[bytes]) -> None:
    """SIGTERM by PID, then SIGKILL by PID."""
    if proc.poll() is None:
        proc.terminate()
        try:
            proc.wait(timeout=8)
        except subprocess.TimeoutExpired:
            proc.kill()
            proc.wait(timeout=8)


def _reply(browser: ClientConnection, ident: int) -> dict[str, Any]:
    while True:
        message = json.loads(browser.recv(timeout=30))
        if message.get("id") == ident:
            if "error" in message:
                raise ChromiumError(f"DevTools: {message['error']}")
            result: dict[str, Any] = message["result"]
            return result
