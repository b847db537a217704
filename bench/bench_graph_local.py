"""Local write and read rates of wm.Graph, as a ratio to raw pycrdt map writes measured in the same run.

The baseline sets one float in a nested pycrdt Map with a deep observer
attached (what the graph's durable tier does underneath, minus validation,
indexing and events). Each case is timed ``--repeat`` times, alternating with
the baseline, and each figure is the best of its runs: on a shared machine,
the ratio of two bests taken side by side holds better than either rate.

    python bench/bench_graph_local.py [--json PATH] [--seconds S] [--repeat N]
"""

from __future__ import annotations

import time
from collections.abc import Callable

from pycrdt import Doc, Map

import benchlib
import wm


def calibrate(step: Callable[[int], object], seconds: float) -> int:
    """How many calls of ``step`` take about ``seconds``."""
    count = 1000
    start = time.perf_counter()
    for i in range(count):
        step(i)
    elapsed = time.perf_counter() - start
    return max(1000, int(count * seconds / max(elapsed, 1e-6)))


def rates(steps: list[Callable[[int], object]], seconds: float, repeat: int) -> list[float]:
    """Best operations per second of each ``step(i)`` over ``repeat`` rounds, the steps alternating in each round."""
    counts = [calibrate(step, seconds) for step in steps]
    best = [0.0] * len(steps)
    for _ in range(repeat):
        for k, (step, count) in enumerate(zip(steps, counts, strict=False)):
            start = time.perf_counter()
            for i in range(count):
                step(i)
            best[k] = max(best[k], count / (time.perf_counter() - start))
    return best


def raw_pycrdt_writer() -> Callable[[int], object]:
    """A float written into a nested Map of a document with a deep observer."""
    doc = Doc()
    root = doc.get("nodes", type=Map)
    root["1"] = Map({"@type": "person", "@name": "ann"})
    node = root["1"]
    seen = []
    root.observe_deep(lambda events: seen.append(len(events)))

    def step(i: int) -> None:
        node["radius"] = float(i)

    return step


def graph_fixture() -> tuple[wm.Graph, int]:
    """A small scene: a world, a person with a few attributes, and 10 objects it has edges to."""
    g = wm.Graph()
    world = g.insert_node("world", "world")
    ann = g.insert_node("person", "ann", {"radius": 0.3, "speed": 1.0, "track_id": 3, "velocity": (0.0, 0.0)})
    g.rt.set_pose2d(world, ann, 1.0, 2.0, 0.0)
    for k in range(10):
        obj = g.insert_node("object", f"obj{k}", {"kind": "ball", "size": (0.2, 0.2, 0.2)})
        g.rt.set_pose2d(world, obj, k, 0.0, 0.0)
        g.insert_or_assign_edge(ann, obj, "has_intention", {"risky": False, "stamp": 0.0})
    return g, ann


def measure(seconds: float, repeat: int) -> dict[str, dict[str, float]]:
    raw_step = raw_pycrdt_writer()
    g, ann = graph_fixture()
    g.on(lambda event: None)  # a consumer, as in a real agent
    world = g.get_node("world").id
    cases: dict[str, Callable[[int], object]] = {
        "durable attribute write (update_node)": lambda i: g.update_node(ann, {"radius": float(i)}),
        "volatile attribute write (update_node)": lambda i: g.update_node(ann, {"last_seen": float(i)}),
        "RT pose write (rt.set_pose2d, volatile)": lambda i: g.rt.set_pose2d(world, ann, float(i), 0.0, 0.1),
        "get_node": lambda i: g.get_node(ann),
        "edges(src=...) (11 edges)": lambda i: g.edges(src=ann),
    }
    results = {"raw pycrdt nested-map float write": {"ops_per_s": 0.0, "ratio_to_raw": 1.0}}
    for label, step in cases.items():
        raw, ops = rates([raw_step, step], seconds, repeat)
        results[label] = {"ops_per_s": ops, "raw_ops_per_s": raw, "ratio_to_raw": ops / raw}
        results["raw pycrdt nested-map float write"]["ops_per_s"] = max(
            raw, results["raw pycrdt nested-map float write"]["ops_per_s"]
        )
    return results


def main() -> None:
    parser = benchlib.parser("bench_graph_local", __doc__.split("\n")[0])
    parser.add_argument("--seconds", type=float, default=0.5, help="length of one timed run (default 0.5)")
    parser.add_argument(
        "--repeat",
        type=int,
        default=5,
        help="timed runs per case and of the baseline beside it; the best counts (default 5)",
    )
    args = parser.parse_args()
    results = measure(args.seconds, args.repeat)
    print(f"{'operation':42} {'ops/s':>12} {'raw beside it':>14} {'ratio to raw':>13}")
    for label, row in results.items():
        print(
            f"{label:42} {row['ops_per_s']:12,.0f} {row.get('raw_ops_per_s', row['ops_per_s']):14,.0f} {row['ratio_to_raw']:13.3f}"
        )
    benchlib.write_json(args.json, {"benchmark": "graph_local", "results": results})


if __name__ == "__main__":
    main()
