"""Helpers and fixtures for the deploy tests: free ports, a test PKI, role processes, sessions.

Every wait is bounded; every process started here is stopped by its PID at teardown.
"""

from __future__ import annotations

import os
import queue
import signal
import socket
import subprocess
import sys
import threading
import time
from collections.abc import Callable, Iterator, Sequence
from pathlib import Path
from typing import Any

import pytest
import zenoh

from wm.zenoh_config import build_config

TESTS_DIR = Path(__file__).resolve().parents[1]
REPO = TESTS_DIR.parent
DEPLOY = REPO / "deploy"
ZENOH_DIR = DEPLOY / "zenoh"
ZPROC = Path(__file__).resolve().parent / "zproc.py"
PYTHON = sys.executable
# After a later message has arrived, how long an earlier, denied one is still given to show up.
GRACE_S = 0.5
if str(TESTS_DIR) not in sys.path:
    sys.path.insert(0, str(TESTS_DIR))


def free_port() -> int:
    """A TCP port free on 127.0.0.1 right now."""
    with socket.socket(socket.AF_INET, socket.SOCK_STREAM) as s:
        s.bind(("127.0.0.1", 0))
        return int(s.getsockname()[1])


class Proc:
    """A child process whose stdout lines are read on a thread."""

    def __init__(self, argv: Sequence[str], name: str) -> None:
        self.name = name
        self.argv = list(argv)
        self.popen = subprocess.Popen(
            self.argv,
            stdin=subprocess.DEVNULL,
            stdout=subprocess.PIPE,
            stderr=subprocess.STDOUT,
            text=True,
            cwd=REPO,
            env={**os.environ, "PYTHONUNBUFFERED": "1"},
        )
        self.lines: list[str] = []
        self._q: queue.Queue[str | None] = queue.Queue()
        threading.Thread(target=self._pump, daemon=True).start()

    def _pump(self) -> None:
        assert self.popen.stdout is not None
        for line in self.popen.stdout:
            line = line.rstrip("\n")
            self.lines.append(line)
            self._q.put(line)
        self._q.put(None)

    def wait_line(self, prefix: str, timeout: float, contains: str = "") -> str:
        """The next stdout line starting with ``prefix`` (and containing ``contains``);
        fail clearly after ``timeout`` s."""
        deadline = time.monotonic() + timeout
        while True:
            left = deadline - time.monotonic()
            if left <= 0:
                break
            try:
                line = self._q.get(timeout=left)
            except queue.Empty:
                break
            if line is None:
                pytest.fail(
                    f"{self.name} exited (rc={self.popen.wait()}) before printing {prefix!r}; output:\n"
                    + "\n".join(self.lines)
                )
            if line.startswith(prefix) and contains in line:
                return line
        pytest.fail(f"{self.name}: no {prefix!r} line with {contains!r} within {timeout} s; output so far:\n" + "\n".join(self.lines))

    def stop(self, timeout: float = 5.0) -> int | None:
        """SIGTERM by PID, then SIGKILL by PID if it does not exit in time."""
        if self.popen.poll() is None:
            try:
                os.kill(self.popen.pid, signal.SIGTERM)
                self.popen.wait(timeout=timeout)
            except subprocess.TimeoutExpired:
                os.kill(self.popen.pid, signal.SIGKILL)
                self.popen.wait(timeout=timeout)
            except ProcessLookupError:
                pass
        return self.popen.returncode


@pytest.fixture
def spawn() -> Iterator[Callable[..., Proc]]:
    """Start ``zproc.py ARGS`` (or any argv with ``argv=``); all are stopped at teardown."""
    procs: list[Proc] = []

    def _spawn(*args: str, name: str = "zproc", argv: Sequence[str] | None = None) -> Proc:
        p = Proc(argv if argv is not None else [PYTHON, str(ZPROC), *args], name)
        procs.append(p)
        return p

    yield _spawn
    for p in reversed(procs):
        p.stop()


@pytest.fixture
def sessions() -> Iterator[Callable[..., zenoh.Session]]:
    """Open in-process Zenoh sessions with ``build_config(...)`` arguments; closed at teardown."""
    opened: list[zenoh.Session] = []

    def _open(*args: Any, **kwargs: Any) -> zenoh.Session:
        s = zenoh.open(build_config(*args, **kwargs))
        opened.append(s)
        return s

    yield _open
    for s in reversed(opened):
        s.close()


class Collector:
    """Thread-safe sink for subscriber callbacks."""

    def __init__(self) -> None:
        self.items: list[tuple[str, str]] = []
        self._cv = threading.Condition()

    def __call__(self, sample: zenoh.Sample) -> None:
        with self._cv:
            self.items.append((str(sample.key_expr), sample.payload.to_string()))
            self._cv.notify_all()

    def payloads(self) -> list[str]:
        with self._cv:
            return [p for _, p in self.items]

    def wait_for(self, pred: Callable[[list[str]], bool], timeout: float, what: str) -> None:
        deadline = time.monotonic() + timeout
        with self._cv:
            while not pred([p for _, p in self.items]):
                left = deadline - time.monotonic()
                if left <= 0:
                    pytest.fail(f"timed out after {timeout} s waiting for {what}; received {self.items!r}")
                self._cv.wait(left)


def wait_until(cond: Callable[[], bool], timeout: float, what: str, step: float = 0.05) -> None:
    deadline = time.monotonic() + timeout
    while not cond():
        if time.monotonic() > deadline:
            pytest.fail(f"timed out after {timeout} s waiting for {what}")
        time.sleep(step)


def wait_matching(publisher: zenoh.Publisher, timeout: float, what: str) -> None:
    """Wait until Zenoh knows of a subscriber matching ``publisher`` (routes are in place)."""
    wait_until(lambda: publisher.matching_status.matching, timeout, what)


def make_certs(outdir: Path, *args: str) -> Path:
    subprocess.run(
        ["bash", str(DEPLOY / "certs" / "make-test-certs.sh"), str(outdir), *args],
        check=True,
        capture_output=True,
        timeout=60,
    )
    return outdir


@pytest.fixture(scope="session")
def pki(tmp_path_factory: pytest.TempPathFactory) -> Path:
    """Test CA + router cert (CN router) + agent certs perception/intention/monitor/stranger."""
    return make_certs(tmp_path_factory.mktemp("pki"), "perception", "intention", "monitor", "stranger")


@pytest.fixture(scope="session")
def other_pki(tmp_path_factory: pytest.TempPathFactory) -> Path:
    """A second, unrelated CA with a client cert named like a legitimate agent."""
    return make_certs(tmp_path_factory.mktemp("other-pki"), "perception")
