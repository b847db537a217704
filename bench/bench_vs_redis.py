"""Write in one process -> notification in another: cortex-wm against Redis keyspace notifications, in the same run.

Redis is what a robotics team often picks for a shared blackboard in Python.
The bench installs Debian's ``redis-server`` if it is missing (apt-get, with
``sudo -n`` when not root), starts it on a free loopback port with
``notify-keyspace-events Kh`` and no persistence, and stops it by its PID. If
it cannot be installed or started, the bench says so and skips the Redis part.

* Redis: ``HSET probe stamp <ns>`` through redis-py in this process -> the
  ``__keyspace@0__:probe`` message in a second process (redis-py pub/sub; the
  stamp is read with ``HGET`` after the arrival time is taken).
* cortex-wm: a durable ``update_node`` in this process -> the NODE_UPDATED
  event, to a ``g.on`` callback, in a second process (two peers on loopback,
  no server in between).

Both are one-way, stamped with CLOCK_MONOTONIC; the ratio is wm / Redis p50.
"""

from __future__ import annotations

import asyncio
import json
import os
import shutil
import signal
import subprocess
import sys
import time

import wm
from benchlib import endpoint, free_port, parser, percentiles, print_table, read_line, spawn, write_json

GRAPH = "bench_vs_redis"
PACE_S = 0.002
SILENCE_S = 1.0  # a receiver stops after this long without a message


def ensure_redis_server() -> str | None:
    """The path of ``redis-server``, installing Debian's package if needed; None (and why, printed) if impossible."""
    found = shutil.which("redis-server")
    if found:
        return found
    sudo = [] if os.geteuid() == 0 else ["sudo", "-n"]
    env = {**os.environ, "DEBIAN_FRONTEND": "noninteractive"}
    for command in (["apt-get", "update", "-qq"], ["apt-get", "install", "-y", "-qq", "redis-server"]):
        try:
            done = subprocess.run([*sudo, *command], env=env, capture_output=True, text=True, timeout=600)
        except (OSError, subprocess.TimeoutExpired) as exc:
            print(f"redis-server is not installed and could not be installed ({exc}); skipping the Redis part")
            return None
        if done.returncode != 0:
            print(
                f"redis-server is not installed and `{' '.join(command)}` failed: {done.stderr.strip()[-300:]}; skipping the Redis part"
            )
            return None
    return shutil.which("redis-server")


def start_redis(binary: str, port: int) -> subprocess.Popen[str] | None:
    """A private redis-server on loopback (no disk), ready to answer; None if it did not start."""
    import redis

    server = subprocess.Popen(
        [
            binary,
            "--port",
            str(port),
            "--bind",
            "127.0.0.1",
            "--save",
            "",
            "--appendonly",
            "no",
            "--notify-keyspace-events",
            "Kh",
            "--daemonize",
            "no",
        ],
        stdout=subprocess.DEVNULL,
        stderr=subprocess.DEVNULL,
    )
    client = redis.Redis(port=port)
    for _ in range(100):
        try:
            client.ping()
            return server
        except redis.ConnectionError:
            time.sleep(0.05)
    stop(server)
    print("redis-server did not answer on loopback; skipping the Redis part")
    return None


def stop(child: subprocess.Popen) -> None:  # type: ignore[type-arg]
    if child.poll() is None:
        os.kill(child.pid, signal.SIGTERM)
    child.wait(timeout=10)


def redis_receiver(port: int) -> None:
    import redis

    client = redis.Redis(port=port)
    pubsub = client.pubsub(ignore_subscribe_messages=True)
    pubsub.subscribe("__keyspace@0__:probe")
    while pubsub.get_message(timeout=0.1) is not None:
        pass
    print("ready", flush=True)
    latencies: list[float] = []
    last = None
    while True:
        message = pubsub.get_message(timeout=SILENCE_S)
        now = time.monotonic_ns()
        if message is None:
            if latencies:  # the writer is done
                break
            continue
        if message["data"] != b"hset":
            continue
        stamp = int(client.hget("probe", "stamp"))
        if stamp != last and now >= stamp:  # a later write already landed: its own message comes next
            latencies.append((now - stamp) / 1e6)
        last = stamp
    print("result", json.dumps(latencies), flush=True)


def redis_latencies(binary: str, count: int) -> list[float] | None:
    import redis

    port = free_port()
    server = start_redis(binary, port)
    if server is None:
        return None
    child = spawn([__file__, "--role", "redis", "--port", str(port)])
    try:
        read_line(child, "ready")
        client = redis.Redis(port=port)
        for _ in range(count + 100):
            client.hset("probe", "stamp", time.monotonic_ns())
            time.sleep(PACE_S)
        return json.loads(read_line(child, "result"))
    finally:
        stop(child)
        stop(server)


async def wm_receiver(port: int) -> None:
    latencies: list[float] = []
    last = time.monotonic()
    async with wm.connect(GRAPH, name="receiver", connect=[endpoint(port)]) as g:

        def on_event(event: wm.Event) -> None:  # a callback, like the Redis listener loop
            nonlocal last
            now = time.monotonic_ns()
            latencies.append((now - g.get_node(event.id).attrs["pos_x"]) / 1e6)  # type: ignore[arg-type]
            last = time.monotonic()

        g.on(on_event, kind="node_updated", type="object")
        print("ready", flush=True)
        while not latencies or time.monotonic() - last < SILENCE_S:
            await asyncio.sleep(0.1)
    print("result", json.dumps(latencies), flush=True)


async def wm_latencies(count: int) -> list[float]:
    port = free_port()
    async with wm.connect(GRAPH, name="writer", listen=[endpoint(port)]) as g:
        node = g.insert_node("object", "probe")
        child = spawn([__file__, "--role", "wm", "--port", str(port)])
        try:
            read_line(child, "ready")
            await asyncio.sleep(1.0)
            for _ in range(count + 100):
                g.update_node(node, {"pos_x": float(time.monotonic_ns())})
                await asyncio.sleep(PACE_S)
            return json.loads(await asyncio.to_thread(read_line, child, "result"))
        finally:
            stop(child)


def main() -> None:
    p = parser("bench_vs_redis", __doc__.splitlines()[0])
    p.add_argument("--count", type=int, default=2000)
    p.add_argument("--role", choices=["main", "redis", "wm"], default="main")
    p.add_argument("--port", type=int, default=0)
    args = p.parse_args()
    if args.role == "redis":
        redis_receiver(args.port)
        return
    if args.role == "wm":
        asyncio.run(wm_receiver(args.port))
        return
    ours = percentiles(asyncio.run(wm_latencies(args.count))[100:])
    figures: dict = {"wm_durable_write_to_remote_event": ours, "redis": None}
    rows = [("wm durable write -> event (2 peers)", f"p50 {ours['p50_ms']:.3f} ms  p99 {ours['p99_ms']:.3f} ms")]
    binary = ensure_redis_server()
    samples = redis_latencies(binary, args.count) if binary else None
    if samples is not None:
        theirs = percentiles(samples[100:])
        figures["redis"] = theirs
        figures["ratio_p50_wm_to_redis"] = round(ours["p50_ms"] / theirs["p50_ms"], 2)
        figures["ratio_p99_wm_to_redis"] = round(ours["p99_ms"] / theirs["p99_ms"], 2)
        rows.append(
            ("Redis HSET -> keyspace notification", f"p50 {theirs['p50_ms']:.3f} ms  p99 {theirs['p99_ms']:.3f} ms")
        )
        rows.append(("wm / Redis", f"p50 {figures['ratio_p50_wm_to_redis']}x  p99 {figures['ratio_p99_wm_to_redis']}x"))
    print_table("write in one process -> notification in another (same host)", rows)
    write_json(args.json, figures)


if __name__ == "__main__":
    sys.exit(main())
