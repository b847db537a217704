"""``DSRGraph``: pydsr's graph object, a cortex-wm replica joined over Zenoh.

The replica lives on an asyncio loop in a thread of its own
(``wm.dsr-replica``); every call of the agent runs there and waits for the
answer, so a pydsr agent stays the synchronous program it was. Signals are
delivered on a third thread (see :mod:`wm.dsr.signals`).

Where to connect is not among pydsr's arguments, so it comes from keywords or
the environment: ``graph`` / ``WM_GRAPH`` (the graph to join, default
``default``), ``connect`` / ``WM_CONNECT`` and ``listen`` / ``WM_LISTEN``
(comma-separated Zenoh endpoints), ``zenoh_config`` / ``WM_ZENOH_CONFIG`` (a
Zenoh config file, its placeholders filled from ``WM_ZENOH_<NAME>``) and
``ontology`` / ``WM_ONTOLOGY`` (a file or a packaged name, default
``default``). As in DSR, ``name`` is the agent's name.
"""

from __future__ import annotations

import asyncio
import atexit
import concurrent.futures
import json
import logging
import os
import threading
from collections.abc import Callable, Iterable
from pathlib import Path
from typing import Any, TypeVar

from .. import dsr_json
from ..errors import NotFoundError, RTError
from ..graph import Graph
from ..net.connection import connect as wm_connect
from ..net.zenoh_config import load_with_environment
from ..ontology import Ontology
from .signals import SignalHub
from .values import DSRTypeError, Edge, Node, _check_id, use_defaults

log = logging.getLogger(__name__)
T = TypeVar("T")
JOIN_TIMEOUT = 30.0


def _endpoints(value: Iterable[str] | str | None, variable: str) -> list[str]:
    if value is None:
        value = os.environ.get(variable, "")
    if isinstance(value, str):
        return [part.strip() for part in value.split(",") if part.strip()]
    return list(value)


def _ref(value: Any, what: str) -> int | str:
    if isinstance(value, str):
        return value
    return _check_id(value, f"{what} (an id or a name)")


def _type_name(value: Any) -> str:
    if not isinstance(value, str):
        raise DSRTypeError(f"a type is a str, got {type(value).__name__}")
    return value


def _succeeds(write: Callable[[], object]) -> bool:
    """Whether ``write`` found what it was to change (pydsr answers False where we raise NotFoundError)."""
    try:
        write()
    except NotFoundError:
        return False
    return True


class DSRGraph:
    """``DSRGraph(root, name, agent_id, config_file="", all_same_host=True)``.

    ``root`` and ``all_same_host`` are accepted for compatibility: the RT root
    is the graph's, and Zenoh chooses its transport from the endpoints. With a
    ``config_file`` (a DSR scene file), the scene is loaded if the joined graph
    holds no node yet. pydsr's keywords ``id`` and ``dsr_input_file`` stand for
    ``agent_id`` and ``config_file``.
    """

    def __init__(
        self,
        root: int,
        name: str,
        agent_id: int | None = None,
        config_file: str = "",
        all_same_host: bool = True,
        *,
        graph: str | None = None,
        connect: Iterable[str] | str | None = None,
        listen: Iterable[str] | str | None = None,
        zenoh_config: str | None = None,
        ontology: Ontology | str | None = None,
        id: int | None = None,
        dsr_input_file: str | None = None,  # pydsr's keyword for config_file
    ) -> None:
        agent_id = agent_id if id is None else id
        config_file = config_file if dsr_input_file is None else dsr_input_file
        _check_id(root, "root")
        if not isinstance(name, str) or not isinstance(config_file, str):
            raise DSRTypeError("name and config_file are str")
        self.agent_id = _check_id(agent_id, "agent_id")
        self.agent_name = name
        self.ontology = (
            ontology
            if isinstance(ontology, Ontology)
            else Ontology.load(ontology or os.environ.get("WM_ONTOLOGY", "default"))
        )
        use_defaults(self.ontology, self.agent_id)
        self.signal_hub = SignalHub(self.agent_id, self.ontology)
        self._graph_name = graph or os.environ.get("WM_GRAPH", "default")
        self._loop = asyncio.new_event_loop()
        self._ready: concurrent.futures.Future[Graph] = concurrent.futures.Future()
        self._stop: asyncio.Event | None = None
        self._thread = threading.Thread(
            target=self._run,
            args=(
                _endpoints(connect, "WM_CONNECT"),
                _endpoints(listen, "WM_LISTEN"),
                zenoh_config or os.environ.get("WM_ZENOH_CONFIG"),
            ),
            name="wm.dsr-replica",
            daemon=True,
        )
        self._thread.start()
        try:
            self._g = self._ready.result(JOIN_TIMEOUT)
        except BaseException:
            self.signal_hub.stop()
            raise
        # at exit, leave before concurrent.futures stops its threads: closing the session needs one
        getattr(threading, "_register_atexit", atexit.register)(self.close)
        if config_file:
            self._call(lambda: self._load_if_empty(config_file))

    # -- the replica's thread -----------------------------------------------------

    def _run(self, connect: list[str], listen: list[str], zenoh_config: str | None) -> None:
        asyncio.set_event_loop(self._loop)
        try:
            self._loop.run_until_complete(self._serve(connect, listen, zenoh_config))
        except BaseException as exc:  # reported to the constructor if it is still waiting
            if not self._ready.done():
                self._ready.set_exception(exc)
            else:
                log.exception("the wm.dsr replica stopped")
        finally:
            self._loop.close()

    async def _serve(self, connect: list[str], listen: list[str], zenoh_config: str | None) -> None:
        self._stop = asyncio.Event()
        async with wm_connect(
            self._graph_name,
            load_with_environment(zenoh_config),
            self.agent_name,
            connect=connect or None,
            listen=listen or None,
            ontology=self.ontology,
        ) as g:
            g.on(self.signal_hub.publish)
            self._ready.set_result(g)
            await self._stop.wait()

    def _call(self, work: Callable[[], T]) -> T:
        """Run ``work`` on the replica's loop and return its result (or raise its error)."""
        if not self._thread.is_alive() or self._stop is None or self._stop.is_set():
            raise RuntimeError("this DSRGraph is closed")
        if threading.current_thread() is self._thread:
            return work()
        done: concurrent.futures.Future[T] = concurrent.futures.Future()

        def run() -> None:
            try:
                done.set_result(work())
            except BaseException as exc:
                done.set_exception(exc)

        self._loop.call_soon_threadsafe(run)
        return done.result()

    def close(self) -> None:
        """Leave the graph: stop replicating, close the Zenoh session, deliver the pending signals."""
        if self._stop is not None and not self._stop.is_set() and self._thread.is_alive():
            self._loop.call_soon_threadsafe(self._stop.set)
            self._thread.join()
            self.signal_hub.stop()

    def __enter__(self) -> DSRGraph:
        return self

    def __exit__(self, *exc: object) -> None:
        self.close()

    def _load_if_empty(self, config_file: str) -> None:
        if self._g.node_count() == 0:
            self._g.load_json(Path(config_file))
        else:
            log.info(
                "graph %r already holds %d nodes; %s not loaded", self._graph_name, self._g.node_count(), config_file
            )

    def get_agent_id(self) -> int:
        return self.agent_id

    def get_agent_name(self) -> str:
        return self.agent_name

    # -- nodes ------------------------------------------------------------------

    def _node(self, ref: int | str) -> Node | None:
        found = self._g.find_node(ref)
        if found is None:
            return None
        return Node.of(found, self._g.edges(src=found.id), self.agent_id, self.ontology)

    def get_node(self, ref: int | str) -> Node | None:
        key = _ref(ref, "get_node takes a node")
        return self._call(lambda: self._node(key))

    def get_node_root(self) -> Node | None:
        """The node of type ``root`` (the lowest id if several), else the node named ``world``."""

        def root() -> Node | None:
            roots = self._g.nodes("root")
            return self._node(roots[0].id) if roots else self._node("world")

        return self._call(root)

    def get_nodes(self) -> list[Node]:
        return self._call(lambda: [self._node(n.id) for n in self._g.nodes()])  # type: ignore[misc]  # _node(id) of a listed node is never None

    def get_nodes_by_type(self, type: str) -> list[Node]:
        type_name = _type_name(type)
        return self._call(lambda: [self._node(n.id) for n in self._g.nodes(type_name)])  # type: ignore[misc]  # _node(id) of a listed node is never None

    def get_name_from_id(self, node_id: int) -> str | None:
        key = _check_id(node_id, "get_name_from_id takes an id")
        return self._call(lambda: found.name if (found := self._g.find_node(key)) else None)

    def get_id_from_name(self, name: str) -> int | None:
        if not isinstance(name, str):
            raise DSRTypeError(f"get_id_from_name takes a str, got {type(name).__name__}")
        return self._call(lambda: found.id if (found := self._g.find_node(name)) else None)

    def insert_node(self, node: Node) -> int | None:
        """Insert a new node and return its id (also set on ``node``); None if its id or name exists."""
        if not isinstance(node, Node):
            raise DSRTypeError(f"insert_node takes a Node, got {type(node).__name__}")

        def insert() -> int | None:
            if (node.id and self._g.id_taken(node.id)) or (node.name and self._g.find_node(node.name) is not None):
                return None
            values, _ = node.changes()  # all of them: a new node was read with none
            new_id = self._g.insert_node(node.type, node.name or None, values)
            node.mark_inserted(new_id, self._g.get_node(new_id).name)
            return new_id

        return self._call(insert)

    def update_node(self, node: Node) -> bool:
        """Write the attributes the caller set, changed or removed since it read ``node``; False if the node is gone."""
        if not isinstance(node, Node):
            raise DSRTypeError(f"update_node takes a Node, got {type(node).__name__}")

        def update() -> bool:
            current = self._g.find_node(node.id) if node.id else None
            if current is None or (current.type, current.name) != (node.type, node.name):
                return False
            return _succeeds(
                lambda: self._write_changes(
                    node,
                    lambda changed: self._g.update_node(node.id, changed),
                    lambda name: self._g.delete_attr(node.id, name),
                )
            )

        return self._call(update)

    def delete_node(self, ref: int | str) -> bool:
        key = _ref(ref, "delete_node takes a node")
        return self._call(lambda: _succeeds(lambda: self._g.delete_node(key)))

    def _write_changes(
        self, element: Node | Edge, write: Callable[[dict[str, Any]], None], remove: Callable[[str], None]
    ) -> None:
        """Write what the caller set, changed or removed on ``element`` since reading it, in one batch."""
        changed, removed = element.changes()
        with self._g.batch():
            write(changed)
            for name in removed:
                remove(name)
        element.mark_written()

    # -- edges ------------------------------------------------------------------

    def get_edge(self, frm: int | str, to: int | str, type: str) -> Edge | None:
        src, dst, type_name = _ref(frm, "get_edge from"), _ref(to, "get_edge to"), _type_name(type)

        def get() -> Edge | None:
            found = self._g.find_edge(src, dst, type_name)
            return Edge.of(found, self.agent_id, self.ontology) if found else None

        return self._call(get)

    def insert_or_assign_edge(self, edge: Edge) -> bool:
        """Create the edge or write what the caller changed or removed since reading it; False if an end is missing."""
        if not isinstance(edge, Edge):
            raise DSRTypeError(f"insert_or_assign_edge takes an Edge, got {type(edge).__name__}")
        key = (edge.origin, edge.destination, edge.type)

        def assign() -> bool:
            try:
                return _succeeds(
                    lambda: self._write_changes(
                        edge,
                        lambda changed: self._g.insert_or_assign_edge(*key, changed),
                        lambda name: self._g.delete_edge_attr(*key, name),
                    )
                )
            except RTError as exc:
                log.warning("insert_or_assign_edge refused: %s", exc)
                return False

        return self._call(assign)

    def delete_edge(self, frm: int | str, to: int | str, type: str) -> bool:
        src, dst, type_name = _ref(frm, "delete_edge from"), _ref(to, "delete_edge to"), _type_name(type)

        return self._call(lambda: _succeeds(lambda: self._g.delete_edge(src, dst, type_name)))

    def get_edges(self) -> list[Edge]:
        return self._call(lambda: [Edge.of(e, self.agent_id, self.ontology) for e in self._g.edges()])

    def get_edges_by_type(self, type: str) -> list[Edge]:
        type_name = _type_name(type)
        return self._call(lambda: [Edge.of(e, self.agent_id, self.ontology) for e in self._g.edges(type=type_name)])

    def get_edges_to_id(self, node_id: int) -> list[Edge]:
        key = _check_id(node_id, "get_edges_to_id takes an id")

        def edges() -> list[Edge]:
            if self._g.find_node(key) is None:
                return []
            return [Edge.of(e, self.agent_id, self.ontology) for e in self._g.edges(dst=key)]

        return self._call(edges)

    # -- files and access for the geometry APIs ---------------------------------------

    def write_to_json_file(self, file: str, skip_atts: list[str] | None = None) -> None:
        """Write the graph as a DSR scene file; nodes of the types in ``skip_atts`` are written without vector contents."""
        if not isinstance(file, str):
            raise DSRTypeError(f"file is a str, got {type(file).__name__}")
        skip = list(skip_atts or [])
        if not all(isinstance(s, str) for s in skip):
            raise DSRTypeError("skip_atts is a list of node type names")
        scene = self._call(lambda: dsr_json.graph_to_dsr(self._g, skip))
        Path(file).write_text(json.dumps(scene, indent=4) + "\n", encoding="utf-8")

    def with_graph(self, work: Callable[[Graph], T]) -> T:
        """Run ``work(graph)`` on the replica's loop: the way to the native :class:`wm.Graph` API."""
        return self._call(lambda: work(self._g))

    @property
    def closed(self) -> bool:
        return self._stop is None or self._stop.is_set()
