"""Start the caregiving stack with ``wm launch`` and its shipped launch file, and stop it by PID.

The stack is :data:`LAUNCH_FILE` (``deploy/launch/one-host.toml`` links to it): ``wm serve`` as the
Zenoh router on a free loopback port, and the world bridge and the six agents as its clients (no
multicast). The harness only fills in the file's variables; which processes run, and how, is the
launch file's business. Each process writes ``<logdir>/<name>.log``; :meth:`Stack.start` returns
once every one of them has said it is ready.
"""

from __future__ import annotations

import json
import os
import signal
import socket
import subprocess
import sys
import time
from dataclasses import dataclass, field
from importlib import resources
from pathlib import Path
from typing import Self

from wm.launch.spec import LaunchFileError, load

LAUNCH_FILE = Path(str(resources.files("bridges.experiment").joinpath("one-host.toml")))
#: What an agent's log says once its runtime runs (processes without a ``ready`` in the launch file).
AGENT_READY = " running "
STOP_TIMEOUT = 30.0


class LaunchError(RuntimeError):
    """A process of the stack exited, failed or did not become ready in time."""


def free_port() -> int:
    """A TCP port free on 127.0.0.1 right now."""
    with socket.socket(socket.AF_INET, socket.SOCK_STREAM) as s:
        s.bind(("127.0.0.1", 0))
        return int(s.getsockname()[1])


def _read(path: Path, start: int = 0) -> str:
    """The file's text from byte ``start`` on; empty when it cannot be read (yet)."""
    try:
        with path.open("rb") as f:
            f.seek(start)
            return f.read().decode(errors="replace")
    except OSError:
        return ""


def _size(path: Path) -> int:
    try:
        return path.stat().st_size
    except OSError:
        return 0


def _tail(path: Path) -> str:
    return _read(path)[-2000:]


@dataclass
class Stack:
    """One launch of the stack; use as a context manager or call :meth:`start`/:meth:`stop`."""

    graph: str
    scenario: str
    logdir: Path
    rate: float = 1.0
    #: Where the simulator records its batches of robot moves (None: nowhere).
    record: Path | None = None
    #: Seconds a person is in W before Algorithm 1 guesses their walks.
    min_track: float = 0.0
    port: int = 0
    launcher: subprocess.Popen[bytes] | None = None
    names: tuple[str, ...] = field(default=())
    #: Where each process's log ended before this launch: a log directory used before keeps its logs.
    log_starts: dict[str, int] = field(default_factory=dict)

    @property
    def endpoint(self) -> str:
        return f"tcp/127.0.0.1:{self.port}"

    def variables(self, config: Path) -> dict[str, str]:
        """The launch file's variables for this stack."""
        return {
            "graph": self.graph,
            "port": str(self.port),
            "data": str(self.logdir / "data"),
            "scenario": self.scenario,
            "rate": f"{self.rate:g}",
            "zenoh": str(config),
            "record": str(self.record) if self.record is not None else "",
            "min_track": f"{self.min_track:g}",
        }

    def start(self, timeout: float = 60.0) -> Self:
        """Launch the stack; wait until every process is ready."""
        self.port = self.port or free_port()
        self.logdir.mkdir(parents=True, exist_ok=True)
        config = self.logdir / "zenoh-client.json5"
        config.write_text(
            json.dumps(
                {
                    "mode": "client",
                    "connect": {"endpoints": [self.endpoint]},
                    "scouting": {"multicast": {"enabled": False}},
                }
            )
        )
        variables = self.variables(config)
        try:
            spec = load(LAUNCH_FILE, variables)
        except LaunchFileError as exc:
            raise LaunchError(str(exc)) from None
        self.names = tuple(p.name for p in spec.processes)
        self.log_starts = {name: _size(self.logdir / f"{name}.log") for name in self.names}
        (self.logdir / "status.json").unlink(missing_ok=True)  # a last launch's, until this one writes its own
        argv = [
            sys.executable,
            "-m",
            "wm.cli",
            "launch",
            str(LAUNCH_FILE),
            "--no-table",
            "--log-dir",
            str(self.logdir),
            *(f"--set={k}={v}" for k, v in variables.items()),
        ]
        with (self.logdir / "launch.log").open("wb") as out:
            self.launcher = subprocess.Popen(
                argv,
                stdin=subprocess.DEVNULL,
                stdout=out,
                stderr=subprocess.STDOUT,
                env={**os.environ, "PYTHONUNBUFFERED": "1"},
            )
        deadline = time.monotonic() + timeout
        for process in spec.processes:
            self._wait_ready(process.name, process.ready or AGENT_READY, deadline)
        return self

    def _wait_ready(self, name: str, marker: str, deadline: float) -> None:
        log = self.logdir / f"{name}.log"
        while marker not in _read(log, self.log_starts.get(name, 0)):
            self.check()
            if time.monotonic() > deadline:
                raise LaunchError(f"{name} not ready in time:\n{_tail(log)}")
            time.sleep(0.05)

    def stop(self) -> None:
        """SIGTERM the launcher by PID (it stops the processes in reverse order), SIGKILL it if it hangs."""
        launcher, self.launcher = self.launcher, None
        if launcher is None:
            return
        if launcher.poll() is None:
            launcher.send_signal(signal.SIGTERM)
        try:
            launcher.wait(timeout=STOP_TIMEOUT)
        except subprocess.TimeoutExpired:
            launcher.kill()
            launcher.wait(timeout=8)

    def check(self) -> None:
        """Raise :class:`LaunchError` if the launcher has ended or any process has failed."""
        if self.launcher is None:
            raise LaunchError("the stack is not running")
        if self.launcher.poll() is not None:
            raise LaunchError(
                f"wm launch exited with status {self.launcher.returncode}:\n{_tail(self.logdir / 'launch.log')}"
            )
        try:
            states = json.loads((self.logdir / "status.json").read_text())
        except (OSError, ValueError):
            return  # not written yet, or being replaced right now
        for state in states.get("processes", []):
            if state.get("failures"):
                name = state["name"]
                raise LaunchError(
                    f"{name} failed ({'; '.join(state['failures'])}):\n{_tail(self.logdir / f'{name}.log')}"
                )

    def __enter__(self) -> Self:
        try:
            return self.start()
        except BaseException:
            self.stop()
            raise

    def __exit__(self, *exc: object) -> None:
        self.stop()
