"""Write -> event latency with N replicas of one graph behind a ``wm serve`` router, against raw Zenoh fan-out.

For each N (2, 8, 16, 32 by default) this starts, on loopback, a ``wm serve``
router (its own free port, multicast scouting off) and N subscriber processes
connected to it in client mode; this process is the writer, also a client.
Every subscriber holds a replica of the graph (``wm.connect``) and, on the
same Zenoh session, a raw subscriber. In the same run, for each N:

* raw Zenoh: a put from the writer -> the subscriber callback in each process;
* raw Zenoh to asyncio: the same put, handed from that callback to the process's
  event loop (``call_soon_threadsafe``) and stamped there, which is what an
  asyncio program built on raw Zenoh gets;
* cortex-wm: a durable ``update_node`` in the writer -> the NODE_UPDATED event
  in each replica (``wm serve`` applies and stores every write too).

Latency is one-way, stamped with CLOCK_MONOTONIC (shared by the processes of
a host). A figure is over every (write, subscriber) pair; "slowest" is, per
write, the last subscriber to see it. Writes are paced so that the machine is
idle between them. Every process is stopped by its PID.
"""

from __future__ import annotations

import asyncio
import json
import os
import signal
import subprocess
import sys
import tempfile
import time
from collections import defaultdict

import wm
from benchlib import endpoint, free_port, parser, percentiles, print_table, read_line, spawn, write_json

GRAPH = "bench_scaling"
RAW_KEY = "bench/scaling/raw"


async def subscriber(port: int, index: int) -> None:
    """One replica in client mode; prints every latency it saw when told to stop."""
    raw: list[tuple[int, float]] = []
    raw_asyncio: list[tuple[int, float]] = []
    durable: list[tuple[int, float]] = []
    loop = asyncio.get_running_loop()

    def on_loop(seq: int, sent: int) -> None:
        raw_asyncio.append((seq, (time.monotonic_ns() - sent) / 1e6))

    def on_raw(sample: object) -> None:
        now = time.monotonic_ns()
        seq, sent = sample.payload.to_bytes().split(b":")  # type: ignore[attr-defined]
        raw.append((int(seq), (now - int(sent)) / 1e6))
        loop.call_soon_threadsafe(on_loop, int(seq), int(sent))

    async with wm.connect(GRAPH, name=f"sub{index}", connect=[endpoint(port)], mode="client") as g:
        g.network.session.declare_subscriber(RAW_KEY, on_raw)  # type: ignore[union-attr]

        def on_event(event: wm.Event) -> None:
            now = time.monotonic_ns()
            attrs = g.get_node(event.id).attrs  # type: ignore[arg-type]
            durable.append((int(attrs["track_id"]), (now - attrs["pos_x"]) / 1e6))

        g.on(on_event, kind="node_updated", type="object")
        print("ready", flush=True)
        await asyncio.to_thread(sys.stdin.readline)
    print("result", json.dumps({"raw": raw, "raw_asyncio": raw_asyncio, "durable": durable}), flush=True)


def start_router(port: int, data: str) -> subprocess.Popen[str]:
    router = subprocess.Popen(
        [sys.executable, "-m", "wm.cli", "serve", "--graph", GRAPH, "--data", data, "--listen", endpoint(port)],
        stdout=subprocess.PIPE,
        stderr=subprocess.DEVNULL,
        text=True,
        env={**os.environ, "PYTHONUNBUFFERED": "1"},
    )
    read_line(router, "wm serve: ready")
    return router


def stop(child: subprocess.Popen[str]) -> None:
    if child.poll() is None:
        os.kill(child.pid, signal.SIGTERM)
    try:
        child.wait(timeout=20)
    except subprocess.TimeoutExpired:
        os.kill(child.pid, signal.SIGKILL)
        child.wait()


async def write_all(port: int, count: int, pace_s: float, subscribers: int) -> None:
    """Raw puts, then durable writes, ``count`` of each (the first tenth are warm-up)."""
    async with wm.connect(GRAPH, name="writer", connect=[endpoint(port)], mode="client") as g:
        deadline = time.monotonic() + 60
        while len(g.members()) < subscribers + 2 and time.monotonic() < deadline:  # + wm serve + this writer
            await asyncio.sleep(0.1)
        node = g.insert_node("object", "probe")
        await asyncio.sleep(1.0)
        publisher = g.network.session.declare_publisher(RAW_KEY, express=True)  # type: ignore[union-attr]
        for seq in range(count):
            publisher.put(f"{seq}:{time.monotonic_ns()}".encode())
            await asyncio.sleep(pace_s)
        for seq in range(count):
            g.update_node(node, {"track_id": seq, "pos_x": float(time.monotonic_ns())})
            await asyncio.sleep(pace_s)
        await asyncio.sleep(1.0)


def run(n: int, count: int) -> dict[str, list[tuple[int, float]]]:
    """Every (seq, latency) pair seen by ``n`` subscribers: raw, raw handed to asyncio, and durable."""
    port = free_port()
    children: list[subprocess.Popen[str]] = []
    with tempfile.TemporaryDirectory(prefix="wm-scaling-") as data:
        router = start_router(port, data)
        try:
            children = [
                spawn([__file__, "--role", "subscriber", "--port", str(port), "--index", str(i)]) for i in range(n)
            ]
            for child in children:
                read_line(child, "ready")
            asyncio.run(write_all(port, count, pace_s=max(0.003, 0.0006 * n), subscribers=n))
            seen: dict[str, list[tuple[int, float]]] = {"raw": [], "raw_asyncio": [], "durable": []}
            for child in children:
                assert child.stdin is not None
                child.stdin.write("stop\n")
                child.stdin.flush()
            for child in children:
                result = json.loads(read_line(child, "result"))
                for kind in seen:
                    seen[kind] += [tuple(pair) for pair in result[kind]]  # type: ignore[misc]
            return seen
        finally:
            for child in children:
                stop(child)
            stop(router)


def summarise(pairs: list[tuple[int, float]], n: int, count: int) -> dict[str, float]:
    warm = count // 10
    kept = [(seq, ms) for seq, ms in pairs if seq >= warm]
    slowest: dict[int, float] = defaultdict(float)
    for seq, ms in kept:
        slowest[seq] = max(slowest[seq], ms)
    stats = percentiles([ms for _, ms in kept])
    stats["slowest_p50_ms"] = percentiles(list(slowest.values()))["p50_ms"]
    stats["delivered"] = round(len(kept) / (n * (count - warm)), 4)
    return stats


def main() -> None:
    p = parser("bench_replica_scaling", __doc__.splitlines()[0])
    p.add_argument("--replicas", default="2,8,16,32", help="comma-separated subscriber counts")
    p.add_argument("--count", type=int, default=300, help="writes of each kind per N")
    p.add_argument("--role", choices=["main", "subscriber"], default="main")
    p.add_argument("--port", type=int, default=0)
    p.add_argument("--index", type=int, default=0)
    args = p.parse_args()
    if args.role == "subscriber":
        try:
            asyncio.run(subscriber(args.port, args.index))
        except (KeyboardInterrupt, asyncio.CancelledError):
            pass
        return
    rows, figures = [], {}
    for n in (int(x) for x in args.replicas.split(",")):
        seen = run(n, args.count)
        raw, durable = summarise(seen["raw"], n, args.count), summarise(seen["durable"], n, args.count)
        raw_asyncio = summarise(seen["raw_asyncio"], n, args.count)
        ratio = round(durable["p50_ms"] / raw["p50_ms"], 2)
        ratio_asyncio = round(durable["p50_ms"] / raw_asyncio["p50_ms"], 2)
        figures[str(n)] = {
            "raw_zenoh": raw,
            "raw_zenoh_to_asyncio": raw_asyncio,
            "wm_durable": durable,
            "ratio_p50": ratio,
            "ratio_p50_to_asyncio": ratio_asyncio,
            "ratio_slowest_p50": round(durable["slowest_p50_ms"] / raw["slowest_p50_ms"], 2),
        }
        rows.append(
            (
                f"N={n}",
                f"raw p50 {raw['p50_ms']:.3f} ms  raw->asyncio {raw_asyncio['p50_ms']:.3f} ms  "
                f"wm p50 {durable['p50_ms']:.3f} ms  ratio {ratio}x ({ratio_asyncio}x to asyncio)  |  "
                f"slowest p50 raw {raw['slowest_p50_ms']:.3f} wm {durable['slowest_p50_ms']:.3f}  |  "
                f"wm p99 {durable['p99_ms']:.3f} ms  delivered {durable['delivered']:.0%}",
            )
        )
        print(rows[-1][0], rows[-1][1], flush=True)
    print_table("write -> event in N client-mode replicas behind a wm serve router (raw Zenoh fan-out alongside)", rows)
    write_json(args.json, {"graph": GRAPH, "writes_per_kind": args.count, "replicas": figures})


if __name__ == "__main__":
    sys.exit(main())
