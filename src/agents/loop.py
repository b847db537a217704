"""A coalescing work loop: many pokes, one run at a time, always on the newest state."""

from __future__ import annotations

import asyncio
from collections.abc import Awaitable, Callable

from .logs import AgentLogger


class Coalescer:
    """Runs ``work()`` after a poke; pokes that arrive while it runs cause exactly one more run."""

    def __init__(self, work: Callable[[], Awaitable[None]], log: AgentLogger, what: str) -> None:
        self._work = work
        self._log = log
        self._what = what
        self._wake = asyncio.Event()
        self._task = asyncio.get_running_loop().create_task(self._run(), name=what)
        self.failures = 0

    def poke(self, *_: object) -> None:
        self._wake.set()

    def cancel(self) -> None:
        self._task.cancel()

    async def _run(self) -> None:
        while True:
            await self._wake.wait()
            self._wake.clear()
            try:
                await self._work()
            except Exception as exc:  # noqa: BLE001 - one failed run must not stop the loop
                self.failures += 1
                self._log.error(f"{self._what} failed", exc=exc, failures=self.failures)
