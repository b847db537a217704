"""A replica process for the multi-process tests: joins a graph, writes, and dumps its view.

It prints ``ready <replica id>`` once joined and ``wrote`` after its writes,
then rewrites ``--dump FILE`` (graph, members and replication counters as JSON)
every time its graph changes, until it is stopped by SIGTERM.
"""

from __future__ import annotations

import argparse
import asyncio
import dataclasses
import json
import os
from pathlib import Path

import wm


def parse_args() -> argparse.Namespace:
    p = argparse.ArgumentParser(description=__doc__)
    p.add_argument("--graph", default="test")
    p.add_argument("--name", default="replica")
    p.add_argument("--connect", action="append", default=[])
    p.add_argument("--listen", action="append", default=[])
    p.add_argument("--mode", default=None)
    p.add_argument("--prefix", default="n", help="names of the nodes this replica creates")
    p.add_argument("--nodes", type=int, default=0, help="how many nodes to create")
    p.add_argument("--updates", type=int, default=0, help="attribute writes to the shared node 'world'")
    p.add_argument("--volatile", type=int, default=0, help="volatile writes to this replica's first node")
    p.add_argument("--drop", type=int, default=0, help="lose this many of the first outgoing deltas on purpose")
    p.add_argument("--pace", type=float, default=0.0, help="seconds between writes")
    p.add_argument("--dump", type=Path)
    p.add_argument("--heartbeat", type=float, default=0.3)
    return p.parse_args()


def dump(g: wm.Graph, path: Path) -> None:
    assert g.network is not None
    data = {
        "graph": g.to_dict(),
        "members": g.members(),
        "stats": dataclasses.asdict(g.network.stats),
        "replica": g.replica_id,
    }
    tmp = path.with_suffix(f".{os.getpid()}.tmp")
    tmp.write_text(json.dumps(data, sort_keys=True))
    os.replace(tmp, path)


async def write(g: wm.Graph, args: argparse.Namespace) -> None:
    assert g.network is not None
    g.network.drop_outgoing = args.drop
    first = None
    for i in range(args.nodes):
        node = g.insert_node("object", f"{args.prefix}{i}", {"kind": args.name, "track_id": i})
        first = first or node
        if i % 3 == 0 and g.find_node("world"):
            g.insert_or_assign_edge(
                "world", node, "RT", {"rt_translation": [i, 0, 0], "rt_rotation_euler_xyz": [0, 0, 0]}
            )
        await asyncio.sleep(args.pace)
    for i in range(args.updates):
        g.update_node("world", {"description": f"{args.name}-{i}", "pos_x": float(i)})
        await asyncio.sleep(args.pace)
    for i in range(args.volatile):
        if first is not None:
            g.update_node(first, {"last_seen": float(i)})
        await asyncio.sleep(args.pace)


async def main() -> None:
    args = parse_args()
    async with wm.connect(
        args.graph,
        name=args.name,
        connect=args.connect or None,
        listen=args.listen or None,
        mode=args.mode,
        heartbeat_period=args.heartbeat,
    ) as g:
        print("ready", g.replica_id, flush=True)
        changed = asyncio.Event()
        g.on(lambda _event: changed.set())
        await write(g, args)
        print(
            "wrote",
            bool(await g.network.confirm(10.0)) if args.nodes or args.updates or args.volatile else "",
            flush=True,
        )
        while True:
            if args.dump is not None:
                dump(g, args.dump)
            changed.clear()
            try:
                await asyncio.wait_for(changed.wait(), timeout=1.0)
            except TimeoutError:
                pass
            await asyncio.sleep(0.1)


if __name__ == "__main__":
    try:
        asyncio.run(main())
    except (KeyboardInterrupt, asyncio.CancelledError):
        pass
