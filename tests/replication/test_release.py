"""A replica that leaves the network is freed: nothing of the replication layer keeps its document alive."""

from __future__ import annotations

import asyncio
import gc
import weakref

import wm
from procs import endpoint, free_port


def test_a_replica_is_freed_once_it_has_left_the_network() -> None:
    async def run() -> weakref.ref[wm.Graph]:
        async with wm.connect("release", name="leaver", listen=[endpoint(free_port())]) as g:
            g.insert_node("world", "world")
            await g.network.flush()  # type: ignore[union-attr]
        return weakref.ref(g)

    left = asyncio.run(run())
    gc.collect()
    assert left() is None
