"""``wm replay FILE [--speed X] [--as GRAPH]``: republish a recording into a live graph.

The replaying replica joins ``GRAPH`` as a writer and applies the recorded
``/wm/updates`` at their recorded pace (divided by ``speed``). CRDT updates go
out as they were made; volatile values are written anew by the replaying
replica (their old clocks would lose against a live graph's). Viewers,
monitors and agents on ``GRAPH`` then watch the past run as if it were live.
"""

from __future__ import annotations

import asyncio
from collections.abc import Sequence
from pathlib import Path

from ..errors import NotFoundError
from ..graph import Graph
from ..model import parse_edge_key
from ..net.connection import connect
from ..net.zenoh_config import ConfigSource
from ..ontology import Ontology
from ..volatile import Record
from .recording_file import iter_updates


def write_volatile(g: Graph, records: list[Record]) -> None:
    """Write recorded volatile values as local writes (elements that no longer exist are skipped)."""
    for owner, attr, value, _clock, _writer in records:
        kind, ident = owner.split(":", 1)
        try:
            if kind == "n":
                if value is None:
                    g.delete_attr(int(ident), attr)
                else:
                    g.update_node(int(ident), {attr: value})
            else:
                src, dst, edge_type = parse_edge_key(ident)
                if value is None:
                    g.delete_edge_attr(src, dst, edge_type, attr)
                elif g.find_edge(src, dst, edge_type) is not None:
                    g.insert_or_assign_edge(src, dst, edge_type, {attr: value})
        except NotFoundError:
            continue


async def replay(
    path: str | Path,
    graph_name: str,
    *,
    speed: float = 1.0,
    config: ConfigSource | None = None,
    connect_to: Sequence[str] = (),
    ontology: Ontology | None = None,
    confirm_timeout: float = 5.0,
) -> int:
    """Republish the recording at ``path`` into ``graph_name``; returns the number of updates applied."""
    if speed <= 0:
        raise ValueError(f"--speed must be positive, got {speed}")
    count = 0
    async with connect(graph_name, config, "wm-replay", connect=list(connect_to) or None, ontology=ontology) as g:
        assert g.network is not None
        loop = asyncio.get_running_loop()
        started, first = loop.time(), None
        for t_ns, update, records in iter_updates(path):
            first = t_ns if first is None else first
            delay = started + (t_ns - first) / 1e9 / speed - loop.time()
            if delay > 0:
                await asyncio.sleep(delay)
            if update:
                g.apply_update(update, g.replica_id)  # our own origin: the replicator publishes it
            write_volatile(g, records)
            await g.network.flush()
            count += 1
        await g.network.confirm(confirm_timeout)
    return count
