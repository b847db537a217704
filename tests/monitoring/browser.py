"""Headless Chromium driven over the DevTools protocol, for the browser tests.

:func:`chromium` starts it on a fresh profile with a free debugging port and
yields a :class:`Page`; the process is stopped by its PID afterwards.
"""

from __future__ import annotations

import base64
import itertools
import json
import shutil
import tempfile
import time
from collections.abc import Iterator
from contextlib import contextmanager
from pathlib import Path
from typing import Any

import pytest
from websockets.sync.client import ClientConnection, connect

from procs import Proc

CHROMIUM = "/usr/bin/chromium"
FLAGS = [
    "--headless", "--no-sandbox", "--disable-gpu", "--disable-quic", "--no-first-run", "--disable-background-networking",
    "--disable-component-update", "--disable-sync", "--window-size=1400,900", "--remote-debugging-port=0",
]


def require_chromium() -> None:
    if not Path(CHROMIUM).exists():
        pytest.skip(f"{CHROMIUM} is missing: `make system-deps` installs Debian's chromium and chromium-driver (needs root)")


class Page:
    """One tab: evaluate JavaScript, click, and take screenshots."""

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
                    raise RuntimeError(f"{method}: {message['error']}")
                return message["result"]

    def eval(self, expression: str) -> Any:
        result = self.call("Runtime.evaluate", expression=expression, returnByValue=True)
        return result["result"].get("value")

    def wait_for(self, expression: str, timeout: float, what: str) -> Any:
        """Poll a JavaScript expression until it is truthy; returns its value."""
        deadline = time.monotonic() + timeout
        while not (value := self.eval(expression)):
            if time.monotonic() > deadline:
                pytest.fail(f"timed out after {timeout} s waiting for {what}")
            time.sleep(0.1)
        return value

    def screenshot(self, path: Path) -> Path:
        path.parent.mkdir(parents=True, exist_ok=True)
        path.write_bytes(base64.b64decode(self.call("Page.captureScreenshot", format="png")["data"]))
        return path


@contextmanager
def chromium(url: str) -> Iterator[Page]:
    """A headless Chromium showing ``url``."""
    require_chromium()
    profile = tempfile.mkdtemp(prefix="wm-chromium-")
    proc = Proc([CHROMIUM, *FLAGS, f"--user-data-dir={profile}", "about:blank"], "chromium")
    try:
        endpoint = proc.wait_line("DevTools listening on ", 30).split()[-1]
        with connect(endpoint, max_size=None, open_timeout=10) as browser:
            browser.send(json.dumps({"id": 1, "method": "Target.createTarget", "params": {"url": url}}))
            target = _reply(browser, 1)["targetId"]
            browser.send(json.dumps({"id": 2, "method": "Target.attachToTarget", "params": {"targetId": target, "flatten": True}}))
            yield Page(browser, _reply(browser, 2)["sessionId"])
    finally:
        proc.stop()
        shutil.rmtree(profile, ignore_errors=True)


def _reply(browser: ClientConnection, ident: int) -> dict[str, Any]:
    while True:
        message = json.loads(browser.recv(timeout=30))
        if message.get("id") == ident:
            return message["result"]
