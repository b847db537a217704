"""``wm view [--port P]``: a live browser view of a graph, served locally.

One port serves the page (``/``, a self-contained HTML/JS/SVG file shipped
with the package) and a websocket (``/ws``). The viewer is a read-only replica:
every change of the graph marks it dirty, and at most every ``min_interval``
seconds the whole state (graph, 2D scene from :mod:`wm.monitoring.scene2d`, members) goes
to every open page as one JSON message; a page that connects gets it at once.
"""

from __future__ import annotations

import asyncio
import json
from collections.abc import Sequence
from http import HTTPStatus
from importlib import resources
from typing import Any

from websockets.asyncio.server import Server, ServerConnection, serve
from websockets.datastructures import Headers
from websockets.exceptions import ConnectionClosed
from websockets.http11 import Request, Response

from ..graph import Graph
from ..net.connection import connect
from ..net.zenoh_config import ConfigSource
from ..ontology import Ontology
from . import scene2d

PAGE = resources.files("wm.monitoring").joinpath("view_page.html").read_bytes()


class ViewServer:
    """Pushes the state of one graph to every connected page."""

    def __init__(self, graph: Graph, name: str, *, min_interval: float = 0.1) -> None:
        self.graph = graph
        self.name = name
        self.min_interval = min_interval
        self.version = 0
        self._clients: set[ServerConnection] = set()
        self._dirty = asyncio.Event()
        self._dirty.set()
        graph.on(lambda _event: self._dirty.set())

    def state(self) -> str:
        """The message a page renders: name, version, graph, scene and members, as JSON."""
        message: dict[str, Any] = {
            "name": self.name,
            "version": self.version,
            "graph": self.graph.to_dict(),
            "scene": scene2d.build(self.graph),
            "members": self.graph.members(),
        }
        return json.dumps(message)

    def process_request(self, connection: ServerConnection, request: Request) -> Response | None:
        """Serve the page on ``/``; let ``/ws`` through to the websocket handshake."""
        if request.path == "/ws":
            return None
        if request.path in ("/", "/index.html"):
            headers = Headers(
                {
                    "Content-Type": "text/html; charset=utf-8",
                    "Content-Length": str(len(PAGE)),
                    "Cache-Control": "no-store",
                }
            )
            return Response(HTTPStatus.OK, "OK", headers, PAGE)
        return connection.respond(HTTPStatus.NOT_FOUND, "not found\n")

    async def handler(self, websocket: ServerConnection) -> None:
        """Send the current state, then keep the page until it goes away."""
        self._clients.add(websocket)
        try:
            await websocket.send(self.state())
            await websocket.wait_closed()
        finally:
            self._clients.discard(websocket)

    async def push_changes(self) -> None:
        """Broadcast the state whenever the graph changed, at most every ``min_interval`` s."""
        while True:
            await self._dirty.wait()
            self._dirty.clear()
            self.version += 1
            if self._clients:
                message = self.state()
                for websocket in list(self._clients):
                    try:
                        await websocket.send(message)
                    except ConnectionClosed:
                        self._clients.discard(websocket)
            await asyncio.sleep(self.min_interval)

    async def start(self, host: str, port: int) -> Server:
        return await serve(self.handler, host, port, process_request=self.process_request)


async def view(
    graph_name: str,
    *,
    host: str = "127.0.0.1",
    port: int = 8765,
    config: ConfigSource | None = None,
    connect_to: Sequence[str] = (),
    ontology: Ontology | None = None,
) -> None:
    """Serve the live view of ``graph_name`` until cancelled."""
    async with connect(
        graph_name, config, "wm-view", connect=list(connect_to) or None, ontology=ontology, read_only=True
    ) as g:
        viewer = ViewServer(g, graph_name)
        server = await viewer.start(host, port)
        bound = server.sockets[0].getsockname()[1]
        print(f"wm view: serving graph {graph_name!r} on http://{host}:{bound}/", flush=True)
        try:
            await viewer.push_changes()
        finally:
            server.close()
            await server.wait_closed()
