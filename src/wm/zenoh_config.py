"""Build ``zenoh.Config`` objects for cortex-wm processes.

Every cortex-wm process (agents, ``wm serve``, monitors, the routers of a
deployment) opens exactly one Zenoh session.  This module is the single place
where the configuration of that session is assembled, from

(a) a JSON5 file, usually one of the templates under ``deploy/zenoh/``,
(b) a mapping (already parsed configuration), or
(c) plain ``mode=`` / ``connect=`` / ``listen=`` arguments,

and the three can be combined: the file or mapping is loaded first, then the
keyword arguments override ``mode``, ``connect/endpoints``, ``listen/endpoints``
and any ``overrides`` given as ``{"zenoh/config/path": value}``.

Multicast scouting is switched **off** unless the file or mapping sets
``scouting.multicast.enabled`` itself: cortex-wm processes find each other
through explicit endpoints, never by accident on a shared LAN.

Templates
---------
The files under ``deploy/zenoh/`` are JSON5 with placeholders that keep them
valid JSON5 before rendering:

* ``"${NAME}"``: a whole JSON string that is just a placeholder is replaced by
  the JSON encoding of the value, so a list, number or boolean can be injected
  (``cert_common_names: "${WRITERS}"`` with ``WRITERS=["perception"]``).
* ``${NAME}`` inside a longer string is replaced by ``str(value)``
  (``"tcp/${HOST}:${PORT}"``).
* ``${NAME:-default}`` uses ``default`` when ``NAME`` is not given.

When a file is loaded or rendered, a variable not given explicitly is taken from
the environment variable ``WM_ZENOH_<NAME>`` if set (parsed as JSON when it
parses, e.g. ``WM_ZENOH_WRITERS='["perception"]'``), so that tools which only
take a config path (``wm serve --config``, ``wm.connect(config=...)``) can use
the templates too.  A placeholder without a value and without a default is an
error (:class:`ZenohConfigError` names every missing variable).

Command line (the raw steps of ``docs/deploy.md``; ``deploy/zenohctl.py`` is the
same without ``-m``).  ``NAME=VALUE`` template variables, NAME in capitals, may
stand anywhere on the line; a VALUE that parses as JSON is used as such::

    python -m wm.zenoh_config render TEMPLATE [-o OUT] [NAME=VALUE ...]
    python -m wm.zenoh_config check FILE [NAME=VALUE ...]
    python -m wm.zenoh_config run FILE [--mode M] [--connect EP]... [--listen EP]... [NAME=VALUE ...]
    python -m wm.zenoh_config sub FILE KEYEXPR [--count N] [--timeout S] [NAME=VALUE ...]
    python -m wm.zenoh_config put FILE KEY VALUE [--timeout S] [NAME=VALUE ...]

``run`` opens a session with the file (typically a router) and keeps it open
until SIGINT/SIGTERM.  It is the stand-in for ``wm serve`` until that exists.
``sub`` prints the samples it receives from other processes; ``put`` waits (up to
``--timeout``) until a subscriber matches, then puts once.  Both are smoke tests
of a deployment.
"""

from __future__ import annotations

import argparse
import json
import os
import re
import signal
import sys
import threading
import time
from collections.abc import Iterable, Mapping, Sequence
from pathlib import Path
from typing import Any, Literal, TypeAlias

import zenoh

__all__ = [
    "Mode",
    "ZenohConfigError",
    "build_config",
    "config_from_dict",
    "config_from_endpoints",
    "config_from_file",
    "deploy_dir",
    "main",
    "parse_variables",
    "render_template",
    "render_template_file",
    "template_path",
    "template_variables",
]

Mode: TypeAlias = Literal["peer", "client", "router"]
MODES: tuple[str, ...] = ("peer", "client", "router")

PathLike: TypeAlias = str | os.PathLike[str]
Endpoints: TypeAlias = str | Iterable[str]

_PLACEHOLDER = re.compile(r"\$\{([A-Za-z_][A-Za-z0-9_]*)(?::-([^}]*))?\}")
# A JSON string (double or single quoted) whose whole content is one placeholder.
_WHOLE_STRING = re.compile(
    r"""(?P<q>["'])\$\{(?P<name>[A-Za-z_][A-Za-z0-9_]*)(?::-(?P<default>[^}"']*))?\}(?P=q)"""
)
_ASSIGNMENT = re.compile(r"^[A-Z_][A-Z0-9_]*=")
_ENDPOINT = re.compile(r"^[a-z][a-z0-9+-]*/[^\s#]+(#.*)?$")


class ZenohConfigError(ValueError):
    """A Zenoh configuration could not be built; the message names the problem."""


# --------------------------------------------------------------------------
# templates
# --------------------------------------------------------------------------


def deploy_dir() -> Path:
    """Directory holding the deployment templates (``deploy/zenoh``).

    ``$WM_DEPLOY_DIR`` wins when set (an installed, non-editable package has no
    ``deploy/`` next to it); otherwise the repository's ``deploy/zenoh``.
    """
    env = os.environ.get("WM_DEPLOY_DIR")
    if env:
        return Path(env)
    return Path(__file__).resolve().parents[2] / "deploy" / "zenoh"


def template_path(name: str) -> Path:
    """Path of a template by its name relative to :func:`deploy_dir`,
    e.g. ``"router.json5"`` or ``"tls/client.json5"``."""
    path = deploy_dir() / name
    if not path.is_file():
        raise ZenohConfigError(f"no Zenoh config template {name!r} (looked for {path})")
    return path


def template_variables(text: str) -> dict[str, str | None]:
    """Placeholders of a template: name -> default (``None`` when required)."""
    found: dict[str, str | None] = {}
    for m in _PLACEHOLDER.finditer(_strip_comments(text)):
        name, default = m.group(1), m.group(2)
        if name not in found or found[name] is None:
            found[name] = default
    return found


ENV_PREFIX = "WM_ZENOH_"


def _with_environment(variables: Mapping[str, Any] | None) -> dict[str, Any]:
    merged: dict[str, Any] = {}
    for key, raw in os.environ.items():
        if key.startswith(ENV_PREFIX) and len(key) > len(ENV_PREFIX):
            try:
                merged[key[len(ENV_PREFIX) :]] = json.loads(raw)
            except ValueError:
                merged[key[len(ENV_PREFIX) :]] = raw
    merged.update(variables or {})
    return merged


def render_template(text: str, variables: Mapping[str, Any] | None = None, *, source: str = "<template>") -> str:
    """Substitute ``${NAME}`` placeholders in JSON5 template text (see module doc).

    Only ``variables`` are used here; the file-level functions add ``WM_ZENOH_*``.

    Raises :class:`ZenohConfigError` naming every variable that has neither a
    value nor a default, or a list/dict value used inside a longer string.
    """
    values: Mapping[str, Any] = variables or {}
    missing: set[str] = set()

    def lookup(name: str, default: str | None) -> Any:
        if name in values:
            return values[name]
        if default is not None:
            return default
        missing.add(name)
        return ""

    def whole(m: re.Match[str]) -> str:
        value = lookup(m.group("name"), m.group("default"))
        return json.dumps(_to_json_value(value))

    def inner(m: re.Match[str]) -> str:
        name = m.group(1)
        value = lookup(name, m.group(2))
        if isinstance(value, (list, tuple, dict, set)):
            raise ZenohConfigError(
                f"{source}: variable {name} is a {type(value).__name__} but is used inside a longer string"
            )
        if isinstance(value, bool):
            return "true" if value else "false"
        return str(value)

    out: list[str] = []
    for is_comment, chunk in _split_comments(text):
        if is_comment:
            out.append(chunk)
            continue
        chunk = _WHOLE_STRING.sub(whole, chunk)
        out.append(_PLACEHOLDER.sub(inner, chunk))
    if missing:
        raise ZenohConfigError(f"{source}: no value for template variable(s) {', '.join(sorted(missing))}")
    return "".join(out)


def render_template_file(
    src: PathLike, dst: PathLike | None = None, variables: Mapping[str, Any] | None = None
) -> str:
    """Render the template file ``src``; write it to ``dst`` when given. Returns the text."""
    text = render_template(_read(src), _with_environment(variables), source=str(src))
    _parse_json5(text, source=str(src))  # fail here, not when a session opens
    if dst is not None:
        Path(dst).parent.mkdir(parents=True, exist_ok=True)
        Path(dst).write_text(text)
    return text


def _to_json_value(value: Any) -> Any:
    if isinstance(value, (set, frozenset)):
        return sorted(value)
    if isinstance(value, tuple):
        return list(value)
    if isinstance(value, os.PathLike):
        return os.fspath(value)
    return value


def _split_comments(text: str) -> list[tuple[bool, str]]:
    """Split JSON5 text into (is_comment, chunk) pieces, keeping strings intact."""
    pieces: list[tuple[bool, str]] = []
    i, start, n = 0, 0, len(text)
    while i < n:
        c = text[i]
        if c in "\"'":
            i += 1
            while i < n and text[i] != c:
                i += 2 if text[i] == "\\" else 1
            i += 1
        elif text.startswith("//", i) or text.startswith("/*", i):
            if i > start:
                pieces.append((False, text[start:i]))
            end = text.find("\n", i) if text[i + 1] == "/" else text.find("*/", i + 2)
            end = n if end < 0 else (end if text[i + 1] == "/" else end + 2)
            pieces.append((True, text[i:end]))
            i = start = end
        else:
            i += 1
    if start < n:
        pieces.append((False, text[start:]))
    return pieces


def _strip_comments(text: str) -> str:
    return "".join(chunk for is_comment, chunk in _split_comments(text) if not is_comment)


# --------------------------------------------------------------------------
# building configs
# --------------------------------------------------------------------------


def _read(path: PathLike) -> str:
    p = Path(path)
    if not p.exists():
        raise ZenohConfigError(f"Zenoh config file not found: {p}")
    if not p.is_file():
        raise ZenohConfigError(f"Zenoh config path is not a file: {p}")
    try:
        return p.read_text()
    except (OSError, UnicodeDecodeError) as e:
        raise ZenohConfigError(f"cannot read Zenoh config file {p}: {e}") from e


def _parse_json5(text: str, *, source: str) -> zenoh.Config:
    try:
        return zenoh.Config.from_json5(text)
    except zenoh.ZError as e:
        raise ZenohConfigError(f"invalid Zenoh JSON5 config in {source}: {_clean(e)}") from e


def _clean(e: BaseException) -> str:
    # zenoh appends " at /root/.cargo/.../file.rs:NN." to its messages
    return re.sub(r"\s+at /\S+\.rs:\d+\.?$", "", str(e).strip())


def _insert(config: zenoh.Config, key: str, value: Any, *, source: str) -> None:
    try:
        config.insert_json5(key, json.dumps(_to_json_value(value)))
    except zenoh.ZError as e:
        raise ZenohConfigError(f"{source}: cannot set {key!r} to {value!r}: {_clean(e)}") from e


def _get(config: zenoh.Config, key: str) -> Any:
    try:
        return json.loads(config.get_json(key))
    except (zenoh.ZError, ValueError):
        return None


def _endpoint_list(endpoints: Endpoints, what: str) -> list[str]:
    items = [endpoints] if isinstance(endpoints, str) else list(endpoints)
    for ep in items:
        if not isinstance(ep, str) or not _ENDPOINT.match(ep):
            raise ZenohConfigError(
                f"bad {what} endpoint {ep!r}: expected '<proto>/<address>', e.g. 'tcp/127.0.0.1:7447'"
            )
    return items


def _apply(
    config: zenoh.Config,
    *,
    source: str,
    mode: Mode | None,
    connect: Endpoints | None,
    listen: Endpoints | None,
    overrides: Mapping[str, Any] | None,
) -> zenoh.Config:
    if mode is not None:
        if mode not in MODES:
            raise ZenohConfigError(f"bad Zenoh mode {mode!r}: expected one of {', '.join(MODES)}")
        _insert(config, "mode", mode, source=source)
    if connect is not None:
        _insert(config, "connect/endpoints", _endpoint_list(connect, "connect"), source=source)
    if listen is not None:
        _insert(config, "listen/endpoints", _endpoint_list(listen, "listen"), source=source)
    for key, value in (overrides or {}).items():
        _insert(config, key, value, source=source)
    # Off unless the file, the mapping or the overrides decided.
    if _get(config, "scouting/multicast/enabled") is None:
        _insert(config, "scouting/multicast/enabled", False, source=source)
    return config


def config_from_file(
    path: PathLike,
    *,
    variables: Mapping[str, Any] | None = None,
    mode: Mode | None = None,
    connect: Endpoints | None = None,
    listen: Endpoints | None = None,
    overrides: Mapping[str, Any] | None = None,
) -> zenoh.Config:
    """Load a JSON5 file (rendering its placeholders with ``variables``, then
    ``WM_ZENOH_<NAME>`` environment variables, then defaults), then apply the overrides."""
    source = str(path)
    text = render_template(_read(path), _with_environment(variables), source=source)
    config = _parse_json5(text, source=source)
    return _apply(
        config,
        source=source,
        mode=mode,
        connect=connect,
        listen=listen,
        overrides=overrides,
    )


def config_from_dict(
    data: Mapping[str, Any],
    *,
    mode: Mode | None = None,
    connect: Endpoints | None = None,
    listen: Endpoints | None = None,
    overrides: Mapping[str, Any] | None = None,
) -> zenoh.Config:
    """Build from a mapping shaped like the JSON5 file, then apply the overrides."""
    if not isinstance(data, Mapping):
        raise ZenohConfigError(f"Zenoh config must be a mapping, not {type(data).__name__}")
    try:
        text = json.dumps(data, default=_json_default)
    except (TypeError, ValueError) as e:
        raise ZenohConfigError(f"Zenoh config mapping is not JSON-serialisable: {e}") from e
    config = _parse_json5(text, source="<dict>")
    return _apply(
        config,
        source="<dict>",
        mode=mode,
        connect=connect,
        listen=listen,
        overrides=overrides,
    )


def _json_default(value: Any) -> Any:
    converted = _to_json_value(value)
    if converted is value:
        raise TypeError(f"{type(value).__name__} is not JSON-serialisable")
    return converted


def config_from_endpoints(
    *,
    mode: Mode = "peer",
    connect: Endpoints = (),
    listen: Endpoints = (),
    overrides: Mapping[str, Any] | None = None,
) -> zenoh.Config:
    """A config from endpoints alone (multicast scouting off)."""
    return _apply(
        zenoh.Config(),
        source="<endpoints>",
        mode=mode,
        connect=connect,
        listen=listen,
        overrides=overrides,
    )


def build_config(
    source: PathLike | Mapping[str, Any] | None = None,
    *,
    variables: Mapping[str, Any] | None = None,
    mode: Mode | None = None,
    connect: Endpoints | None = None,
    listen: Endpoints | None = None,
    overrides: Mapping[str, Any] | None = None,
) -> zenoh.Config:
    """One entry point: a file path, a mapping, or nothing (endpoints only).

    ``build_config("deploy/zenoh/client.json5", variables={"ROUTER_PORT": 7447})``
    ``build_config({"mode": "peer"}, listen=["tcp/127.0.0.1:0"])``
    ``build_config(mode="client", connect=["tcp/10.0.0.1:7447"])``
    """
    if source is None:
        if variables:
            raise ZenohConfigError("template variables given without a config file")
        return config_from_endpoints(
            mode=mode or "peer", connect=connect or (), listen=listen or (), overrides=overrides
        )
    if isinstance(source, Mapping):
        if variables:
            raise ZenohConfigError("template variables only apply to config files")
        return config_from_dict(source, mode=mode, connect=connect, listen=listen, overrides=overrides)
    if isinstance(source, (str, os.PathLike)):
        return config_from_file(
            source, variables=variables, mode=mode, connect=connect, listen=listen, overrides=overrides
        )
    raise ZenohConfigError(f"Zenoh config source must be a path or a mapping, not {type(source).__name__}")


# --------------------------------------------------------------------------
# command line
# --------------------------------------------------------------------------


def parse_variables(items: Sequence[str]) -> dict[str, Any]:
    """``NAME=VALUE`` pairs; a VALUE that parses as JSON (number, list, bool) is used as such."""
    out: dict[str, Any] = {}
    for item in items:
        name, sep, raw = item.partition("=")
        if not sep or not re.fullmatch(r"[A-Za-z_][A-Za-z0-9_]*", name):
            raise ZenohConfigError(f"expected NAME=VALUE, got {item!r}")
        try:
            value: Any = json.loads(raw)
        except ValueError:
            value = raw
        out[name] = value
    return out


def main(argv: Sequence[str] | None = None) -> int:
    parser = argparse.ArgumentParser(prog="python -m wm.zenoh_config", description=__doc__.split("\n")[0])
    sub = parser.add_subparsers(dest="cmd", required=True)
    p_render = sub.add_parser("render", help="render a template to stdout or -o FILE")
    p_render.add_argument("template")
    p_render.add_argument("-o", "--output")
    p_check = sub.add_parser("check", help="load a config (rendering it) and print its mode and endpoints")
    p_check.add_argument("file")
    p_run = sub.add_parser("run", help="open a session with FILE and keep it open until SIGINT/SIGTERM")
    p_run.add_argument("file")
    p_run.add_argument("--mode", choices=MODES)
    p_run.add_argument("--connect", action="append", default=None, metavar="ENDPOINT")
    p_run.add_argument("--listen", action="append", default=None, metavar="ENDPOINT")
    p_sub = sub.add_parser("sub", help="print samples from other processes on KEYEXPR")
    p_sub.add_argument("file")
    p_sub.add_argument("key")
    p_sub.add_argument("--count", type=int, default=0, help="exit after N samples (0: never)")
    p_sub.add_argument("--timeout", type=float, default=0.0, help="exit after S seconds (0: never)")
    p_put = sub.add_parser("put", help="put VALUE on KEY once a subscriber matches")
    p_put.add_argument("file")
    p_put.add_argument("key")
    p_put.add_argument("value")
    p_put.add_argument("--timeout", type=float, default=10.0)
    # NAME=VALUE assignments (NAME in capitals) may stand anywhere on the line.
    tokens = list(sys.argv[1:] if argv is None else argv)
    assignments = [t for t in tokens if _ASSIGNMENT.match(t)]
    args = parser.parse_args([t for t in tokens if not _ASSIGNMENT.match(t)])
    try:
        variables = parse_variables(assignments)
        if args.cmd == "render":
            text = render_template_file(args.template, args.output, variables)
            if args.output is None:
                sys.stdout.write(text)
            return 0
        if args.cmd == "check":
            config = config_from_file(args.file, variables=variables)
            for key in ("mode", "listen/endpoints", "connect/endpoints", "scouting/multicast/enabled"):
                print(f"{key}: {config.get_json(key)}")
            return 0
        if args.cmd == "run":
            config = config_from_file(
                args.file, variables=variables, mode=args.mode, connect=args.connect, listen=args.listen
            )
        else:
            config = config_from_file(args.file, variables=variables)
    except ZenohConfigError as e:
        print(f"error: {e}", file=sys.stderr)
        return 2
    stop = threading.Event()
    for sig in (signal.SIGINT, signal.SIGTERM):
        signal.signal(sig, lambda *_: stop.set())
    try:
        session = zenoh.open(config)
    except zenoh.ZError as e:
        print(f"error: cannot open Zenoh session: {_clean(e)}", file=sys.stderr)
        return 1
    try:
        if args.cmd == "run":
            print(f"zenoh {json.loads(config.get_json('mode'))} {session.zid()} up; Ctrl-C to stop", flush=True)
            while not stop.wait(0.5):
                pass
            return 0
        if args.cmd == "sub":
            return _sub(session, args.key, args.count, args.timeout, stop)
        return _put(session, args.key, args.value, args.timeout)
    finally:
        session.close()


def _sub(session: zenoh.Session, key: str, count: int, timeout: float, stop: threading.Event) -> int:
    seen = 0
    lock = threading.Lock()

    def on_sample(sample: zenoh.Sample) -> None:
        nonlocal seen
        with lock:
            kind = "delete" if sample.kind == zenoh.SampleKind.DELETE else "put"
            raw = sample.payload.to_bytes()
            try:
                text = raw.decode()
            except UnicodeDecodeError:
                text = f"<{len(raw)} bytes>"
            print(f"{kind} {sample.key_expr} {text}", flush=True)
            seen += 1
            if count and seen >= count:
                stop.set()

    session.declare_subscriber(key, on_sample, allowed_origin=zenoh.Locality.REMOTE)
    print(f"subscribed to {key}", file=sys.stderr, flush=True)
    deadline = time.monotonic() + timeout if timeout else None
    while not stop.wait(0.2):
        if deadline is not None and time.monotonic() > deadline:
            break
    return 0 if (not count or seen >= count) else 3


def _put(session: zenoh.Session, key: str, value: str, timeout: float) -> int:
    publisher = session.declare_publisher(key)
    deadline = time.monotonic() + timeout
    while not publisher.matching_status.matching:
        if time.monotonic() > deadline:
            print(f"error: no subscriber matches {key} after {timeout} s", file=sys.stderr)
            return 3
        time.sleep(0.05)
    publisher.put(value)
    print(f"put {key} {value}", flush=True)
    return 0


if __name__ == "__main__":
    sys.exit(main())
