"""Memory of a replica receiving 50 volatile attributes written at 30 Hz, across processes.

A writer process holds 15 RT edges (``rt_translation``, ``rt_rotation_euler_xyz``)
and 10 people (``velocity``, ``last_seen``): 50 volatile attributes. It writes
them tick after tick, as fast as it can: one tick is one ``g.batch()`` of 50
writes and leaves as one DELTA, so every write reaches the receiver. The goal
is what 30 Hz produces in an hour (108,000 ticks, 5.4M writes); when the time
budget runs out first, the run stops after at least 1M writes and the JSON
says so (``full_hour: false``).

A receiver process (connected to the writer over loopback) samples its RSS
(psutil, after ``gc.collect()``) and ``len(g.encode_state())`` every few
seconds (RSS growth is given from idle and after a 5 s warm-up: RSS steps
up once in the first second of traffic, in the writer too; the cause is not
pinned down, MALLOC_ARENA_MAX=1 does not change it), and at the end compares the state with the live data (the final graph
written once into a fresh replica). Baseline in the same run: the same 50
values as plain durable pycrdt Map overwrites in one process, for a smaller
count, extrapolated linearly. Goals: receiver RSS growth <= 20 MB, state
<= 2x live data.
"""

from __future__ import annotations

import asyncio
import gc
import json
import os
import signal
import sys
import time

import psutil
from pycrdt import Doc, Map

import wm
from benchlib import (
    endpoint,
    free_port,
    parser,
    print_table,
    read_line,
    spawn,
    write_json,
)

GRAPH = "bench_volatile"
HZ = 30
EDGES = 15  # rt_translation, rt_rotation_euler_xyz
PEOPLE = 10  # velocity, last_seen
ATTRIBUTES = EDGES * 2 + PEOPLE * 2
HOUR_WRITES = 3600 * HZ * ATTRIBUTES
MIN_WRITES = 1_000_000
WARMUP_S = 5.0  # RSS steps up once in the first second of traffic (see the docstring)
RSS_GOAL_MB = 20.0
STATE_GOAL_RATIO = 2.0


def rss_mb() -> float:
    gc.collect()
    return psutil.Process().memory_info().rss / 2**20


async def writer(port: int, seconds: float, target: int) -> None:
    async with wm.connect(GRAPH, name="writer", listen=[endpoint(port)]) as g:
        world = g.insert_node("world", "world")
        objects = [g.insert_node("object", f"obj{k}", {"kind": "ball"}) for k in range(EDGES)]
        people = [g.insert_node("person", f"person{k}", {"radius": 0.3}) for k in range(PEOPLE)]
        for k, node in enumerate(objects):
            g.insert_or_assign_edge(
                world, node, "RT", {"rt_translation": (float(k), 0.0, 0.0), "rt_rotation_euler_xyz": (0.0, 0.0, 0.0)}
            )
        for node in people:
            g.update_node(node, {"velocity": (0.0, 0.0), "last_seen": -1.0})
        print("ready", flush=True)
        await asyncio.to_thread(sys.stdin.readline)  # go
        rss_before = rss_mb()
        start = time.monotonic()
        tick = 0
        while tick * ATTRIBUTES < target and (time.monotonic() - start < seconds or tick * ATTRIBUTES < MIN_WRITES):
            t = tick / HZ
            with g.batch():  # one 30 Hz tick: 50 writes, one DELTA
                for k, node in enumerate(objects):
                    g.insert_or_assign_edge(
                        world,
                        node,
                        "RT",
                        {
                            "rt_translation": (k + 0.001 * tick, 0.5, 0.0),
                            "rt_rotation_euler_xyz": (0.0, 0.0, 0.01 * tick),
                        },
                    )
                for k, node in enumerate(people):
                    g.update_node(node, {"velocity": (0.5, 0.001 * k), "last_seen": t})
            tick += 1
            await asyncio.sleep(0)  # the replicator publishes the tick
        elapsed = time.monotonic() - start
        confirmed = bool(await g.network.confirm(timeout=30.0))  # type: ignore[union-attr]
        result = {
            "ticks": tick,
            "writes": tick * ATTRIBUTES,
            "seconds": elapsed,
            "final_last_seen": (tick - 1) / HZ,
            "confirmed": confirmed,
            "published": g.network.stats.published,  # type: ignore[union-attr]
            "rss_growth_mb": rss_mb() - rss_before,
        }
        print("result", json.dumps(result), flush=True)
        await asyncio.to_thread(sys.stdin.readline)  # stop


async def receiver(port: int, interval: float) -> None:
    async with wm.connect(GRAPH, name="receiver", connect=[endpoint(port)]) as g:
        while len(g.edges("RT")) < EDGES or len(g.nodes("person")) < PEOPLE:
            await asyncio.sleep(0.05)
        print("ready", flush=True)
        await asyncio.to_thread(sys.stdin.readline)  # go
        start = time.monotonic()
        samples: list[dict] = []
        person0 = g.resolve("person0")

        def sample() -> None:
            samples.append(
                {
                    "t_s": round(time.monotonic() - start, 2),
                    "rss_mb": round(rss_mb(), 2),
                    "state_bytes": len(g.encode_state()),
                    "deltas_applied": g.network.stats.applied,  # type: ignore[union-attr]
                    "last_seen": g.get_node(person0).attrs["last_seen"],
                }
            )

        async def sampler() -> None:
            while True:
                sample()
                await asyncio.sleep(interval)

        task = asyncio.ensure_future(sampler())
        final_last_seen = float(await asyncio.to_thread(sys.stdin.readline))  # the writer's last value
        while g.get_node(person0).attrs["last_seen"] != final_last_seen:
            await asyncio.sleep(0.05)
        task.cancel()
        sample()
        live = wm.Graph()
        live.load_json(g.to_dict())
        result = {
            "samples": samples,
            "live_state_bytes": len(live.encode_state()),
            "gaps": g.network.stats.gaps,  # type: ignore[union-attr]
            "repairs": g.network.stats.repairs,
        }  # type: ignore[union-attr]
        print("result", json.dumps(result), flush=True)
        await asyncio.to_thread(sys.stdin.readline)  # stop


def baseline(writes: int, extrapolate_to: list[int]) -> dict:
    """The same 50 values as durable overwrites of keys in nested pycrdt Maps, in one process."""
    doc = Doc()
    root = doc.get("nodes", type=Map)
    for k in range(EDGES + PEOPLE):
        root[str(k)] = Map()
    edges = [root[str(k)] for k in range(EDGES)]
    people = [root[str(EDGES + k)] for k in range(PEOPLE)]
    before = rss_mb()
    start = time.perf_counter()
    for tick in range(writes // ATTRIBUTES):
        with doc.transaction():
            for k, owner in enumerate(edges):
                owner["rt_translation"] = [k + 0.001 * tick, 0.5, 0.0]
                owner["rt_rotation_euler_xyz"] = [0.0, 0.0, 0.01 * tick]
            for k, owner in enumerate(people):
                owner["velocity"] = [0.5, 0.001 * k]
                owner["last_seen"] = tick / HZ
    elapsed = time.perf_counter() - start
    growth = rss_mb() - before
    state = len(doc.get_update())
    live = Doc()
    live_root = live.get("nodes", type=Map)
    for k in range(EDGES + PEOPLE):
        live_root[str(k)] = Map(root[str(k)].to_py())
    live_size = len(live.get_update())
    return {
        "writes": writes,
        "seconds": round(elapsed, 2),
        "rss_growth_mb": round(growth, 2),
        "state_bytes": state,
        "live_state_bytes": live_size,
        "state_over_live": round(state / live_size, 1),
        "extrapolated": [
            {"writes": n, "rss_growth_mb": round(growth * n / writes, 1), "state_bytes": round(state * n / writes)}
            for n in extrapolate_to
        ],
    }


def run(seconds: float, target: int, interval: float) -> tuple[dict, dict]:
    port = free_port()
    children = [
        spawn([__file__, "--role", "writer", "--port", str(port), "--seconds", str(seconds), "--target", str(target)])
    ]
    try:
        read_line(children[0], "ready")
        children.append(spawn([__file__, "--role", "receiver", "--port", str(port), "--interval", str(interval)]))
        read_line(children[1], "ready")
        for child in children:
            child.stdin.write("go\n")
            child.stdin.flush()
        written = json.loads(read_line(children[0], "result"))
        children[1].stdin.write(f"{written['final_last_seen']!r}\n")
        children[1].stdin.flush()
        received = json.loads(read_line(children[1], "result"))
        for child in children:
            child.stdin.write("stop\n")
            child.stdin.flush()
        for child in children:
            child.wait(timeout=20)
    finally:
        for child in children:
            if child.poll() is None:
                os.kill(child.pid, signal.SIGTERM)
                child.wait(timeout=10)
    return written, received


def main() -> None:
    p = parser("bench_volatile_memory_processes", __doc__.splitlines()[0])
    p.add_argument("--seconds", type=float, default=100.0, help="writing time budget (at least 1M writes are made)")
    p.add_argument("--target", type=int, default=HOUR_WRITES, help="writes wanted (default: an hour at 30 Hz)")
    p.add_argument("--interval", type=float, default=3.0, help="seconds between receiver samples")
    p.add_argument("--baseline-writes", type=int, default=150_000)
    p.add_argument("--role", choices=["main", "writer", "receiver"], default="main")
    p.add_argument("--port", type=int, default=0)
    args = p.parse_args()
    if args.role != "main":
        try:
            if args.role == "writer":
                asyncio.run(writer(args.port, args.seconds, args.target))
            else:
                asyncio.run(receiver(args.port, args.interval))
        except (KeyboardInterrupt, asyncio.CancelledError):
            pass
        return
    written, received = run(args.seconds, args.target, args.interval)
    base = baseline(args.baseline_writes, [written["writes"], HOUR_WRITES])
    samples = received["samples"]
    first, last = samples[0], samples[-1]
    rss_growth = last["rss_mb"] - first["rss_mb"]
    peak_growth = max(s["rss_mb"] for s in samples) - first["rss_mb"]
    warm = next((s for s in samples if s["t_s"] >= WARMUP_S), first)
    steady_growth = last["rss_mb"] - warm["rss_mb"]
    state_ratio = last["state_bytes"] / received["live_state_bytes"]
    writes = written["writes"]
    figures = {
        "attributes": ATTRIBUTES,
        "writes": writes,
        "ticks": written["ticks"],
        "full_hour": writes >= HOUR_WRITES,
        "simulated_seconds_at_30hz": round(written["ticks"] / HZ),
        "note": None
        if writes >= HOUR_WRITES
        else f"time budget: {writes:,} of {HOUR_WRITES:,} writes ({writes / HOUR_WRITES:.0%} of an hour)",
        "write_seconds": round(written["seconds"], 1),
        "writes_per_s": round(writes / written["seconds"]),
        "writer_confirmed": written["confirmed"],
        "deltas_published": written["published"],
        "receiver_deltas_applied": last["deltas_applied"],
        "receiver_gaps": received["gaps"],
        "receiver_rss_start_mb": first["rss_mb"],
        "receiver_rss_end_mb": last["rss_mb"],
        "receiver_rss_growth_mb": round(rss_growth, 2),
        "receiver_rss_peak_growth_mb": round(peak_growth, 2),
        "receiver_rss_growth_after_warmup_mb": round(steady_growth, 2),
        "warmup_sample_t_s": warm["t_s"],
        "writer_rss_growth_mb": round(written["rss_growth_mb"], 2),
        "receiver_state_bytes_start": first["state_bytes"],
        "receiver_state_bytes_end": last["state_bytes"],
        "live_state_bytes": received["live_state_bytes"],
        "state_over_live": round(state_ratio, 3),
        "receiver_samples": samples,
        "baseline_plain_pycrdt_overwrites": base,
        "goals": {"rss_growth_mb": RSS_GOAL_MB, "state_over_live": STATE_GOAL_RATIO},
        "meets_goals_from_idle": rss_growth <= RSS_GOAL_MB
        and peak_growth <= RSS_GOAL_MB
        and state_ratio <= STATE_GOAL_RATIO,
        "meets_goals_after_warmup": steady_growth <= RSS_GOAL_MB and state_ratio <= STATE_GOAL_RATIO,
    }
    print("receiver samples:  t(s)   RSS MB   state B   deltas applied")
    for s in samples:
        print(f"  {s['t_s']:8.1f} {s['rss_mb']:8.1f} {s['state_bytes']:9,} {s['deltas_applied']:12,}")
    ext = {e["writes"]: e for e in base["extrapolated"]}
    print_table(
        f"50 volatile attributes across processes, {writes:,} writes ({figures['simulated_seconds_at_30hz']:,} s at 30 Hz)",
        [
            ("write rate", f"{figures['writes_per_s']:,}/s over {figures['write_seconds']} s"),
            (
                "deltas published / applied by receiver",
                f"{written['published']:,} / {last['deltas_applied']:,}  (gaps {received['gaps']})",
            ),
            ("receiver RSS growth from idle (end, peak)", f"{rss_growth:.1f} MB, {peak_growth:.1f} MB"),
            (f"receiver RSS growth after {warm['t_s']:.0f} s warm-up", f"{steady_growth:.1f} MB"),
            ("writer RSS growth", f"{written['rss_growth_mb']:.1f} MB"),
            (
                "receiver state / live data",
                f"{last['state_bytes']:,} / {received['live_state_bytes']:,} B = {state_ratio:.2f}x",
            ),
            (
                f"plain pycrdt overwrites, {base['writes']:,} writes",
                f"RSS +{base['rss_growth_mb']} MB, state {base['state_bytes']:,} B ({base['state_over_live']}x live)",
            ),
            (
                f"  extrapolated to {writes:,}",
                f"RSS +{ext[writes]['rss_growth_mb']} MB, state {ext[writes]['state_bytes']:,} B",
            ),
            (
                f"  extrapolated to {HOUR_WRITES:,}",
                f"RSS +{ext[HOUR_WRITES]['rss_growth_mb']} MB, state {ext[HOUR_WRITES]['state_bytes']:,} B",
            ),
            (
                "goals",
                f"RSS growth <= {RSS_GOAL_MB} MB, state <= {STATE_GOAL_RATIO}x live: "
                f"from idle {'met' if figures['meets_goals_from_idle'] else 'NOT met'}, "
                f"after warm-up {'met' if figures['meets_goals_after_warmup'] else 'NOT met'}"
                + ("" if figures["full_hour"] else " (not a full hour of writes)"),
            ),
        ],
    )
    write_json(args.json, figures)


if __name__ == "__main__":
    sys.exit(main())
