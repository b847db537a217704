#!/usr/bin/env python3
"""Zenoh deployment tool of cortex-wm: render and check templates, run a router, smoke-test pub/sub.

The raw steps of docs/deploy.md, with the templates of ``deploy/zenoh/``::

    .venv/bin/python deploy/zenohctl.py render TEMPLATE [-o OUT] [NAME=VALUE ...]
    .venv/bin/python deploy/zenohctl.py check FILE [NAME=VALUE ...]
    .venv/bin/python deploy/zenohctl.py run FILE [--mode M] [--connect EP]... [--listen EP]... [NAME=VALUE ...]
    .venv/bin/python deploy/zenohctl.py sub FILE KEYEXPR [--count N] [--timeout S] [NAME=VALUE ...]
    .venv/bin/python deploy/zenohctl.py put FILE KEY VALUE [--timeout S] [NAME=VALUE ...]

Template variables come from ``NAME=VALUE`` assignments (NAME in capitals,
anywhere on the line; a VALUE that parses as JSON is used as such), else from
``WM_ZENOH_<NAME>`` environment variables, else from the placeholder's default.

``render`` writes the file as JSON with its placeholders filled (comments are
dropped). ``run`` opens a session (typically a router) and keeps it open until
SIGINT/SIGTERM. ``sub`` prints the samples it receives from other processes;
``put`` waits (up to ``--timeout``) until a subscriber matches, then puts once.
"""

from __future__ import annotations

import argparse
import json
import re
import signal
import sys
import threading
import time
from collections.abc import Sequence
from pathlib import Path
from typing import Any

import zenoh

from wm.net.zenoh_config import (
    MODES,
    ZenohConfigError,
    build_config,
    environment_variables,
    read_config,
    variable_value,
)

_ASSIGNMENT = re.compile(r"^[A-Z_][A-Z0-9_]*=")


def parse_variables(items: Sequence[str]) -> dict[str, Any]:
    """``NAME=VALUE`` pairs as template variables (values as :func:`wm.net.zenoh_config.variable_value`)."""
    out: dict[str, Any] = {}
    for item in items:
        name, sep, raw = item.partition("=")
        if not sep or not re.fullmatch(r"[A-Za-z_][A-Za-z0-9_]*", name):
            raise ZenohConfigError(f"expected NAME=VALUE, got {item!r}")
        out[name] = variable_value(raw)
    return out


def build_parser() -> argparse.ArgumentParser:
    """The five commands and their options (``NAME=VALUE`` assignments are taken out before parsing)."""
    parser = argparse.ArgumentParser(prog="zenohctl.py", description=(__doc__ or "").split("\n")[0])
    commands = parser.add_subparsers(dest="cmd", required=True)
    p = commands.add_parser("render", help="render a template to stdout or -o FILE")
    p.add_argument("file")
    p.add_argument("-o", "--output")
    p = commands.add_parser("check", help="load a config (rendering it) and print its mode and endpoints")
    p.add_argument("file")
    p = commands.add_parser("run", help="open a session with FILE and keep it open until SIGINT/SIGTERM")
    p.add_argument("file")
    p.add_argument("--mode", choices=MODES)
    p.add_argument("--connect", action="append", default=None, metavar="ENDPOINT")
    p.add_argument("--listen", action="append", default=None, metavar="ENDPOINT")
    p = commands.add_parser("sub", help="print samples from other processes on KEYEXPR")
    p.add_argument("file")
    p.add_argument("key")
    p.add_argument("--count", type=int, default=0, help="exit after N samples (0: never)")
    p.add_argument("--timeout", type=float, default=0.0, help="exit after S seconds (0: never)")
    p = commands.add_parser("put", help="put VALUE on KEY once a subscriber matches")
    p.add_argument("file")
    p.add_argument("key")
    p.add_argument("value")
    p.add_argument("--timeout", type=float, default=10.0)
    return parser


def main(argv: Sequence[str] | None = None) -> int:
    """Run one command; exit status 0 on success, 1 when no session opens, 2 for a bad config, 3 on timeout."""
    tokens = list(sys.argv[1:] if argv is None else argv)
    args = build_parser().parse_args([t for t in tokens if not _ASSIGNMENT.match(t)])
    try:
        variables = {**environment_variables(), **parse_variables([t for t in tokens if _ASSIGNMENT.match(t)])}
        if args.cmd == "run":
            config = build_config(
                args.file, variables=variables, mode=args.mode, connect=args.connect, listen=args.listen
            )
        else:
            config = build_config(args.file, variables=variables)
        if args.cmd == "render":
            _render(read_config(args.file, variables), args.output)
            return 0
    except ZenohConfigError as exc:
        print(f"error: {exc}", file=sys.stderr)
        return 2
    if args.cmd == "check":
        for key in ("mode", "listen/endpoints", "connect/endpoints", "scouting/multicast/enabled"):
            print(f"{key}: {config.get_json(key)}")
        return 0
    return _with_session(config, args)


def _render(data: dict[str, Any], output: str | None) -> None:
    text = json.dumps(data, indent=2) + "\n"
    if output is None:
        sys.stdout.write(text)
        return
    Path(output).parent.mkdir(parents=True, exist_ok=True)
    Path(output).write_text(text)


def _with_session(config: zenoh.Config, args: argparse.Namespace) -> int:
    """``run``, ``sub`` or ``put`` in a session that is closed on the way out, SIGINT and SIGTERM included."""
    stop = threading.Event()
    for sig in (signal.SIGINT, signal.SIGTERM):
        signal.signal(sig, lambda *_: stop.set())
    try:
        session = zenoh.open(config)
    except zenoh.ZError as exc:
        print(f"error: cannot open Zenoh session: {exc}", file=sys.stderr)
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
