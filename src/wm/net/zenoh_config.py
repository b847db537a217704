"""Build the ``zenoh.Config`` of a cortex-wm process.

Every cortex-wm process (an agent, ``wm serve``, a monitor) opens one Zenoh
session, configured by :func:`build_config` from

* a JSON5 file (for example one of the templates in ``deploy/zenoh/``),
* a mapping shaped like such a file, or an existing ``zenoh.Config``,
* or nothing (a peer),

then ``mode``, ``connect``, ``listen`` and ``overrides``
(``{"zenoh/config/path": value}``) are applied on top. Multicast scouting is
off unless the source or the overrides turn it on: cortex-wm processes find
each other through explicit endpoints, never by accident on a shared LAN.

A string in the file or mapping may hold ``${NAME}`` or ``${NAME:-default}``
placeholders (:mod:`wm.placeholders`), filled from the ``variables`` given. A
string that is one placeholder and nothing else takes the variable's value with
its type (``cert_common_names: "${WRITERS}"`` with ``WRITERS=["perception"]``).
A placeholder with neither a value nor a default is an error that names it.

Nothing is read from the environment unless asked: command-line programs call
:func:`load_with_environment` so that ``--config FILE`` takes its variables
from ``WM_ZENOH_<NAME>`` environment variables.
"""

from __future__ import annotations

import json
import os
import re
from collections.abc import Callable, Iterable, Mapping
from functools import partial
from pathlib import Path
from typing import Any, Literal, TypeAlias

import json5
import zenoh

from .. import placeholders
from ..errors import WMError

__all__ = [
    "ENV_PREFIX",
    "MODES",
    "ConfigSource",
    "Endpoints",
    "Mode",
    "ZenohConfigError",
    "build_config",
    "environment_variables",
    "load_with_environment",
    "read_config",
    "variable_value",
]

Mode: TypeAlias = Literal["peer", "client", "router"]
MODES: tuple[Mode, ...] = ("peer", "client", "router")
PathLike: TypeAlias = str | os.PathLike[str]
Endpoints: TypeAlias = str | Iterable[str]
ConfigSource: TypeAlias = PathLike | Mapping[str, Any] | zenoh.Config
ENV_PREFIX = "WM_ZENOH_"

_ENDPOINT = re.compile(r"^[a-z][a-z0-9+-]*/[^\s#]+(#.*)?$")


class ZenohConfigError(WMError, ValueError):
    """A Zenoh configuration could not be built; the message names the problem."""


def read_config(source: PathLike | Mapping[str, Any], variables: Mapping[str, Any] | None = None) -> dict[str, Any]:
    """The configuration in a JSON5 file or a mapping, as plain data with its placeholders filled."""
    data: Any
    if isinstance(source, Mapping):
        data, where = source, "<mapping>"
    elif isinstance(source, (str, os.PathLike)):
        data, where = _read_json5(Path(source)), str(source)
    else:
        raise ZenohConfigError(f"Zenoh config source must be a path or a mapping, not {type(source).__name__}")
    missing: list[str] = []
    render = partial(_inline_text, where)
    filled: dict[str, Any] = _fill(
        data, lambda text: placeholders.expand_value(text, variables or {}, missing.append, render)
    )
    if missing:
        raise ZenohConfigError(f"{where}: no value for template variable(s) {', '.join(sorted(set(missing)))}")
    return filled


def build_config(
    source: ConfigSource | None = None,
    *,
    variables: Mapping[str, Any] | None = None,
    mode: Mode | None = None,
    connect: Endpoints | None = None,
    listen: Endpoints | None = None,
    overrides: Mapping[str, Any] | None = None,
) -> zenoh.Config:
    """A ``zenoh.Config`` from a file, a mapping, a config or nothing, with the keyword arguments applied.

    ``build_config("deploy/zenoh/client.json5", variables={"ROUTER_PORT": 7447})``
    ``build_config({"mode": "peer"}, listen=["tcp/127.0.0.1:0"])``
    ``build_config(mode="client", connect=["tcp/10.0.0.1:7447"])``

    Raises :class:`ZenohConfigError` for a missing or malformed file, a missing
    variable, a bad mode or endpoint, or a key or value that Zenoh refuses.
    """
    if source is None:
        if variables:
            raise ZenohConfigError("template variables given without a config file or mapping")
        config, where, mode = zenoh.Config(), "<endpoints>", mode or "peer"
    elif isinstance(source, zenoh.Config):
        if variables:
            raise ZenohConfigError("template variables do not apply to a zenoh.Config")
        config, where = _parse(str(source), "<zenoh.Config>"), "<zenoh.Config>"
    else:
        where = "<mapping>" if isinstance(source, Mapping) else str(source)
        config = _parse(_to_json(read_config(source, variables), where), where)
    if mode is not None:
        if mode not in MODES:
            raise ZenohConfigError(f"bad Zenoh mode {mode!r}: expected one of {', '.join(MODES)}")
        _insert(config, "mode", mode, where)
    if connect is not None:
        _insert(config, "connect/endpoints", _endpoint_list(connect, "connect"), where)
    if listen is not None:
        _insert(config, "listen/endpoints", _endpoint_list(listen, "listen"), where)
    for key, value in (overrides or {}).items():
        _insert(config, key, value, where)
    if _get(config, "scouting/multicast/enabled") is None:
        _insert(config, "scouting/multicast/enabled", False, where)
    return config


def variable_value(text: str) -> Any:
    """A template variable given as text: its JSON value when it parses (``7447``, ``["a"]``), else the text."""
    try:
        return json.loads(text)
    except ValueError:
        return text


def environment_variables(environ: Mapping[str, str] | None = None) -> dict[str, Any]:
    """Template variables from ``WM_ZENOH_<NAME>`` environment variables (values as :func:`variable_value`)."""
    env = os.environ if environ is None else environ
    return {
        key[len(ENV_PREFIX) :]: variable_value(raw)
        for key, raw in env.items()
        if key.startswith(ENV_PREFIX) and len(key) > len(ENV_PREFIX)
    }


def load_with_environment(path: PathLike | None) -> zenoh.Config | None:
    """The config of a command line's ``--config FILE``: FILE with its placeholders
    filled from ``WM_ZENOH_<NAME>`` environment variables; ``None`` without a file."""
    return None if path is None else build_config(path, variables=environment_variables())


# -- helpers ---------------------------------------------------------------------


def _read_json5(path: Path) -> dict[str, Any]:
    if not path.exists():
        raise ZenohConfigError(f"Zenoh config file not found: {path}")
    try:
        data = json5.loads(path.read_text(encoding="utf-8"))
    except (OSError, UnicodeDecodeError) as exc:
        raise ZenohConfigError(f"cannot read Zenoh config file {path}: {exc}") from exc
    except ValueError as exc:
        raise ZenohConfigError(f"invalid Zenoh JSON5 config in {path}: {exc}") from exc
    if not isinstance(data, dict):
        raise ZenohConfigError(f"invalid Zenoh JSON5 config in {path}: expected an object, not {type(data).__name__}")
    return data


def _fill(value: Any, expand: Callable[[str], Any]) -> Any:
    """``value`` with ``expand`` applied to every string inside it (keys stay as they are)."""
    if isinstance(value, str):
        return expand(value)
    if isinstance(value, Mapping):
        return {key: _fill(item, expand) for key, item in value.items()}
    if isinstance(value, (list, tuple)):
        return [_fill(item, expand) for item in value]
    return value


def _inline_text(where: str, name: str, value: Any) -> str:
    """A variable's text inside a longer string: JSON spelling for booleans; no lists or mappings."""
    if isinstance(value, (list, tuple, set, frozenset, Mapping)):
        raise ZenohConfigError(
            f"{where}: variable {name} is a {type(value).__name__} but is used inside a longer string"
        )
    if isinstance(value, bool):
        return "true" if value else "false"
    return str(value)


def _json_default(value: Any) -> Any:
    if isinstance(value, (set, frozenset)):
        return sorted(value)
    if isinstance(value, os.PathLike):
        return os.fspath(value)
    raise TypeError(f"{type(value).__name__} is not JSON-serialisable")


def _to_json(value: Any, where: str) -> str:
    try:
        return json.dumps(value, default=_json_default)
    except (TypeError, ValueError) as exc:
        raise ZenohConfigError(f"{where}: Zenoh config is not JSON-serialisable: {exc}") from exc


def _clean(exc: BaseException) -> str:
    """Zenoh's message without the Rust source location it appends."""
    return re.sub(r"\s+at /\S+\.rs:\d+\.?$", "", str(exc).strip())


def _parse(text: str, where: str) -> zenoh.Config:
    try:
        return zenoh.Config.from_json5(text)
    except zenoh.ZError as exc:
        raise ZenohConfigError(f"invalid Zenoh JSON5 config in {where}: {_clean(exc)}") from exc


def _insert(config: zenoh.Config, key: str, value: Any, where: str) -> None:
    try:
        config.insert_json5(key, _to_json(value, where))
    except zenoh.ZError as exc:
        raise ZenohConfigError(f"{where}: cannot set {key!r} to {value!r}: {_clean(exc)}") from exc


def _get(config: zenoh.Config, key: str) -> Any:
    try:
        return json.loads(config.get_json(key))
    except (zenoh.ZError, ValueError):
        return None


def _endpoint_list(endpoints: Endpoints, what: str) -> list[str]:
    items = [endpoints] if isinstance(endpoints, str) else list(endpoints)
    for endpoint in items:
        if not isinstance(endpoint, str) or not _ENDPOINT.match(endpoint):
            raise ZenohConfigError(
                f"bad {what} endpoint {endpoint!r}: expected '<proto>/<address>', e.g. 'tcp/127.0.0.1:7447'"
            )
    return items
