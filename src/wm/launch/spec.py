"""Launch files for ``wm launch``: parsing and validation (nothing is started or imported here).

A launch file is TOML::

    log_dir = "logs/home"             # optional; default logs/<file stem>
    stop_timeout = 5.0                # optional; seconds between SIGTERM and SIGKILL

    [vars]                            # ${name} or ${name:-default} in cmd, args, env, cwd, ready, log_dir;
                                      # ${process} is the process's own name
    graph = "home"
    router = "tcp/127.0.0.1:7447"

    [defaults]                        # any process key except name, cmd, module, args
    restart = "on-failure"

    [[process]]
    name = "serve"
    module = "wm.cli"                 # run as: python -m wm.cli ARGS  (or cmd = ["prog", ...])
    args = ["serve", "--data", "data", "--graph", "${graph}", "--listen", "${router}"]
    ready = "wm serve: ready"         # later processes start once this text is printed
    restart = "always"                # never | on-failure | always
    backoff = { initial = 0.5, factor = 2.0, max = 30.0, reset_after = 10.0 }
    env = { WM_ZENOH_PORT = "7447" }

Processes start in file order and stop in reverse order. Every problem found is
reported with the key it concerns (``process.serve.restart: ...``); ``module``
names are checked for form only, never imported.
"""

from __future__ import annotations

import re
import shlex
import shutil
import sys
import tomllib
from collections.abc import Mapping
from dataclasses import dataclass, field
from pathlib import Path
from typing import Any

from .. import placeholders
from ..errors import WMError

RESTART_POLICIES = ("never", "on-failure", "always")
TOP_KEYS = {"log_dir", "stop_timeout", "vars", "defaults", "process"}
PROCESS_KEYS = {
    "name",
    "cmd",
    "module",
    "args",
    "env",
    "cwd",
    "restart",
    "backoff",
    "ready",
    "ready_timeout",
    "stop_timeout",
}
DEFAULTABLE = PROCESS_KEYS - {"name", "cmd", "module", "args"}
BACKOFF_KEYS = {"initial", "factor", "max", "reset_after"}
_NAME = re.compile(r"^[A-Za-z0-9_.\-]+$")
_MODULE = re.compile(r"^[A-Za-z_][A-Za-z0-9_]*(\.[A-Za-z_][A-Za-z0-9_]*)*$")


class LaunchFileError(WMError):
    """A launch file that cannot be used; ``problems`` lists each one with its key."""

    def __init__(self, path: str | Path, problems: list[str]) -> None:
        self.path = str(path)
        self.problems = problems
        super().__init__("\n".join(f"{self.path}: {p}" for p in problems))


@dataclass(frozen=True)
class Backoff:
    """Delay before restart n (0-based) of a run shorter than ``reset_after``: ``initial * factor**n``, at most ``max``."""

    initial: float = 0.5
    factor: float = 2.0
    max: float = 30.0
    reset_after: float = 10.0

    def delay(self, quick_failures: int) -> float:
        return min(self.max, self.initial * self.factor ** max(0, quick_failures))


@dataclass(frozen=True)
class ProcessSpec:
    """One process of a launch file, with variables expanded and defaults applied."""

    name: str
    argv: tuple[str, ...]
    env: Mapping[str, str] = field(default_factory=dict)
    cwd: str | None = None
    restart: str = "never"
    backoff: Backoff = Backoff()
    ready: str | None = None
    ready_timeout: float = 30.0
    stop_timeout: float = 5.0


@dataclass(frozen=True)
class LaunchSpec:
    path: Path
    log_dir: Path
    processes: tuple[ProcessSpec, ...]


class _Checker:
    """Collects problems instead of stopping at the first one."""

    def __init__(self, variables: Mapping[str, str]) -> None:
        self.variables = variables
        self.problems: list[str] = []

    def problem(self, key: str, message: str) -> None:
        self.problems.append(f"{key}: {message}")

    def expand(self, key: str, text: str) -> str:
        def undefined(name: str) -> None:
            self.problem(key, f"undefined variable ${{{name}}} (define it in [vars] or with --set {name}=VALUE)")

        return placeholders.expand(text, self.variables, undefined)

    def string(self, key: str, value: Any) -> str | None:
        if not isinstance(value, str):
            self.problem(key, f"must be a string, got {_kind(value)}")
            return None
        return self.expand(key, value)

    def strings(self, key: str, value: Any) -> list[str]:
        if not isinstance(value, list) or not all(isinstance(v, str) for v in value):
            self.problem(key, f"must be a list of strings, got {_kind(value)}")
            return []
        return [self.expand(f"{key}[{i}]", v) for i, v in enumerate(value)]

    def number(self, key: str, value: Any, minimum: float = 0.0) -> float | None:
        if isinstance(value, bool) or not isinstance(value, (int, float)) or value < minimum:
            self.problem(key, f"must be a number >= {minimum:g}, got {value!r}")
            return None
        return float(value)

    def unknown(self, key: str, table: Mapping[str, Any], allowed: set[str]) -> None:
        for extra in sorted(set(table) - allowed):
            self.problem(
                f"{key}{extra}" if key else extra, f"unknown key (expected one of {', '.join(sorted(allowed))})"
            )


def _kind(value: Any) -> str:
    return f"{type(value).__name__} {value!r}"


def load(path: str | Path, overrides: Mapping[str, str] | None = None) -> LaunchSpec:
    """Read and validate a launch file; raises :class:`LaunchFileError` listing every problem."""
    path = Path(path)
    try:
        data = tomllib.loads(path.read_text(encoding="utf-8"))
    except OSError as exc:
        raise LaunchFileError(path, [f"cannot read: {exc.strerror or exc}"]) from None
    except tomllib.TOMLDecodeError as exc:
        raise LaunchFileError(path, [f"not valid TOML: {exc}"]) from None
    variables = data.get("vars", {})
    check = _Checker({})
    if not isinstance(variables, dict):
        check.problem("vars", "must be a table")
        variables = {}
    for name, value in variables.items():
        if not isinstance(value, (str, int, float)) or isinstance(value, bool):
            check.problem(f"vars.{name}", f"must be a string or a number, got {_kind(value)}")
    check.variables = {**{k: str(v) for k, v in variables.items()}, **(overrides or {})}
    check.unknown("", data, TOP_KEYS)
    processes = _processes(check, data)
    log_dir = check.string("log_dir", data.get("log_dir", f"logs/{path.stem}"))
    if "stop_timeout" in data:
        check.number("stop_timeout", data["stop_timeout"])
    if check.problems:
        raise LaunchFileError(path, check.problems)
    return LaunchSpec(path, Path(log_dir or "."), tuple(processes))


def _processes(check: _Checker, data: Mapping[str, Any]) -> list[ProcessSpec]:
    defaults = data.get("defaults", {})
    if not isinstance(defaults, dict):
        check.problem("defaults", "must be a table")
        defaults = {}
    check.unknown("defaults.", defaults, DEFAULTABLE)
    if "stop_timeout" in data and "stop_timeout" not in defaults:
        defaults = {**defaults, "stop_timeout": data["stop_timeout"]}
    entries = data.get("process")
    if not isinstance(entries, list) or not entries:
        check.problem("process", "no processes: add at least one [[process]] table")
        return []
    specs, seen = [], set()
    for i, entry in enumerate(entries):
        name = entry.get("name") if isinstance(entry, dict) else None
        key = f"process.{name}" if isinstance(name, str) and name else f"process[{i}]"
        if not isinstance(name, str) or not _NAME.match(name):
            check.problem(f"{key}.name", f"required: letters, digits, '_', '-' or '.', got {name!r}")
        elif name in seen:
            check.problem(f"{key}.name", "duplicate process name")
        seen.add(name)
        spec = _process(check, key, str(name), {**defaults, **entry})
        if spec is not None:
            specs.append(spec)
    return specs


def _process(check: _Checker, key: str, name: str, entry: dict[str, Any]) -> ProcessSpec | None:
    before = len(check.problems)
    check.variables = {**check.variables, "process": name}
    check.unknown(f"{key}.", entry, PROCESS_KEYS)
    argv = _argv(check, key, entry)
    env = entry.get("env", {})
    if not isinstance(env, dict):
        check.problem(f"{key}.env", "must be a table of strings")
        env = {}
    expanded_env = {}
    for var, value in env.items():
        text = check.string(f"{key}.env.{var}", value)
        if text is not None:
            expanded_env[var] = text
    restart = entry.get("restart", "never")
    if restart not in RESTART_POLICIES:
        check.problem(f"{key}.restart", f"must be one of {', '.join(RESTART_POLICIES)}, got {restart!r}")
    backoff = _backoff(check, f"{key}.backoff", entry.get("backoff", {}))
    ready = check.string(f"{key}.ready", entry["ready"]) if "ready" in entry else None
    cwd = check.string(f"{key}.cwd", entry["cwd"]) if "cwd" in entry else None
    ready_timeout = check.number(f"{key}.ready_timeout", entry.get("ready_timeout", 30.0))
    stop_timeout = check.number(f"{key}.stop_timeout", entry.get("stop_timeout", 5.0))
    if len(check.problems) > before:
        return None
    return ProcessSpec(
        name,
        tuple(argv),
        expanded_env,
        cwd,
        restart,
        backoff,
        ready or None,
        ready_timeout or 0.0,
        stop_timeout or 0.0,
    )


def _argv(check: _Checker, key: str, entry: Mapping[str, Any]) -> list[str]:
    has_cmd, has_module = "cmd" in entry, "module" in entry
    if has_cmd == has_module:
        check.problem(key, "give exactly one of cmd (a program) or module (python -m MODULE)")
        return []
    args = check.strings(f"{key}.args", entry.get("args", []))
    if has_module:
        module = entry["module"]
        if not isinstance(module, str) or not _MODULE.match(module):
            check.problem(
                f"{key}.module", f"must be a dotted module name like agents.caregiving.perception, got {module!r}"
            )
            return []
        return [sys.executable, "-m", module, *args]
    cmd = entry["cmd"]
    try:
        words = check.strings(f"{key}.cmd", shlex.split(cmd) if isinstance(cmd, str) else cmd)
    except ValueError as exc:
        check.problem(f"{key}.cmd", f"cannot split into words: {exc}")
        return []
    if not words:
        check.problem(f"{key}.cmd", "is empty")
        return []
    if shutil.which(words[0]) is None:
        check.problem(f"{key}.cmd", f"program {words[0]!r} not found (not on PATH, or not executable)")
    return [*words, *args]


def _backoff(check: _Checker, key: str, table: Any) -> Backoff:
    if not isinstance(table, dict):
        check.problem(key, "must be a table like { initial = 0.5, factor = 2.0, max = 30.0 }")
        return Backoff()
    check.unknown(f"{key}.", table, BACKOFF_KEYS)
    values = {
        k: check.number(f"{key}.{k}", v, 1.0 if k == "factor" else 0.0) for k, v in table.items() if k in BACKOFF_KEYS
    }
    return Backoff(**{k: v for k, v in values.items() if v is not None})
