"""Sustained attribute writes with three replicas converging, in three processes.

Each process writes ``--writes`` attribute updates to its own node as fast as
it can (the replicator merges a loop tick's writes into one message), then
waits until it has seen the final value of every other process's node. The
figure is total writes / time until the last process has converged. Baseline
in the same run: raw pycrdt map writes with an observer in one process.
"""

from __future__ import annotations

import asyncio
import json
import os
import signal
import sys
import time

from pycrdt import Doc, Map

import wm
from benchlib import endpoint, free_port, parser, print_table, read_line, spawn, write_json

GRAPH = "bench"


def raw_pycrdt_rate(count: int) -> float:
    doc = Doc()
    nodes = doc.get("nodes", type=Map)
    nodes["1"] = Map({"pos_x": 0.0})
    node = nodes["1"]
    nodes.observe_deep(lambda events: None)
    start = time.perf_counter()
    for i in range(count):
        node["pos_x"] = float(i)
    return count / (time.perf_counter() - start)


async def writer(index: int, ports: list[int], writes: int, attr: str, per_tick: int) -> None:
    others = [endpoint(p) for i, p in enumerate(ports) if i != index]
    async with wm.connect(GRAPH, name=f"w{index}", listen=[endpoint(ports[index])], connect=others) as g:
        node = g.insert_node("object", f"w{index}")
        print("ready", flush=True)
        await asyncio.to_thread(sys.stdin.readline)  # start together
        start = time.monotonic()
        for first in range(1, writes + 1, per_tick):
            with g.batch():  # one tick's writes share a transaction and leave as one message
                for i in range(first, min(first + per_tick, writes + 1)):
                    g.update_node(node, {attr: float(i)})
            await asyncio.sleep(0)

        def done() -> bool:
            finals = [n.attrs.get(attr) for n in g.nodes("object")]
            return len(finals) == len(ports) and all(v == float(writes) for v in finals)

        while not done():
            await asyncio.sleep(0.001)
        print("result", json.dumps({"start": start, "end": time.monotonic()}), flush=True)
        await asyncio.to_thread(sys.stdin.readline)


def run(writes: int, attr: str, per_tick: int) -> float:
    ports = [free_port() for _ in range(3)]
    children = []
    for i in range(3):
        child = spawn(
            [
                __file__,
                "--role",
                str(i),
                "--ports",
                ",".join(map(str, ports)),
                "--writes",
                str(writes),
                "--attr",
                attr,
                "--per-tick",
                str(per_tick),
            ]
        )
        children.append(child)
    try:
        return _measure(children, writes)
    finally:
        for child in children:
            if child.poll() is None:
                os.kill(child.pid, signal.SIGTERM)
            child.wait(timeout=10)


def _measure(children: list, writes: int) -> float:
    for child in children:
        read_line(child, "ready")
    time.sleep(1.0)
    for child in children:
        child.stdin.write("go\n")
        child.stdin.flush()
    results = [json.loads(read_line(child, "result")) for child in children]
    for child in children:
        child.stdin.write("stop\n")
        child.stdin.flush()
    elapsed = max(r["end"] for r in results) - min(r["start"] for r in results)
    return 3 * writes / elapsed


def main() -> None:
    p = parser("bench_replication_throughput", __doc__.splitlines()[0])
    p.add_argument("--writes", type=int, default=100_000, help="writes per process")
    p.add_argument("--per-tick", type=int, default=500)
    p.add_argument("--role", default="main")
    p.add_argument("--ports", default="")
    p.add_argument("--attr", default="pos_x")
    args = p.parse_args()
    if args.role != "main":
        try:
            asyncio.run(
                writer(int(args.role), [int(x) for x in args.ports.split(",")], args.writes, args.attr, args.per_tick)
            )
        except (KeyboardInterrupt, asyncio.CancelledError):
            pass
        return
    raw = raw_pycrdt_rate(200_000)
    durable = run(args.writes, "pos_x", args.per_tick)
    volatile = run(args.writes, "last_seen", args.per_tick)
    figures = {
        "raw_pycrdt_writes_per_s": round(raw),
        "three_replicas_durable_writes_per_s": round(durable),
        "three_replicas_volatile_writes_per_s": round(volatile),
        "durable_ratio_to_raw_pycrdt": round(durable / raw, 3),
        "volatile_ratio_to_raw_pycrdt": round(volatile / raw, 3),
        "writes_per_process": args.writes,
        "goal_writes_per_s": 100_000,
    }
    print_table("sustained attribute writes, 3 processes converging", [(k, v) for k, v in figures.items()])
    write_json(args.json, figures)


if __name__ == "__main__":
    sys.exit(main())
