"""cortex-wm: a distributed working memory for cognitive robots.

A typed graph of nodes and edges with typed attributes and RT (geometric)
edges, replicated as a CRDT. Start with :class:`wm.Graph` for a local replica.
"""

from .errors import (
    AttributeTypeError,
    DecodeError,
    EdgeNotFoundError,
    NameExistsError,
    NodeExistsError,
    NodeNotFoundError,
    NotFoundError,
    OntologyError,
    PluginError,
    RTError,
    SceneFormatError,
    UnknownAttributeError,
    UnknownTypeError,
    ValidationError,
    WMError,
)
from .events import Event, EventKind, EventStream, Subscription
from .graph import Graph
from .model import Edge, Node
from .net.connection import ConnectError, connect
from .ontology import AttributeSpec, Ontology
from .rt import se2

__all__ = [
    "AttributeSpec",
    "AttributeTypeError",
    "ConnectError",
    "connect",
    "DecodeError",
    "Edge",
    "EdgeNotFoundError",
    "Event",
    "EventKind",
    "EventStream",
    "Graph",
    "NameExistsError",
    "Node",
    "NodeExistsError",
    "NodeNotFoundError",
    "NotFoundError",
    "Ontology",
    "OntologyError",
    "PluginError",
    "RTError",
    "SceneFormatError",
    "Subscription",
    "UnknownAttributeError",
    "UnknownTypeError",
    "ValidationError",
    "WMError",
    "se2",
]
