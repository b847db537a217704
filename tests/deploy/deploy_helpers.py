"""Helpers and fixtures for the deploy tests: free ports, a test PKI, role processes, sessions.

Every wait is bounded; every process started here is stopped by its PID at teardown.
"""

from __future__ import annotations

import subprocess
import sys
import threading
import time
from collections.abc import Callable, Iterator, Sequence
from pathlib import Path
from typing import Any

import pytest
import zenoh

from wm.net.zenoh_config import build_config

TESTS_DIR = Path(__file__).resolve().parents[1]
REPO = TESTS_DIR.parent
DEPLOY = REPO / "deploy"
ZENOH_DIR = DEPLOY / "zenoh"
ZPROC = Path(__file__).resolve().parent / "zproc.py"
PYTHON = sys.executable
# After a later message has arrived, how long an earlier, denied one is still given to show up.
GRACE_S = 0.5
for _where in (TESTS_DIR, DEPLOY):  # procs (shared test helpers) and zenohctl (the deploy tool)
    if str(_where) not in sys.path:
        sys.path.insert(0, str(_where))

from procs import Proc, free_port, wait_until  # noqa: E402,F401 - shared by the deploy tests


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
