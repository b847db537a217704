"""What ``wm launch`` shows: the prefixed combined console, a live status table, ``status.json``.

Each output line of a child is printed as ``<name> | <line>``; the launcher's
own lines are prefixed ``launch |``. On a terminal a status table (state, pid,
uptime, restarts, failures, last exit) stays at the bottom of the screen; the
same facts are written to ``<log dir>/status.json`` on every change, for tools
and tests.
"""

from __future__ import annotations

import json
import os
import time
from collections.abc import Sequence
from dataclasses import dataclass, field
from pathlib import Path

from rich.console import Console
from rich.live import Live
from rich.table import Table
from rich.text import Text

COLOURS = ("cyan", "green", "magenta", "yellow", "blue", "bright_red", "bright_cyan", "bright_green")


@dataclass
class ProcessState:
    """What the launcher knows of one process right now."""

    name: str
    state: str = "waiting"
    pid: int | None = None
    restarts: int = 0
    failures: list[str] = field(default_factory=list)
    last_exit: int | None = None
    started_at: float | None = None

    def as_dict(self) -> dict[str, object]:
        return {
            "name": self.name,
            "state": self.state,
            "pid": self.pid,
            "restarts": self.restarts,
            "failures": self.failures,
            "last_exit": self.last_exit,
            "started_at": self.started_at,
        }


class LaunchConsole:
    """The combined console of one launch; use as a context manager around the run."""

    def __init__(self, names: Sequence[str], status_file: Path, live_table: bool = True) -> None:
        self.console = Console(highlight=False, soft_wrap=True)
        self.width = max([len(n) for n in names] + [len("launch")])
        self.colours = {name: COLOURS[i % len(COLOURS)] for i, name in enumerate(names)}
        self.status_file = status_file
        self.states: list[ProcessState] = []
        self._live = (
            Live(console=self.console, refresh_per_second=2, get_renderable=self.table)
            if (live_table and self.console.is_terminal)
            else None
        )

    def __enter__(self) -> LaunchConsole:
        if self._live is not None:
            self._live.start()
        return self

    def __exit__(self, *exc: object) -> None:
        if self._live is not None:
            self._live.stop()

    def line(self, name: str, text: str) -> None:
        """One output line of process ``name``."""
        self.console.print(Text.assemble((f"{name:<{self.width}} | ", self.colours.get(name, "")), text))

    def note(self, text: str) -> None:
        """One line of the launcher's own."""
        self.console.print(Text.assemble((f"{'launch':<{self.width}} | ", "bold"), text))

    def changed(self) -> None:
        """A process changed state: rewrite ``status.json`` (the table redraws itself)."""
        data = {"launcher_pid": os.getpid(), "processes": [s.as_dict() for s in self.states]}
        tmp = self.status_file.with_name(f".{self.status_file.name}.tmp")
        tmp.write_text(json.dumps(data, indent=1))
        os.replace(tmp, self.status_file)

    def table(self) -> Table:
        table = Table(box=None, header_style="bold", pad_edge=False)
        for column in ("process", "state", "pid", "up", "restarts", "failures", "last exit"):
            table.add_column(column)
        now = time.time()
        for s in self.states:
            up = _duration(now - s.started_at) if s.state == "up" and s.started_at else "-"
            table.add_row(
                Text(s.name, self.colours.get(s.name, "")),
                Text(s.state, _STATE_STYLE.get(s.state, "")),
                str(s.pid or "-"),
                up,
                str(s.restarts),
                str(len(s.failures)),
                "-" if s.last_exit is None else str(s.last_exit),
            )
        return table

    def summary(self) -> None:
        """The final table, and one line per failure."""
        self.console.print(self.table())
        for s in self.states:
            for failure in s.failures:
                self.note(f"{s.name}: {failure}")


_STATE_STYLE = {
    "up": "green",
    "backoff": "yellow",
    "failed": "red",
    "stopping": "yellow",
    "exited": "dim",
    "stopped": "dim",
}


def _duration(seconds: float) -> str:
    seconds = int(seconds)
    if seconds < 60:
        return f"{seconds}s"
    if seconds < 3600:
        return f"{seconds // 60}m{seconds % 60:02d}s"
    return f"{seconds // 3600}h{seconds // 60 % 60:02d}m"
