"""``wm serve``: the durable member. Keeps graphs on disk and can be the Zenoh router.

Each served graph is loaded from ``<data>/<graph>/`` before joining the
network, then merged with whatever live peers hold, and every change after
that is appended to disk within ``interval`` seconds (see :mod:`wm.persistence`).
"""

from __future__ import annotations

import asyncio
import logging
from collections.abc import Sequence
from pathlib import Path

from ..graph import Graph
from ..ontology import Ontology
from ..persistence import DiskLog, Persister
from ..reaper import install_reaper
from .connection import close_session, open_session, sigterm_cancels_current_task
from .keys import check_segment
from .replication import DURABLE_AGENT, Replicator
from .zenoh_config import ConfigSource, Mode

log = logging.getLogger("wm.net.serve")


async def serve(
    data_dir: str | Path,
    graphs: Sequence[str],
    *,
    config: ConfigSource | None = None,
    connect: Sequence[str] = (),
    listen: Sequence[str] = (),
    mode: Mode | None = None,
    ontology: Ontology | None = None,
    interval: float = 0.05,
    heartbeat_period: float = 1.0,
    ready: asyncio.Event | None = None,
) -> None:
    """Serve ``graphs`` until cancelled (SIGINT or SIGTERM)."""
    for name in graphs:
        check_segment(name, "graph name")
    if mode is None:
        mode = "router" if listen and config is None else None
    session = await open_session(config, connect=list(connect) or None, listen=list(listen) or None, mode=mode)
    replicators: list[Replicator] = []
    persisters: list[asyncio.Task[None]] = []
    try:
        with sigterm_cancels_current_task():
            for name in graphs:
                graph = Graph(ontology)
                disk = DiskLog(Path(data_dir) / name)
                replayed = disk.load_into(graph)
                persister = Persister(graph, disk, interval=interval)
                persisters.append(asyncio.ensure_future(persister.run()))
                replicator = Replicator(graph, session, name, DURABLE_AGENT, heartbeat_period=heartbeat_period)
                persister.progress, replicator.on_disk = replicator.received, persister.on_disk
                graph.network = replicator
                await replicator.start()
                install_reaper(graph)  # agent nodes of members that leave, even by kill -9
                replicators.append(replicator)
                log.info(
                    "serving graph %r: %d nodes from %s (%d log records), replica %s",
                    name,
                    graph.node_count(),
                    disk.directory,
                    replayed,
                    graph.replica_id,
                )
            print(
                f"wm serve: ready, graphs {', '.join(graphs)}, listening on {', '.join(listen) or 'config endpoints'}",
                flush=True,
            )
            if ready is not None:
                ready.set()
            await asyncio.Event().wait()
    finally:
        for replicator in replicators:
            await replicator.stop()
        for task in persisters:
            task.cancel()
        await asyncio.gather(*persisters, return_exceptions=True)
        await close_session(session)
