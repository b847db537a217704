"""Structured, one-line logs: ``time level agent=<name> message key=value ...``.

Every record of the process (the agent's own and the library's) goes through
:class:`LineFormatter`, so that the logs of many processes can be read side by
side or merged by time. Values with spaces, quotes or ``=`` are JSON-quoted;
a traceback is reduced to ``error=`` and ``at=`` (innermost frame) to keep one
line per event.
"""

from __future__ import annotations

import json
import logging
import sys
import time
import traceback
from collections.abc import Mapping
from typing import Any, TextIO

FIELDS = "wm_fields"


def format_value(value: Any) -> str:
    """A value as it appears after ``key=``: bare when it is one plain token, JSON-quoted otherwise."""
    text = value if isinstance(value, str) else str(value)
    if text and not any(c.isspace() or c in '"=' for c in text):
        return text
    return json.dumps(text, ensure_ascii=False)


def format_fields(fields: Mapping[str, Any]) -> str:
    return " ".join(f"{key}={format_value(value)}" for key, value in fields.items())


def describe_exception(exc: BaseException) -> dict[str, str]:
    """``error`` (type and message) and ``at`` (innermost frame: file:line function)."""
    fields = {"error": f"{type(exc).__name__}: {exc}".rstrip(": ")}
    frames = traceback.extract_tb(exc.__traceback__)
    if frames:
        last = frames[-1]
        fields["at"] = f"{last.filename.rsplit('/', 1)[-1]}:{last.lineno} {last.name}"
    return fields


class LineFormatter(logging.Formatter):
    """Formats every record as one line tagged with the agent's name (UTC time, milliseconds)."""

    def __init__(self, agent: str) -> None:
        super().__init__()
        self.agent = agent

    def format(self, record: logging.LogRecord) -> str:
        stamp = time.strftime("%Y-%m-%dT%H:%M:%S", time.gmtime(record.created)) + f".{int(record.msecs):03d}Z"
        fields: dict[str, Any] = {}
        if not record.name.startswith("agents."):
            fields["logger"] = record.name
        fields.update(getattr(record, FIELDS, {}))
        if record.exc_info and record.exc_info[1] is not None:
            fields.update(describe_exception(record.exc_info[1]))
        message = record.getMessage().replace("\n", " | ")
        tail = format_fields(fields)
        return f"{stamp} {record.levelname} agent={format_value(self.agent)} {message}" + (f" {tail}" if tail else "")


class AgentLogger:
    """The agent's logger: ``log.info("message", key=value, ...)``."""

    def __init__(self, agent: str) -> None:
        self.agent = agent
        self.logger = logging.getLogger(f"agents.{agent}")

    def _log(self, level: int, message: str, fields: dict[str, Any], exc: BaseException | None = None) -> None:
        if self.logger.isEnabledFor(level):
            exc_info = (type(exc), exc, exc.__traceback__) if exc is not None else None
            self.logger.log(level, message, exc_info=exc_info, extra={FIELDS: fields}, stacklevel=3)

    def debug(self, message: str, **fields: Any) -> None:
        self._log(logging.DEBUG, message, fields)

    def info(self, message: str, **fields: Any) -> None:
        self._log(logging.INFO, message, fields)

    def warning(self, message: str, **fields: Any) -> None:
        self._log(logging.WARNING, message, fields)

    def error(self, message: str, *, exc: BaseException | None = None, **fields: Any) -> None:
        """An error line; with ``exc``, its type, message and innermost frame are added."""
        self._log(logging.ERROR, message, fields, exc)


def configure(agent: str, level: str | int = "INFO", stream: TextIO | None = None) -> None:
    """Send every log record of the process to ``stream`` (stderr) as one line tagged ``agent=``."""
    handler = logging.StreamHandler(stream or sys.stderr)
    handler.setFormatter(LineFormatter(agent))
    root = logging.getLogger()
    for old in list(root.handlers):
        root.removeHandler(old)
    root.addHandler(handler)
    root.setLevel(level if isinstance(level, int) else level.upper())
