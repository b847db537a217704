"""pydsr's signals: ``signals.connect(g, signals.UPDATE_NODE, callback)`` and DSR's signal types.

Every change of the graph, made by this agent or by any other, becomes the
DSR signals below. They are delivered in order on one thread that each
``DSRGraph`` owns for them (named ``wm.dsr-signals``): never on a Zenoh
thread and never on the loop that keeps the replica, so a callback may call
the graph. A callback that raises is logged and counted; delivery goes on.

| Change | Signals, with the callback's arguments |
|---|---|
| node added | ``UPDATE_NODE(id, type)`` |
| node attributes written or removed | ``UPDATE_NODE_ATTR(id, names)`` |
| node deleted | ``DELETE_NODE(id)``, then ``DELETE_NODE_OBJ(node)`` |
| edge added | ``UPDATE_EDGE(from, to, type)`` |
| edge attributes written or removed | ``UPDATE_EDGE(from, to, type)``, then ``UPDATE_EDGE_ATTR(from, to, names)`` |
| edge deleted | ``DELETE_EDGE(from, to, type)``, then ``DELETE_EDGE_OBJ(edge)`` |

pydsr's releases differ on ``UPDATE_EDGE_ATTR``: a callback that takes four
arguments gets ``(from, to, type, names)``, as recent releases give. The
``node`` and ``edge`` of the ``*_OBJ`` signals carry the id, type and name (or
ends) of what was deleted; its attributes are gone with it. ``connect2``
(pydsr's queued connection) is ``connect``: every connection is queued here.
"""

from __future__ import annotations

import inspect
import logging
import queue
import threading
from collections.abc import Callable
from enum import Enum
from typing import TYPE_CHECKING, Any

from ..events import Event, EventKind
from ..model import Edge as WMEdge
from ..model import Node as WMNode
from ..ontology import Ontology
from .values import DSRTypeError, Edge, Node

if TYPE_CHECKING:
    from .graph import DSRGraph

log = logging.getLogger(__name__)


class SignalType(Enum):
    UPDATE_NODE = "update_node"
    UPDATE_NODE_ATTR = "update_node_attr"
    UPDATE_EDGE = "update_edge"
    UPDATE_EDGE_ATTR = "update_edge_attr"
    DELETE_EDGE = "delete_edge"
    DELETE_NODE = "delete_node"
    DELETE_NODE_OBJ = "delete_node_obj"
    DELETE_EDGE_OBJ = "delete_edge_obj"


UPDATE_NODE = SignalType.UPDATE_NODE
UPDATE_NODE_ATTR = SignalType.UPDATE_NODE_ATTR
UPDATE_EDGE = SignalType.UPDATE_EDGE
UPDATE_EDGE_ATTR = SignalType.UPDATE_EDGE_ATTR
DELETE_EDGE = SignalType.DELETE_EDGE
DELETE_NODE = SignalType.DELETE_NODE
DELETE_NODE_OBJ = SignalType.DELETE_NODE_OBJ
DELETE_EDGE_OBJ = SignalType.DELETE_EDGE_OBJ

Emission = tuple[SignalType, tuple[Any, ...]]


def connect(graph: DSRGraph, signal: SignalType, callback: Callable[..., object]) -> None:
    """Call ``callback`` with the signal's arguments for every matching change, local or remote."""
    if not isinstance(signal, SignalType):
        raise DSRTypeError(
            f"signal must be one of signals.{', signals.'.join(s.name for s in SignalType)}, got {signal!r:.40}"
        )
    if not callable(callback):
        raise DSRTypeError(f"callback must be callable, got {type(callback).__name__}")
    if signal is UPDATE_EDGE_ATTR and not _takes_four(callback):
        graph.signal_hub.add(signal, lambda frm, to, _type, names: callback(frm, to, names))
    else:
        graph.signal_hub.add(signal, callback)


connect2 = connect


def _takes_four(callback: Callable[..., object]) -> bool:
    """Whether a callback takes (from, to, type, names) rather than (from, to, names)."""
    try:
        parameters = inspect.signature(callback).parameters.values()
    except (TypeError, ValueError):  # no signature to read (some builtins): the recent form
        return True
    if any(p.kind is p.VAR_POSITIONAL for p in parameters):
        return True
    return sum(p.kind in (p.POSITIONAL_ONLY, p.POSITIONAL_OR_KEYWORD) for p in parameters) >= 4


def emissions(event: Event, agent_id: int, ontology: Ontology) -> list[Emission]:
    """The DSR signals one cortex-wm event stands for."""
    names = sorted(event.attrs)
    if event.kind is EventKind.NODE_ADDED:
        return [(UPDATE_NODE, (event.id, event.type))]
    if event.kind is EventKind.NODE_UPDATED:
        return [(UPDATE_NODE_ATTR, (event.id, names))]
    if event.kind is EventKind.NODE_REMOVED:
        gone = Node.of(WMNode(event.id, event.type, event.name or ""), [], agent_id, ontology)  # type: ignore[arg-type]  # a node event always carries its id
        return [(DELETE_NODE, (event.id,)), (DELETE_NODE_OBJ, (gone,))]
    if event.kind is EventKind.EDGE_ADDED:
        return [(UPDATE_EDGE, (event.src, event.dst, event.type))]
    if event.kind is EventKind.EDGE_UPDATED:
        return [
            (UPDATE_EDGE, (event.src, event.dst, event.type)),
            (UPDATE_EDGE_ATTR, (event.src, event.dst, event.type, names)),
        ]
    if event.kind is EventKind.EDGE_REMOVED:
        gone_edge = Edge.of(WMEdge(event.src, event.dst, event.type), agent_id, ontology)  # type: ignore[arg-type]  # an edge event always carries both ends
        return [(DELETE_EDGE, (event.src, event.dst, event.type)), (DELETE_EDGE_OBJ, (gone_edge,))]
    return []


class SignalHub:
    """The callbacks of one DSRGraph and the thread that calls them."""

    def __init__(self, agent_id: int, ontology: Ontology) -> None:
        self._agent_id = agent_id
        self._ontology = ontology
        self._callbacks: dict[SignalType, list[Callable[..., object]]] = {s: [] for s in SignalType}
        self._queue: queue.SimpleQueue[Emission | None] = queue.SimpleQueue()
        self._lock = threading.Lock()
        self.errors = 0
        self._thread = threading.Thread(target=self._deliver, name="wm.dsr-signals", daemon=True)
        self._thread.start()

    def add(self, signal: SignalType, callback: Callable[..., object]) -> None:
        with self._lock:
            self._callbacks[signal] = [*self._callbacks[signal], callback]

    def publish(self, event: Event) -> None:
        """Queue an event's signals (called on the replica's loop)."""
        for emission in emissions(event, self._agent_id, self._ontology):
            if self._callbacks[emission[0]]:
                self._queue.put(emission)

    def _deliver(self) -> None:
        while (emission := self._queue.get()) is not None:
            signal, args = emission
            for callback in self._callbacks[signal]:
                try:
                    callback(*args)
                except Exception:
                    self.errors += 1
                    log.exception("a %s callback raised", signal.name)

    def stop(self) -> None:
        """Deliver what is queued, then end the thread (unless called from a callback)."""
        self._queue.put(None)
        if threading.current_thread() is not self._thread:
            self._thread.join()
