"""Process helpers shared by the multi-process tests: free ports, child processes stopped by PID.

Every wait is bounded and fails with the child's output; every process started
through :func:`spawner` is stopped by its PID at teardown (SIGTERM, then SIGKILL).
"""

from __future__ import annotations

import json
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

TESTS_DIR = Path(__file__).resolve().parent
REPO = TESTS_DIR.parent
PYTHON = sys.executable
WM = [PYTHON, "-m", "wm.cli"]


def free_port() -> int:
    """A TCP port free on 127.0.0.1 right now."""
    with socket.socket(socket.AF_INET, socket.SOCK_STREAM) as s:
        s.bind(("127.0.0.1", 0))
        return int(s.getsockname()[1])


def endpoint(port: int) -> str:
    return f"tcp/127.0.0.1:{port}"


class Proc:
    """A child process whose output lines are collected on a thread."""

    def __init__(self, argv: Sequence[str], name: str, env: dict[str, str] | None = None, cwd: Path = REPO) -> None:
        self.name = name
        self.argv = list(argv)
        self.popen = subprocess.Popen(
            self.argv,
            stdin=subprocess.DEVNULL,
            stdout=subprocess.PIPE,
            stderr=subprocess.STDOUT,
            text=True,
            cwd=cwd,
            env={**os.environ, "PYTHONUNBUFFERED": "1", **(env or {})},
        )
        self.lines: list[str] = []
        self._queue: queue.Queue[str | None] = queue.Queue()
        threading.Thread(target=self._pump, daemon=True).start()

    @property
    def pid(self) -> int:
        return self.popen.pid

    def _pump(self) -> None:
        assert self.popen.stdout is not None
        for line in self.popen.stdout:
            line = line.rstrip("\n")
            self.lines.append(line)
            self._queue.put(line)
        self._queue.put(None)

    def output(self) -> str:
        return "\n".join(self.lines)

    def wait_line(self, prefix: str, timeout: float, contains: str = "") -> str:
        """The next output line starting with ``prefix`` and containing ``contains``; fails after ``timeout`` s."""
        deadline = time.monotonic() + timeout
        while (left := deadline - time.monotonic()) > 0:
            try:
                line = self._queue.get(timeout=left)
            except queue.Empty:
                break
            if line is None:
                pytest.fail(f"{self.name} exited (rc={self.popen.wait()}) before printing {prefix!r}:\n{self.output()}")
            if line.startswith(prefix) and contains in line:
                return line
        pytest.fail(
            f"{self.name}: no {prefix!r} line with {contains!r} within {timeout} s; output so far:\n{self.output()}"
        )

    def kill9(self) -> None:
        os.kill(self.popen.pid, signal.SIGKILL)
        self.popen.wait(timeout=10)

    def stop(self, timeout: float = 8.0) -> int | None:
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
def spawner() -> Iterator[Callable[..., Proc]]:
    """``spawner(argv, name=...)`` starts a process; all are stopped by PID at teardown."""
    procs: list[Proc] = []

    def spawn(argv: Sequence[str], name: str = "proc", env: dict[str, str] | None = None, cwd: Path = REPO) -> Proc:
        proc = Proc(argv, name, env, cwd)
        procs.append(proc)
        return proc

    yield spawn
    for proc in reversed(procs):
        proc.stop()
        print(f"--- output of {proc.name} (pid {proc.pid}, rc {proc.popen.returncode}) ---\n{proc.output()}")


def wait_until(condition: Callable[[], bool], timeout: float, what: str, step: float = 0.05) -> None:
    deadline = time.monotonic() + timeout
    while not condition():
        if time.monotonic() > deadline:
            pytest.fail(f"timed out after {timeout} s waiting for {what}")
        time.sleep(step)


def read_dump(path: Path) -> dict[str, Any] | None:
    """A replica_proc dump file, or None while it does not exist or is being replaced."""
    try:
        return json.loads(path.read_text())
    except (OSError, json.JSONDecodeError):
        return None
