"""Zenoh role process for the deploy tests: a router, a subscriber or a publisher.

    zproc.py router CONFIG [NAME=VALUE ...] [--connect EP]...
    zproc.py sub CONFIG KEY [NAME=VALUE ...] [--count N] [--timeout S]
    zproc.py pub CONFIG KEY PAYLOAD [NAME=VALUE ...] [--period S] [--timeout S]

CONFIG is a JSON5 file filled with the NAME=VALUE variables (wm.net.zenoh_config).
Every role prints ``READY <zid>`` once its session is open and its entities are
declared; ``sub`` prints ``SAMPLE <key> <payload>`` per sample it receives.
Each role ends on SIGTERM/SIGINT, and ``sub``/``pub`` also after --timeout seconds
(``sub`` exits 3 when it got fewer than --count samples), always closing the session.
"""

from __future__ import annotations

import argparse
import signal
import sys
import threading
import time
from pathlib import Path

import zenoh

sys.path.insert(0, str(Path(__file__).resolve().parents[2] / "deploy"))

from zenohctl import parse_variables

from wm.net.zenoh_config import ZenohConfigError, build_config


def main() -> int:
    p = argparse.ArgumentParser()
    p.add_argument("role", choices=("router", "sub", "pub"))
    p.add_argument("config")
    p.add_argument("rest", nargs="*")
    p.add_argument("--connect", action="append", default=None)
    p.add_argument("--count", type=int, default=1)
    p.add_argument("--timeout", type=float, default=30.0)
    p.add_argument("--period", type=float, default=0.1)
    a = p.parse_args()
    positional = [x for x in a.rest if "=" not in x]
    try:
        variables = parse_variables([x for x in a.rest if "=" in x])
        config = build_config(a.config, variables=variables, connect=a.connect)
    except ZenohConfigError as e:
        print(f"ERROR {e}", flush=True)
        return 2

    stop = threading.Event()
    for sig in (signal.SIGINT, signal.SIGTERM):
        signal.signal(sig, lambda *_: stop.set())

    try:
        session = zenoh.open(config)
    except zenoh.ZError as e:
        print(f"OPEN-FAILED {e}", flush=True)
        return 4
    try:
        if a.role == "router":
            print(f"READY {session.zid()}", flush=True)
            while not stop.wait(0.2):
                pass
            return 0
        if a.role == "sub":
            (key,) = positional
            got = 0
            done = threading.Event()

            def on_sample(s: zenoh.Sample) -> None:
                nonlocal got
                print(f"SAMPLE {s.key_expr} {s.payload.to_string()}", flush=True)
                got += 1
                if got >= a.count:
                    done.set()

            session.declare_subscriber(key, on_sample, allowed_origin=zenoh.Locality.REMOTE)
            print(f"READY {session.zid()}", flush=True)
            deadline = time.monotonic() + a.timeout
            while not done.is_set() and not stop.is_set() and time.monotonic() < deadline:
                done.wait(0.1)
            return 0 if done.is_set() else 3
        key, payload = positional
        pub = session.declare_publisher(key)
        print(f"READY {session.zid()}", flush=True)
        deadline = time.monotonic() + a.timeout
        n = 0
        while not stop.is_set() and time.monotonic() < deadline:
            pub.put(f"{payload} {n}")
            n += 1
            stop.wait(a.period)
        return 0
    finally:
        session.close()


if __name__ == "__main__":
    sys.exit(main())
