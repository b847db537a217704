"""Start the caregiving stack as separate processes on one Zenoh mesh, and stop them by PID.

The world bridge listens on a loopback endpoint; perception, the simulator,
the intention, action and executor agents connect to it (peer mode, no
multicast). Each process writes its log to ``<logdir>/<name>.log``;
:meth:`Stack.start` returns once every one of them has said it is ready.
"""

from __future__ import annotations

import os
import signal
import socket
import subprocess
import sys
import time
from dataclasses import dataclass, field
from pathlib import Path
from typing import Self

READY = {"world": "world: ready", "agent": " running "}


class LaunchError(RuntimeError):
    """A process of the stack exited or did not become ready in time."""


def free_port() -> int:
    """A TCP port free on 127.0.0.1 right now."""
    with socket.socket(socket.AF_INET, socket.SOCK_STREAM) as s:
        s.bind(("127.0.0.1", 0))
        return int(s.getsockname()[1])


@dataclass
class Child:
    name: str
    popen: subprocess.Popen[bytes]
    log: Path

    def text(self) -> str:
        try:
            return self.log.read_text(errors="replace")
        except OSError:
            return ""


@dataclass
class Stack:
    """The processes of one stack; use as a context manager or call :meth:`start`/:meth:`stop`."""

    graph: str
    scenario: str
    logdir: Path
    rate: float = 1.0
    port: int = 0
    agent_args: dict[str, list[str]] = field(default_factory=dict)
    children: list[Child] = field(default_factory=list)

    @property
    def endpoint(self) -> str:
        return f"tcp/127.0.0.1:{self.port}"

    def _spawn(self, name: str, argv: list[str]) -> Child:
        self.logdir.mkdir(parents=True, exist_ok=True)
        log = self.logdir / f"{name}.log"
        out = log.open("wb")
        env = {**os.environ, "PYTHONUNBUFFERED": "1"}
        popen = subprocess.Popen(argv, stdin=subprocess.DEVNULL, stdout=out, stderr=subprocess.STDOUT, env=env)
        out.close()
        child = Child(name, popen, log)
        self.children.append(child)
        return child

    def _wait_ready(self, child: Child, marker: str, timeout: float) -> None:
        deadline = time.monotonic() + timeout
        while marker not in child.text():
            if child.popen.poll() is not None:
                raise LaunchError(f"{child.name} exited with status {child.popen.returncode}:\n{child.text()[-2000:]}")
            if time.monotonic() > deadline:
                raise LaunchError(f"{child.name} not ready within {timeout:g} s:\n{child.text()[-2000:]}")
            time.sleep(0.05)

    def start(self, timeout: float = 60.0) -> Self:
        """Start the world bridge, then the five agents; wait until all are ready."""
        self.port = self.port or free_port()
        py = sys.executable
        world = self._spawn("world", [py, "-m", "bridges.world", "--graph", self.graph, "--scenario", self.scenario,
                                      "--rate", str(self.rate), "--listen", self.endpoint])
        self._wait_ready(world, READY["world"], timeout)
        common = ["--graph", self.graph, "--connect", self.endpoint]
        scenario = ["--scenario", self.scenario]
        agents = {"perception": scenario, "simulation": [], "intention": scenario, "action": scenario, "executor": []}
        started = [self._spawn(name, [py, "-m", f"agents.caregiving.{name}", *common, *extra, *self.agent_args.get(name, [])])
                   for name, extra in agents.items()]
        for child in started:
            self._wait_ready(child, READY["agent"], timeout)
        return self

    def add(self, name: str, argv: list[str], ready: str, timeout: float = 30.0) -> Child:
        """Start one more process beside the stack (stopped with it, by PID); return once its log shows ``ready``."""
        child = self._spawn(name, argv)
        self._wait_ready(child, ready, timeout)
        return child

    def stop(self) -> None:
        """SIGTERM every child by PID (newest first), then SIGKILL the ones still there."""
        for child in reversed(self.children):
            if child.popen.poll() is None:
                child.popen.send_signal(signal.SIGTERM)
        for child in reversed(self.children):
            try:
                child.popen.wait(timeout=8)
            except subprocess.TimeoutExpired:
                child.popen.kill()
                child.popen.wait(timeout=8)
        self.children.clear()

    def check(self) -> None:
        """Raise :class:`LaunchError` if any process has died."""
        for child in self.children:
            if child.popen.poll() is not None:
                raise LaunchError(f"{child.name} exited with status {child.popen.returncode}:\n{child.text()[-2000:]}")

    def __enter__(self) -> Self:
        try:
            return self.start()
        except BaseException:
            self.stop()
            raise

    def __exit__(self, *exc: object) -> None:
        self.stop()
