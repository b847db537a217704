"""Late joiner catch-up: 10k nodes x 10 durable attributes, A to a new process B, against raw pycrdt.

Process A (this one) builds the graph in batches and listens on loopback. A
late joiner B, a second process, connects and catches up; B reports:

* ``wm.connect`` entry time: session open, membership query and the sync;
* the sync exchange alone: ``sync_from(A)`` into a fresh, empty replica
  (SYNC_REQUEST, A's ``answer_sync``, SYNC_REPLY back, decode and apply with
  the index and events), repeated, split into the Zenoh query round trip and
  the decode + apply;
* sizes: the SYNC_REPLY message and ``len(encode_state())``.

Baseline in the same run (in B, on the same state): ``Doc.get_update()`` and
``apply_update`` into a fresh ``Doc``, the raw pycrdt cost of moving the state.
Each raw ``Doc`` is freed after its apply, and the previous replicas are
collected before each exchange, so both run on memory the process already
has; the first catch-up of a new process also pays for fresh pages (about
25 ms for 10k nodes here), raw pycrdt as much.
B's graph is checked against A's (node count and a checksum of every node).
Goal: catch-up <= 150 ms.
"""

from __future__ import annotations

import asyncio
import gc
import hashlib
import json
import os
import signal
import sys
import time

from pycrdt import Doc

import wm
from benchlib import (
    endpoint,
    free_port,
    parser,
    percentiles,
    print_table,
    read_line,
    spawn,
    write_json,
)
from wm.net import keys
from wm.net import sync_protocol as proto
from wm.net.replication import Replicator

GRAPH = "bench_catchup"
GOAL_MS = 150.0


def attrs_of(i: int) -> dict:
    """Ten durable attributes of an ``object`` node."""
    return {
        "kind": "ball" if i % 2 else "chair",
        "shape": "circle",
        "size": (0.1 * (i % 7), 0.2, 0.3),
        "is_obstacle": bool(i % 3),
        "is_target": False,
        "track_id": i,
        "level": 2,
        "parent": 1,
        "pos_x": float(i),
        "pos_y": -float(i),
    }


def checksum(g: wm.Graph) -> str:
    h = hashlib.sha256()
    for node in g.nodes():
        h.update(json.dumps([node.id, node.type, node.name, sorted(node.attrs.items())], default=repr).encode())
    return h.hexdigest()[:16]


async def joiner(port: int, a_replica: str, repeats: int) -> None:
    start = time.perf_counter()
    async with wm.connect(GRAPH, name="late_joiner", connect=[endpoint(port)]) as g:
        connect_ms = (time.perf_counter() - start) * 1e3
        net = g.network
        assert net is not None
        figures: dict = {
            "connect_entry_ms": connect_ms,
            "caught_up_from": net.stats.caught_up_from,
            "nodes": g.node_count(),
            "checksum": checksum(g),
        }
        request = proto.encode(proto.SyncRequest("probe", wm.Graph().state_vector()))
        sync_ms, query_ms, apply_ms = [], [], []
        reply_bytes = 0
        for _ in range(repeats):
            # the previous replicas freed first, as the raw baseline's Doc is after each apply:
            # every figure then runs on memory the process already has
            fresh = target = None
            gc.collect()
            # sync_from on a fresh, empty replica sharing B's session (not started: no subscriptions)
            fresh = Replicator(wm.Graph(), net.session, GRAPH, "probe")
            t0 = time.perf_counter()
            ok = await fresh.sync_from(a_replica)
            sync_ms.append((time.perf_counter() - t0) * 1e3)
            assert ok and fresh.graph.node_count() == g.node_count()
            # the same exchange in two parts: query round trip, then decode + apply
            t0 = time.perf_counter()
            replies = await net._query(keys.sync(GRAPH, a_replica), request)
            t1 = time.perf_counter()
            target = wm.Graph()
            proto.apply_delta(target, proto.decode(replies[0][1]))
            t2 = time.perf_counter()
            query_ms.append((t1 - t0) * 1e3)
            apply_ms.append((t2 - t1) * 1e3)
            reply_bytes = len(replies[0][1])
        state = g.encode_state()
        # raw pycrdt baseline on the same state, in this process
        source = g._store.doc
        raw_get, raw_apply = [], []
        for _ in range(repeats):
            t0 = time.perf_counter()
            update = source.get_update()
            t1 = time.perf_counter()
            Doc().apply_update(update)
            t2 = time.perf_counter()
            raw_get.append((t1 - t0) * 1e3)
            raw_apply.append((t2 - t1) * 1e3)
        figures.update(
            sync_ms=sync_ms,
            query_ms=query_ms,
            apply_ms=apply_ms,
            raw_get_ms=raw_get,
            raw_apply_ms=raw_apply,
            sync_reply_bytes=reply_bytes,
            encode_state_bytes=len(state),
            crdt_update_bytes=len(update),
        )
        print("result", json.dumps(figures), flush=True)
        await asyncio.to_thread(sys.stdin.readline)


async def builder(nodes: int, chunk: int, repeats: int) -> dict:
    port = free_port()
    async with wm.connect(GRAPH, name="builder", listen=[endpoint(port)]) as g:
        t0 = time.perf_counter()
        for first in range(0, nodes, chunk):
            with g.batch():
                for i in range(first, min(first + chunk, nodes)):
                    g.insert_node("object", f"obj{i}", attrs_of(i))
            await asyncio.sleep(0)  # the replicator publishes the chunk
        build_s = time.perf_counter() - t0
        t0 = time.perf_counter()
        answer = proto.answer_sync(g, proto.SyncRequest("probe", wm.Graph().state_vector()), 0)
        encoded = proto.encode(answer)
        answer_ms = (time.perf_counter() - t0) * 1e3
        expected = {"nodes": g.node_count(), "checksum": checksum(g), "reply_bytes": len(encoded)}
        child = spawn(
            [__file__, "--role", "joiner", "--port", str(port), "--replica", g.replica_id, "--repeats", str(repeats)]
        )
        try:
            result = json.loads(await asyncio.to_thread(read_line, child, "result"))
            child.stdin.write("stop\n")
            child.stdin.flush()
            child.wait(timeout=20)
        finally:
            if child.poll() is None:
                os.kill(child.pid, signal.SIGTERM)
                child.wait(timeout=10)
    return {"build_s": build_s, "answer_sync_in_a_ms": answer_ms, "a": expected, "b": result}


def main() -> None:
    p = parser("bench_catchup", __doc__.splitlines()[0])
    p.add_argument("--nodes", type=int, default=10_000)
    p.add_argument("--chunk", type=int, default=1000, help="nodes per batch while building")
    p.add_argument("--repeats", type=int, default=7, help="sync exchanges and raw baselines measured")
    p.add_argument("--role", choices=["builder", "joiner"], default="builder")
    p.add_argument("--port", type=int, default=0)
    p.add_argument("--replica", default="")
    args = p.parse_args()
    if args.role == "joiner":
        try:
            asyncio.run(joiner(args.port, args.replica, args.repeats))
        except (KeyboardInterrupt, asyncio.CancelledError):
            pass
        return
    run = asyncio.run(builder(args.nodes, args.chunk, args.repeats))
    a, b = run["a"], run["b"]
    sync, query, apply_ = percentiles(b["sync_ms"]), percentiles(b["query_ms"]), percentiles(b["apply_ms"])
    raw_get, raw_apply = percentiles(b["raw_get_ms"]), percentiles(b["raw_apply_ms"])
    raw_total = raw_get["p50_ms"] + raw_apply["p50_ms"]
    equal = a["nodes"] == b["nodes"] and a["checksum"] == b["checksum"]
    figures = {
        "nodes": args.nodes,
        "attributes_per_node": 10,
        "build_s": round(run["build_s"], 2),
        "connect_entry_ms": round(b["connect_entry_ms"], 1),
        "sync_exchange_fresh_replica": sync,
        "sync_query_round_trip": query,
        "sync_decode_and_apply": apply_,
        "answer_sync_in_a_ms": round(run["answer_sync_in_a_ms"], 1),
        "raw_pycrdt_get_update": raw_get,
        "raw_pycrdt_apply_update": raw_apply,
        "raw_pycrdt_total_p50_ms": round(raw_total, 2),
        "sync_p50_over_raw_p50": round(sync["p50_ms"] / raw_total, 2),
        "sync_reply_bytes": b["sync_reply_bytes"],
        "encode_state_bytes": b["encode_state_bytes"],
        "crdt_update_bytes": b["crdt_update_bytes"],
        "b_equals_a": equal,
        "a_nodes": a["nodes"],
        "b_nodes": b["nodes"],
        "a_checksum": a["checksum"],
        "b_checksum": b["checksum"],
        "caught_up_from": b["caught_up_from"],
        "goal_ms": GOAL_MS,
        "meets_goal_sync_p50": sync["p50_ms"] <= GOAL_MS,
    }
    print_table(
        f"late joiner catch-up, {args.nodes} nodes x 10 attributes (B measures)",
        [
            ("wm.connect entry (open + members + sync)", f"{figures['connect_entry_ms']:.1f} ms"),
            (
                "sync_from(A) into a fresh replica",
                f"p50 {sync['p50_ms']:.1f} ms  max {sync['max_ms']:.1f} ms  (n={sync['n']})",
            ),
            ("  query round trip (incl. A's answer)", f"p50 {query['p50_ms']:.1f} ms"),
            ("  decode + apply (index, events)", f"p50 {apply_['p50_ms']:.1f} ms"),
            ("answer_sync + encode, timed in A", f"{figures['answer_sync_in_a_ms']:.1f} ms"),
            (
                "raw pycrdt get_update + apply_update",
                f"p50 {raw_get['p50_ms']:.1f} + {raw_apply['p50_ms']:.1f} = {raw_total:.1f} ms",
            ),
            ("sync / raw", f"{figures['sync_p50_over_raw_p50']}x"),
            ("SYNC_REPLY bytes", f"{figures['sync_reply_bytes']:,}"),
            ("len(encode_state())", f"{figures['encode_state_bytes']:,}"),
            ("B equals A", f"{equal}  nodes {a['nodes']}/{b['nodes']}  checksum {a['checksum']}/{b['checksum']}"),
            ("goal", f"<= {GOAL_MS:.0f} ms: {'met' if figures['meets_goal_sync_p50'] else 'NOT met'}"),
        ],
    )
    write_json(args.json, figures)


if __name__ == "__main__":
    sys.exit(main())
