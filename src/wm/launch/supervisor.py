"""``wm launch``: start the processes of a launch file, restart them by policy, stop them in order.

* Processes start in file order; one with ``ready`` holds the next ones back
  until it prints that text (or exits, or ``ready_timeout`` passes).
* Each runs in its own session (a terminal's Ctrl-C reaches only the launcher)
  and, on Linux, gets SIGTERM if the launcher itself dies.
* Output goes to ``<log dir>/<name>.log`` and to the combined console.
* ``restart``: ``never``; ``on-failure`` (a non-zero status or a signal);
  ``always``. The delay grows by ``backoff.factor`` for each run shorter than
  ``backoff.reset_after`` seconds.
* SIGINT/SIGTERM: no more restarts; then, in reverse order, each process gets
  SIGTERM by PID and, after its ``stop_timeout``, SIGKILL. A second signal
  kills whatever is left at once.
* Exit status: 0 when no process ever failed, 1 otherwise (the summary names
  every failure: a crash, a non-zero status, a process that had to be killed).
"""

from __future__ import annotations

import asyncio
import ctypes
import os
import signal
import sys
import time
from pathlib import Path
from typing import IO

from .console import LaunchConsole, ProcessState
from .spec import LaunchSpec, ProcessSpec

LINE_LIMIT = 1 << 20
PUMP_GRACE = 1.0  # seconds to drain output after the process exits
CLEAN_STOP = {0, -signal.SIGTERM, 128 + signal.SIGTERM}
PR_SET_PDEATHSIG = 1


def describe_exit(returncode: int) -> str:
    if returncode < 0:
        try:
            return f"killed by {signal.Signals(-returncode).name}"
        except ValueError:
            return f"killed by signal {-returncode}"
    return f"exited with status {returncode}"


def _die_with_parent() -> None:
    """Runs in the child before exec: ask Linux for SIGTERM when the launcher dies."""
    if sys.platform.startswith("linux"):
        ctypes.CDLL(None, use_errno=True).prctl(PR_SET_PDEATHSIG, signal.SIGTERM)


class Supervisor:
    """Runs one process of the launch file, again and again as its restart policy says."""

    def __init__(self, spec: ProcessSpec, console: LaunchConsole, log_dir: Path) -> None:
        self.spec = spec
        self.console = console
        self.log_path = log_dir / f"{spec.name}.log"
        self.status = ProcessState(spec.name)
        self.ready = asyncio.Event()
        self.stopping = asyncio.Event()
        self._proc: asyncio.subprocess.Process | None = None

    def _set(self, state: str) -> None:
        self.status.state = state
        self.console.changed()

    def _fail(self, what: str) -> None:
        self.status.failures.append(what)
        self.console.changed()

    async def run(self) -> None:
        """Until the policy says no more, or :meth:`stop` is called."""
        quick_runs = 0
        while not self.stopping.is_set():
            started = time.monotonic()
            failure = await self._run_once()
            if self.stopping.is_set():
                return
            if failure is not None:
                self._fail(failure)
            restart = self.spec.restart == "always" or (self.spec.restart == "on-failure" and failure is not None)
            if not restart:
                self._set("failed" if failure else "exited")
                self.console.note(
                    f"{self.spec.name}: {failure or 'exited with status 0'}; not restarting (restart = {self.spec.restart!r})"
                )
                return
            quick_runs = quick_runs + 1 if time.monotonic() - started < self.spec.backoff.reset_after else 0
            delay = self.spec.backoff.delay(quick_runs - 1)
            self._set("backoff")
            self.console.note(f"{self.spec.name}: {failure or 'exited with status 0'}; restarting in {delay:.2g} s")
            try:
                await asyncio.wait_for(self.stopping.wait(), delay)
                return
            except TimeoutError:
                self.status.restarts += 1

    async def _run_once(self) -> str | None:
        """Start the process and wait for it; returns what went wrong, or None for status 0."""
        with self.log_path.open("ab") as log:
            log.write(
                f"--- {time.strftime('%Y-%m-%dT%H:%M:%S')} launch: starting {' '.join(self.spec.argv)}\n".encode()
            )
            log.flush()
            try:
                proc = await asyncio.create_subprocess_exec(
                    *self.spec.argv,
                    stdin=asyncio.subprocess.DEVNULL,
                    stdout=asyncio.subprocess.PIPE,
                    stderr=asyncio.subprocess.STDOUT,
                    cwd=self.spec.cwd,
                    limit=LINE_LIMIT,
                    env={**os.environ, "PYTHONUNBUFFERED": "1", **self.spec.env},
                    start_new_session=True,
                    preexec_fn=_die_with_parent,
                )
            except OSError as exc:
                self.status.last_exit = None
                return f"cannot start: {exc}"
            self._proc = proc
            self.status.pid, self.status.started_at = proc.pid, time.time()
            self._set("up")
            self.console.note(
                f"{self.spec.name}: started, pid {proc.pid}"
                + (f" (restart {self.status.restarts})" if self.status.restarts else "")
            )
            assert proc.stdout is not None
            pump = asyncio.create_task(self._pump(proc.stdout, log))
            returncode = await proc.wait()
            await asyncio.wait({pump}, timeout=PUMP_GRACE)  # a grandchild may hold the pipe open
            pump.cancel()
            log.write(
                f"--- {time.strftime('%Y-%m-%dT%H:%M:%S')} launch: pid {proc.pid} {describe_exit(returncode)}\n".encode()
            )
        self.status.last_exit = returncode
        self.status.pid = None
        self.console.changed()
        return None if returncode == 0 else describe_exit(returncode)

    async def _pump(self, stream: asyncio.StreamReader, log: IO[bytes]) -> None:
        while True:
            try:
                line = await stream.readline()
            except ValueError:  # a line longer than LINE_LIMIT: take it in pieces
                line = await stream.read(LINE_LIMIT)
            if not line:
                return
            log.write(line)
            log.flush()
            text = line.decode("utf-8", errors="replace").rstrip("\r\n")
            self.console.line(self.spec.name, text)
            if self.spec.ready and self.spec.ready in text:
                self.ready.set()

    async def stop(self) -> None:
        """SIGTERM by PID; SIGKILL by PID after ``stop_timeout``. Records an unclean stop as a failure."""
        self.stopping.set()
        proc = self._proc
        if proc is None or proc.returncode is not None:
            self._set_final()
            return
        self._set("stopping")
        self.console.note(f"{self.spec.name}: stopping, SIGTERM to pid {proc.pid}")
        try:
            os.kill(proc.pid, signal.SIGTERM)
            returncode = await asyncio.wait_for(proc.wait(), self.spec.stop_timeout)
            if returncode not in CLEAN_STOP:
                self._fail(f"{describe_exit(returncode)} when stopped")
        except TimeoutError:
            self.kill()
            await proc.wait()
            self._fail(f"did not stop within {self.spec.stop_timeout:g} s of SIGTERM; killed")
        except ProcessLookupError:
            pass
        self._set_final()

    def _set_final(self) -> None:
        if self.status.state in ("up", "stopping", "backoff", "waiting"):
            self._set("stopped")

    def kill(self) -> None:
        """SIGKILL by PID, now."""
        proc = self._proc
        if proc is not None and proc.returncode is None:
            try:
                os.kill(proc.pid, signal.SIGKILL)
            except ProcessLookupError:
                pass


class Launcher:
    """Runs a whole launch file until every process is done or a stop signal arrives."""

    def __init__(self, spec: LaunchSpec, live_table: bool = True) -> None:
        self.spec = spec
        spec.log_dir.mkdir(parents=True, exist_ok=True)
        names = [p.name for p in spec.processes]
        self.console = LaunchConsole(names, spec.log_dir / "status.json", live_table)
        self.supervisors = [Supervisor(p, self.console, spec.log_dir) for p in spec.processes]
        self.console.states = [s.status for s in self.supervisors]
        self._tasks: list[asyncio.Task[None]] = []
        self._starting: asyncio.Task[None] | None = None
        self._done = asyncio.Event()
        self._signals = 0

    async def run(self) -> int:
        """Start everything, wait for a signal (or for every process to end), stop, return the exit status."""
        loop = asyncio.get_running_loop()
        for sig in (signal.SIGINT, signal.SIGTERM):
            loop.add_signal_handler(sig, self._on_signal, sig)
        try:
            with self.console:
                self.console.changed()
                self.console.note(f"{self.spec.path}: {len(self.supervisors)} processes, logs in {self.spec.log_dir}")
                self._starting = asyncio.create_task(self._start_in_order())
                self._starting.add_done_callback(self._check_done)
                await self._done.wait()
                self._starting.cancel()
                await self._stop_all()
                await asyncio.gather(*self._tasks, return_exceptions=True)
        finally:
            for sig in (signal.SIGINT, signal.SIGTERM):
                loop.remove_signal_handler(sig)
        self.console.summary()
        failed = [s for s in self.supervisors if s.status.failures]
        self.console.note(
            "every process stopped cleanly" if not failed else f"failures in: {', '.join(s.spec.name for s in failed)}"
        )
        return 1 if failed else 0

    def _on_signal(self, sig: signal.Signals) -> None:
        self._signals += 1
        if self._signals == 1:
            self.console.note(f"{sig.name}: stopping every process, last started first")
            self._done.set()
        else:
            self.console.note(f"{sig.name} again: killing every process now")
            for supervisor in self.supervisors:
                supervisor.kill()

    async def _start_in_order(self) -> None:
        for supervisor in self.supervisors:
            task = asyncio.create_task(supervisor.run(), name=supervisor.spec.name)
            task.add_done_callback(self._check_done)
            self._tasks.append(task)
            if supervisor.spec.ready:
                await self._wait_ready(supervisor, task)

    async def _wait_ready(self, supervisor: Supervisor, task: asyncio.Task[None]) -> None:
        ready = asyncio.create_task(supervisor.ready.wait())
        try:
            await asyncio.wait(
                {ready, task}, timeout=supervisor.spec.ready_timeout, return_when=asyncio.FIRST_COMPLETED
            )
        finally:
            ready.cancel()
        if not supervisor.ready.is_set():
            self.console.note(
                f"{supervisor.spec.name}: not ready ({supervisor.spec.ready!r} not seen); starting the rest anyway"
            )

    def _check_done(self, _task: asyncio.Task[None]) -> None:
        starting_done = self._starting is not None and self._starting.done()
        if starting_done and all(task.done() for task in self._tasks):
            self._done.set()

    async def _stop_all(self) -> None:
        for supervisor in self.supervisors:
            supervisor.stopping.set()
        for supervisor in reversed(self.supervisors):
            await supervisor.stop()
