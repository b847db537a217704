"""``wm foxglove [--port P]``: a live, read-only view of a graph for the Foxglove app.

A read-only replica of the graph (it never publishes into it) feeds the
channels of :class:`wm.monitoring.foxglove.GraphChannels` to a WebSocket
server of ``foxglove-sdk``, which speaks the Foxglove WebSocket protocol:
open ``ws://HOST:PORT`` in the Foxglove app. Every graph event goes out at
once on ``/wm/changes``; the RT tree (``/wm/tf``) and the scene
(``/wm/scene``) go out at most every ``period`` seconds after a change, and
again whenever a client subscribes, so a new client sees the current state.
Given the launcher's log directory, the agents' new log lines go out on
``/wm/log`` every ``period`` seconds.

Clients cannot write. The server advertises no capability that takes input
(client publishing, parameters, services), so the SDK refuses a client's
channels and messages; malformed frames are answered or dropped by the SDK,
and nothing a client sends reaches the replica.
"""

from __future__ import annotations

import asyncio
import time
from collections.abc import Sequence
from pathlib import Path

import foxglove
from foxglove.websocket import ChannelView, Client, ServerListener

from ..events import Event
from ..graph import Graph
from ..net.connection import connect
from ..net.zenoh_config import ConfigSource
from ..ontology import Ontology
from .foxglove import GraphChannels

DEFAULT_PORT = 8765


class _Subscriptions(ServerListener):
    """Asks for the view to be sent again when a client subscribes (called on the SDK's thread)."""

    def __init__(self, loop: asyncio.AbstractEventLoop, resend: asyncio.Event) -> None:
        self._loop = loop
        self._resend = resend

    def on_subscribe(self, client: Client, channel: ChannelView) -> None:
        self._loop.call_soon_threadsafe(self._resend.set)


async def serve_foxglove(
    graph_name: str,
    *,
    host: str = "127.0.0.1",
    port: int = DEFAULT_PORT,
    config: ConfigSource | None = None,
    connect_to: Sequence[str] = (),
    ontology: Ontology | None = None,
    log_dir: str | Path | None = None,
    period: float = 0.1,
) -> None:
    """Serve ``graph_name`` to Foxglove clients on ``ws://host:port`` until cancelled (and the logs in ``log_dir``)."""
    graph = Graph(ontology)
    context = foxglove.Context()
    channels = GraphChannels(context, log_dir)
    changed = asyncio.Event()

    def on_event(event: Event) -> None:
        channels.publish_change(graph, event, time.time_ns())
        changed.set()

    graph.on(on_event)
    server = foxglove.start_server(
        name=f"cortex-wm {graph_name}",
        host=host,
        port=port,
        context=context,
        capabilities=[],
        server_listener=_Subscriptions(asyncio.get_running_loop(), changed),
    )
    try:
        async with connect(
            graph_name, config, "wm-foxglove", connect=list(connect_to) or None, replica=graph, read_only=True
        ):
            print(f"wm foxglove: serving graph {graph_name!r} on ws://{host}:{server.port}", flush=True)
            while True:
                if changed.is_set():
                    changed.clear()
                    channels.publish_view(graph, time.time_ns())
                channels.publish_logs(time.time_ns())
                await asyncio.sleep(period)
    finally:
        server.stop()
