"""Agents' logs as Foxglove ``foxglove.Log`` messages: following the ``*.log`` files of a directory.

``wm launch`` writes each process's output to ``<log dir>/<name>.log``, one
line per record, ``TIME LEVEL message ...``. :class:`LogTail` follows every
such file of a directory from its end at start (and new files from their
beginning) and :func:`log_message` turns each complete line into a
``foxglove.Log`` named after the file; a line without a known level is
``Info``, stamped with the time it was read.
"""

from __future__ import annotations

from datetime import datetime
from pathlib import Path

from foxglove.messages import Log, LogLevel, Timestamp

LEVELS = {
    "DEBUG": LogLevel.Debug,
    "INFO": LogLevel.Info,
    "WARNING": LogLevel.Warning,
    "ERROR": LogLevel.Error,
    "CRITICAL": LogLevel.Fatal,
}


class LogTail:
    """The complete lines added to ``directory/*.log`` since the last :meth:`read`, with the file's stem."""

    def __init__(self, directory: str | Path) -> None:
        self.directory = Path(directory)
        self._offsets = {path: path.stat().st_size for path in self.directory.glob("*.log")}

    def read(self) -> list[tuple[str, str]]:
        lines: list[tuple[str, str]] = []
        for path in sorted(self.directory.glob("*.log")):
            offset = self._offsets.get(path, 0)
            try:
                with path.open("rb") as file:
                    file.seek(offset)
                    data = file.read()
            except OSError:
                continue
            complete = data[: data.rfind(b"\n") + 1]
            self._offsets[path] = offset + len(complete)
            lines += [(path.stem, line.decode("utf-8", "replace")) for line in complete.splitlines() if line.strip()]
        return lines


def log_message(agent: str, line: str, t_ns: int) -> Log:
    """One log line as a ``foxglove.Log``: its own time and level when it starts with them."""
    parts = line.split(" ", 2)
    level = LEVELS.get(parts[1]) if len(parts) == 3 else None
    stamp = Timestamp(sec=t_ns // 1_000_000_000, nsec=t_ns % 1_000_000_000)
    if level is None:
        return Log(timestamp=stamp, level=LogLevel.Info, message=line, name=agent)
    try:
        stamp = Timestamp.from_datetime(datetime.fromisoformat(parts[0].replace("Z", "+00:00")))
    except ValueError:
        pass
    return Log(timestamp=stamp, level=level, message=parts[2], name=agent)
