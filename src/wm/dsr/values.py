"""pydsr's value classes over cortex-wm: ``Attribute``, ``Node`` and ``Edge``.

They are plain Python objects, as in pydsr: an agent reads a node, edits its
``attrs`` and hands it back to ``DSRGraph.update_node``. A node or edge read
from the graph remembers the attribute values it was read with, so that the
graph writes back only what the caller changed or removed.

Every check that pydsr makes happens here too, with its exception types:
``TypeError`` for a value of the wrong type, ``AttributeError`` for a
read-only property, ``KeyError`` for a missing attribute, ``RuntimeError`` for
an unknown node or edge type. Each is also a :class:`wm.WMError`.
"""

from __future__ import annotations

import time
from collections.abc import Iterator, Mapping, MutableMapping
from typing import Any

import numpy as np

from ..errors import AttributeTypeError, UnknownAttributeError, UnknownTypeError
from ..model import Edge as WMEdge
from ..model import Node as WMNode
from ..ontology import ElementType, Ontology


class DSRTypeError(AttributeTypeError, TypeError):
    """A value or argument of the wrong type (pydsr raises TypeError)."""


class DSRUnknownTypeError(UnknownTypeError, RuntimeError):
    """A node or edge type the ontology does not declare (pydsr raises RuntimeError)."""


class DSRUnknownAttributeError(UnknownAttributeError, KeyError):
    """An attribute the ontology does not allow on this node or edge type."""

    def __str__(self) -> str:  # KeyError would quote the message
        return str(self.args[0]) if self.args else ""


def _kind(value: Any) -> str:
    """The value class pydsr keeps fixed for an attribute: bool, int, float, str, bytes or vector."""
    if isinstance(value, (bool, np.bool_)):
        return "bool"
    if isinstance(value, (int, np.integer)):
        return "int"
    if isinstance(value, (float, np.floating)):
        return "float"
    if isinstance(value, str):
        return "str"
    if isinstance(value, (bytes, bytearray, memoryview)):
        return "bytes"
    if isinstance(value, (list, tuple, np.ndarray)):
        return "vector"
    raise DSRTypeError(
        f"an Attribute holds a bool, int, float, str, bytes or a vector of numbers, not {type(value).__name__}"
    )


def _plain(value: Any) -> Any:
    """The value as the Attribute keeps it: vectors as numpy arrays, like pydsr."""
    if isinstance(value, (list, tuple, np.ndarray)):
        array = np.array(value)
        if array.ndim != 1 or not (np.issubdtype(array.dtype, np.number) or array.size == 0):
            raise DSRTypeError(f"a vector attribute holds a flat sequence of numbers, got {value!r:.60}")
        return array
    return bytes(value) if isinstance(value, (bytearray, memoryview)) else value


class Attribute:
    """``Attribute(value, agent_id)`` or ``Attribute(value, timestamp, agent_id)``.

    Without an agent id (``Attribute(value)``), it is the id of the agent that
    created the last DSRGraph, as in pydsr; the timestamp defaults to now.
    """

    __slots__ = ("_agent_id", "_timestamp", "_value")

    def __init__(self, value: Any, *args: int, timestamp: int | None = None, agent_id: int | None = None) -> None:
        _kind(value)
        if len(args) > 2 or (len(args) == 2 and (timestamp is not None or agent_id is not None)):
            raise DSRTypeError("Attribute takes (value, agent_id) or (value, timestamp, agent_id)")
        if len(args) == 2:
            timestamp, agent_id = args
        elif len(args) == 1:
            if agent_id is None:
                agent_id = args[0]
            else:
                timestamp = args[0]
        timestamp = time.time_ns() if timestamp is None else timestamp
        agent_id = _current["agent_id"] if agent_id is None else agent_id
        for name, number in (("agent_id", agent_id), ("timestamp", timestamp)):
            if isinstance(number, bool) or not isinstance(number, (int, np.integer)):
                raise DSRTypeError(f"Attribute {name} must be an int, got {type(number).__name__}")
        self._value = _plain(value)
        self._timestamp = int(timestamp)
        self._agent_id = int(agent_id)

    @property
    def value(self) -> Any:
        return self._value

    @value.setter
    def value(self, new: Any) -> None:
        if _kind(new) != _kind(self._value):
            raise DSRTypeError(f"this Attribute holds a {_kind(self._value)}; cannot assign a {_kind(new)}")
        self._value = _plain(new)

    @property
    def agent_id(self) -> int:
        return self._agent_id

    @property
    def timestamp(self) -> int:
        return self._timestamp

    def __repr__(self) -> str:
        return f"Attribute({self._value!r}, {self._timestamp}, {self._agent_id})"


class Attrs(MutableMapping[str, Attribute]):
    """A node's or edge's attributes: name -> :class:`Attribute`.

    A value of the wrong type for a declared attribute is refused on
    assignment. As in pydsr, any name may be assigned; one the ontology does
    not allow on the type is refused when the node or edge is written.
    """

    def __init__(self, ontology: Ontology, element: ElementType) -> None:
        self._ontology = ontology
        self._element = element
        self._items: dict[str, Attribute] = {}

    def __getitem__(self, name: str) -> Attribute:
        return self._items[name]

    def __setitem__(self, name: str, attribute: Attribute) -> None:
        if not isinstance(attribute, Attribute):
            raise DSRTypeError(f"attrs[{name!r}] takes an Attribute, got {type(attribute).__name__}")
        try:
            self.check(name, attribute.value)
        except DSRUnknownAttributeError:
            pass  # refused when written, as the graph cannot hold it
        self._items[name] = attribute

    def check(self, name: str, value: Any) -> Any:
        """The value in its stored form; DSRTypeError or DSRUnknownAttributeError if the ontology refuses it."""
        try:
            spec = self._ontology.attribute_for(self._element, name)
        except UnknownAttributeError as exc:
            raise DSRUnknownAttributeError(str(exc)) from None
        try:
            return spec.coerce(value, self._element.name)
        except AttributeTypeError as exc:
            raise DSRTypeError(str(exc)) from None

    def __delitem__(self, name: str) -> None:
        del self._items[name]

    def __iter__(self) -> Iterator[str]:
        return iter(self._items)

    def __len__(self) -> int:
        return len(self._items)

    def __repr__(self) -> str:
        return repr(self._items)

    def stored(self) -> dict[str, Any]:
        """Every attribute in its stored form (what a write would store)."""
        return {name: self.check(name, attribute.value) for name, attribute in self._items.items()}

    def fill(self, attrs: Mapping[str, Any], agent_id: int) -> None:
        """Set the attributes read from the graph (already valid)."""
        self._items = {name: Attribute(_readable(value), agent_id) for name, value in attrs.items()}


def _readable(value: Any) -> Any:
    return np.array(value) if isinstance(value, tuple) else value


def _element(ontology: Ontology, kind: str, type_name: Any) -> ElementType:
    if not isinstance(type_name, str):
        raise DSRTypeError(f"a {kind} type is a str, got {type(type_name).__name__}")
    if not ontology.declares(kind, type_name):
        raise DSRUnknownTypeError(f"unknown {kind} type {type_name!r} (ontology {ontology.source!r})")
    return ontology.node_type(type_name) if kind == "node" else ontology.edge_type(type_name)


def _check_id(value: Any, what: str) -> int:
    if isinstance(value, bool) or not isinstance(value, (int, np.integer)):
        raise DSRTypeError(f"{what} must be an int, got {type(value).__name__}")
    return int(value)


class _Element:
    """What nodes and edges share: a type, attributes, and the values they were read with."""

    def __init__(self, ontology: Ontology | None, kind: str, type_name: str, agent_id: int) -> None:
        ontology = ontology or default_ontology()
        self.agent_id = _check_id(agent_id, "agent_id")
        self._type = type_name
        self._attrs = Attrs(ontology, _element(ontology, kind, type_name))
        self._read: dict[str, Any] = {}

    def _fill(self, attrs: Mapping[str, Any]) -> None:
        self._attrs.fill(attrs, self.agent_id)
        self.mark_written()

    @property
    def type(self) -> str:
        return self._type

    @property
    def attrs(self) -> Attrs:
        return self._attrs

    def changes(self) -> tuple[dict[str, Any], list[str]]:
        """What the caller set or changed, and what it removed, since this was read (or last written)."""
        now = self._attrs.stored()  # compared in their stored form, handed on as the caller gave them
        changed = {
            name: self._attrs[name].value
            for name, value in now.items()
            if name not in self._read or self._read[name] != value
        }
        return changed, sorted(set(self._read) - set(now))

    def mark_written(self) -> None:
        self._read = self._attrs.stored()


class Edge(_Element):
    """``Edge(to, from, type, agent_id)``: note that the destination comes first, as in pydsr."""

    def __init__(self, to: int, frm: int, type: str, agent_id: int, *, ontology: Ontology | None = None) -> None:
        self._to, self._from = _check_id(to, "Edge to"), _check_id(frm, "Edge from")
        super().__init__(ontology, "edge", type, agent_id)

    @classmethod
    def of(cls, edge: WMEdge, agent_id: int, ontology: Ontology) -> Edge:
        made = cls(edge.dst, edge.src, edge.type, agent_id, ontology=ontology)
        made._fill(edge.attrs)
        return made

    @property
    def origin(self) -> int:
        return self._from

    @property
    def destination(self) -> int:
        return self._to

    def __repr__(self) -> str:
        return f"Edge(from={self._from}, to={self._to}, type={self._type!r}, attrs={self._attrs!r})"


class Node(_Element):
    """``Node(agent_id, type, name="")``; the id is given by ``DSRGraph.insert_node``."""

    def __init__(self, agent_id: int, type: str, name: str = "", *, ontology: Ontology | None = None) -> None:
        if not isinstance(name, str):
            raise DSRTypeError(f"a node name is a str, got {name.__class__.__name__}")
        super().__init__(ontology, "node", type, agent_id)
        self._id = 0
        self._name = name
        self._edges: dict[tuple[int, str], Edge] = {}

    @classmethod
    def of(cls, node: WMNode, out_edges: list[WMEdge], agent_id: int, ontology: Ontology) -> Node:
        made = cls(agent_id, node.type, node.name, ontology=ontology)
        made._id = node.id
        made._fill(node.attrs)
        made._edges = {(e.dst, e.type): Edge.of(e, agent_id, ontology) for e in out_edges}
        return made

    @property
    def id(self) -> int:
        return self._id

    @property
    def name(self) -> str:
        return self._name

    @property
    def edges(self) -> dict[tuple[int, str], Edge]:
        return self._edges

    def get_edges(self) -> list[Edge]:
        return list(self._edges.values())

    def mark_inserted(self, node_id: int, name: str) -> None:
        self._id, self._name = node_id, name
        self.mark_written()

    def __repr__(self) -> str:
        return f"Node(id={self._id}, type={self._type!r}, name={self._name!r}, attrs={self._attrs!r})"


_current: dict[str, Any] = {"ontology": None, "agent_id": 0}


def default_ontology() -> Ontology:
    """The ontology new Node and Edge objects are checked against: the last DSRGraph's, else the default one."""
    current: Ontology | None = _current["ontology"]
    if current is None:
        current = _current["ontology"] = Ontology.default()
    return current


def use_defaults(ontology: Ontology, agent_id: int) -> None:
    """What Node, Edge and Attribute objects made without them get (set by each new DSRGraph)."""
    _current.update(ontology=ontology, agent_id=agent_id)
