"""Write in one process -> event in another, against raw Zenoh one-way latency in the same run.

The receiver is a second process. Both stamp with CLOCK_MONOTONIC, which is
shared by every process on the host, so one-way latency is measured directly.
Raw baseline: a Zenoh put from A seen by a subscriber callback in B (in
Zenoh's own thread). A second baseline hands each sample from that callback to
an asyncio task, as any asyncio program on raw Zenoh must, to show what the
hand-off to the event loop costs by itself.
cortex-wm: ``update_node`` in A seen as a NODE_UPDATED event by an async
consumer in B (durable and volatile attributes, separately).
"""

from __future__ import annotations

import asyncio
import json
import os
import signal
import sys
import time

import zenoh

import wm
from benchlib import endpoint, free_port, parser, percentiles, print_table, read_line, spawn, write_json
from wm.net.zenoh_config import build_config

GRAPH = "bench"


async def receiver(port: int, count: int) -> None:
    raw: list[float] = []
    raw_loop: list[float] = []
    loop = asyncio.get_running_loop()
    samples: asyncio.Queue[bytes] = asyncio.Queue()
    session = zenoh.open(build_config(mode="peer", connect=[endpoint(port)], listen=["tcp/127.0.0.1:0"]))
    session.declare_subscriber(
        "bench/raw", lambda s: raw.append((time.monotonic_ns() - int(s.payload.to_bytes())) / 1e6)
    )
    session.declare_subscriber(
        "bench/raw_loop", lambda s: loop.call_soon_threadsafe(samples.put_nowait, s.payload.to_bytes())
    )

    async def consume_raw() -> None:
        while True:
            payload = await samples.get()
            raw_loop.append((time.monotonic_ns() - int(payload)) / 1e6)

    consumer = asyncio.ensure_future(consume_raw())
    latencies: dict[str, list[float]] = {"durable": [], "volatile": []}
    async with wm.connect(GRAPH, name="receiver", connect=[endpoint(port)]) as g:
        print("ready", flush=True)
        with g.events(kind="node_updated", type="object") as events:
            async for event in events:
                now = time.monotonic_ns()
                node = g.get_node(event.id)
                kind = "volatile" if "stamp" in event.attrs else "durable"
                sent = node.attrs["stamp"] if kind == "volatile" else node.attrs["pos_x"]
                latencies[kind].append((now - sent) / 1e6)
                if all(len(v) >= count for v in latencies.values()):
                    break
    consumer.cancel()
    session.close()
    print("result", json.dumps({"raw": raw, "raw_loop": raw_loop, **latencies}), flush=True)


async def sender(port: int, count: int) -> dict:
    raw_session = zenoh.open(build_config(mode="peer", listen=[endpoint(free_port())]))
    async with wm.connect(GRAPH, name="sender", listen=[endpoint(port)]) as g:
        node = g.insert_node("object", "probe")
        child = spawn([__file__, "--role", "receiver", "--port", str(port), "--count", str(count)])
        try:
            read_line(child, "ready")
            raw_session.close()  # the raw baseline goes through the same wm listener session
            session = g.network.session  # type: ignore[union-attr]
            await asyncio.sleep(1.0)
            for key in ("bench/raw", "bench/raw_loop"):
                publisher = session.declare_publisher(key, express=True)
                for _ in range(count + 50):
                    publisher.put(str(time.monotonic_ns()).encode())
                    await asyncio.sleep(0.002)
                publisher.undeclare()
            for attr in ("pos_x", "stamp"):
                for _ in range(count + 50):
                    g.update_node(node, {attr: float(time.monotonic_ns())})
                    await asyncio.sleep(0.002)
            result = json.loads(await asyncio.to_thread(read_line, child, "result"))
        finally:
            if child.poll() is None:
                os.kill(child.pid, signal.SIGTERM)
            child.wait(timeout=10)
    return result


def main() -> None:
    p = parser("bench_replication_latency", __doc__.splitlines()[0])
    p.add_argument("--count", type=int, default=2000)
    p.add_argument("--role", choices=["sender", "receiver"], default="sender")
    p.add_argument("--port", type=int, default=0)
    args = p.parse_args()
    if args.role == "receiver":
        asyncio.run(receiver(args.port, args.count))
        return
    samples = asyncio.run(sender(free_port(), args.count))
    raw = percentiles(samples["raw"][50:])
    raw_loop = percentiles(samples["raw_loop"][50:])
    figures = {"raw_zenoh_one_way": raw, "raw_zenoh_to_asyncio_task": raw_loop}
    rows = [
        ("raw Zenoh one-way", f"p50 {raw['p50_ms']:.3f} ms  p99 {raw['p99_ms']:.3f} ms"),
        ("raw Zenoh -> asyncio task", f"p50 {raw_loop['p50_ms']:.3f} ms  p99 {raw_loop['p99_ms']:.3f} ms"),
    ]
    for kind in ("durable", "volatile"):
        stats = percentiles(samples[kind][50:])
        stats["ratio_p50_to_raw"] = round(stats["p50_ms"] / raw["p50_ms"], 2)
        stats["ratio_p50_to_raw_asyncio"] = round(stats["p50_ms"] / raw_loop["p50_ms"], 2)
        figures[f"wm_{kind}_write_to_event"] = stats
        rows.append(
            (
                f"wm {kind} write -> remote event",
                f"p50 {stats['p50_ms']:.3f} ms  p99 {stats['p99_ms']:.3f} ms  ratio {stats['ratio_p50_to_raw']}x"
                f" ({stats['ratio_p50_to_raw_asyncio']}x the asyncio baseline)",
            )
        )
    figures["goals"] = {"p50_ms": 0.4, "p99_ms": 2.0, "ratio": 2.5}
    print_table("write in A -> event in B (same host, two processes)", rows)
    write_json(args.json, figures)


if __name__ == "__main__":
    sys.exit(main())
