"""Memory of volatile attributes: 50 attributes written at 30 Hz for a simulated hour (5.4M writes).

The graph keeps volatile attributes in last-writer-wins registers
(:mod:`wm.volatile`), so memory and state size follow the number of live
attributes, not the number of writes. The run writes, without sleeping, what
10 RT edges (translation, rotation, timestamp) and 10 tracked people
(velocity, last_seen) produce in an hour at 30 Hz, draining the outbox every
tick as replication does. It reports RSS growth and ``len(encode_state())``
against the live data (the same final graph written once).

The baseline writes the same 50 values as plain pycrdt Map overwrites for a
smaller count and extrapolates linearly to 5.4M writes, to show why they
cannot be plain overwrites. Goals: RSS growth <= 20 MB, state <= 2x live data.

    python bench/bench_volatile_memory.py [--json PATH] [--seconds-simulated S] [--baseline-writes N]
"""

from __future__ import annotations

import gc
import time

import psutil
from pycrdt import Doc, Map

import benchlib
import wm

HZ = 30
EDGES = 10  # 3 volatile attributes each
PEOPLE = 10  # 2 volatile attributes each
ATTRIBUTES = EDGES * 3 + PEOPLE * 2
RSS_GOAL_MB = 20.0
STATE_GOAL_RATIO = 2.0


def rss_mb() -> float:
    gc.collect()
    return psutil.Process().memory_info().rss / 2**20


def build_scene() -> tuple[wm.Graph, int, list[int], list[int]]:
    g = wm.Graph()
    world = g.insert_node("world", "world")
    objects = [g.insert_node("object", f"obj{k}", {"kind": "ball"}) for k in range(EDGES)]
    people = [g.insert_node("person", f"person{k}", {"radius": 0.3}) for k in range(PEOPLE)]
    for k, node in enumerate(objects):
        g.rt.set_pose2d(world, node, k, 0.0, 0.0)
    return g, world, objects, people


def run_graph(ticks: int) -> dict[str, float]:
    g, world, objects, people = build_scene()
    g.take_volatile_outbox()
    rss_before = rss_mb()
    start = time.perf_counter()
    for tick in range(ticks):
        t = tick / HZ
        for k, node in enumerate(objects):
            pose = {"rt_translation": (k + 0.001 * tick, 0.5, 0.0), "rt_rotation_euler_xyz": (0.0, 0.0, 0.01 * tick)}
            g.insert_or_assign_edge(world, node, "RT", {**pose, "rt_timestamp": t})
        for k, node in enumerate(people):
            g.update_node(node, {"velocity": (0.5, 0.001 * k), "last_seen": t})
        g.take_volatile_outbox()
    elapsed = time.perf_counter() - start
    rss_after = rss_mb()
    state = len(g.encode_state())
    live = wm.Graph()
    live.load_json(g.to_dict())
    live_size = len(live.encode_state())
    writes = ticks * ATTRIBUTES
    return {
        "writes": writes,
        "seconds": elapsed,
        "writes_per_s": writes / elapsed,
        "rss_growth_mb": rss_after - rss_before,
        "state_bytes": state,
        "live_state_bytes": live_size,
        "state_over_live": state / live_size,
    }


def run_baseline(writes: int, target_writes: int) -> dict[str, float]:
    """The same 50 values as overwrites of keys in nested pycrdt Maps, in interleaved order."""
    doc = Doc()
    root = doc.get("nodes", type=Map)
    for k in range(ATTRIBUTES // 5):
        root[str(k)] = Map()
    owners = [root[str(k)] for k in range(ATTRIBUTES // 5)]
    keys = [f"a{j}" for j in range(5)]
    rss_before = rss_mb()
    start = time.perf_counter()
    for i in range(writes // ATTRIBUTES):
        for owner in owners:
            for key in keys:
                owner[key] = float(i)
    elapsed = time.perf_counter() - start
    rss_after = rss_mb()
    state = len(doc.get_update())
    live = Doc()
    live_root = live.get("nodes", type=Map)
    for k, owner in enumerate(owners):
        live_root[str(k)] = Map(owner.to_py())
    live_size = len(live.get_update())
    scale = target_writes / writes
    return {
        "writes": writes,
        "seconds": elapsed,
        "rss_growth_mb": rss_after - rss_before,
        "state_bytes": state,
        "live_state_bytes": live_size,
        "state_over_live": state / live_size,
        "extrapolated_writes": target_writes,
        "extrapolated_rss_growth_mb": (rss_after - rss_before) * scale,
        "extrapolated_state_bytes": state * scale,
    }


def main() -> None:
    parser = benchlib.parser("bench_volatile_memory", __doc__.split("\n")[0])
    parser.add_argument(
        "--seconds-simulated", type=float, default=3600.0, help="simulated time at 30 Hz (default 3600)"
    )
    parser.add_argument(
        "--baseline-writes", type=int, default=500_000, help="plain Map overwrites to measure (default 500000)"
    )
    args = parser.parse_args()
    ticks = int(args.seconds_simulated * HZ)
    graph = run_graph(ticks)
    baseline = run_baseline(args.baseline_writes, graph["writes"])
    graph["meets_goals"] = graph["rss_growth_mb"] <= RSS_GOAL_MB and graph["state_over_live"] <= STATE_GOAL_RATIO
    print(f"{'':34} {'writes':>11} {'RSS growth MB':>14} {'state B':>12} {'live B':>9} {'state/live':>11}")
    print(
        f"{'wm.Graph volatile registers':34} {graph['writes']:11,} {graph['rss_growth_mb']:14.1f} "
        f"{graph['state_bytes']:12,} {graph['live_state_bytes']:9,} {graph['state_over_live']:11.2f}"
    )
    print(
        f"{'plain pycrdt Map overwrites':34} {baseline['writes']:11,} {baseline['rss_growth_mb']:14.1f} "
        f"{baseline['state_bytes']:12,} {baseline['live_state_bytes']:9,} {baseline['state_over_live']:11.2f}"
    )
    print(
        f"{'  extrapolated to ' + format(graph['writes'], ','):34} {baseline['extrapolated_writes']:11,} "
        f"{baseline['extrapolated_rss_growth_mb']:14.1f} {baseline['extrapolated_state_bytes']:12,.0f}"
    )
    print(
        f"goals: RSS growth <= {RSS_GOAL_MB} MB, state <= {STATE_GOAL_RATIO}x live: {'met' if graph['meets_goals'] else 'NOT met'}"
    )
    benchlib.write_json(args.json, {"benchmark": "volatile_memory", "graph": graph, "baseline_plain_map": baseline})


if __name__ == "__main__":
    main()
