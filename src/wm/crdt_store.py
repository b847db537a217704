"""The layout of the graph inside one pycrdt document, and the raw changes it reports.

Four root maps:

``nodes``       node id -> Map{"@type", "@name", attr: value, ...}. Only the
                creator writes a node's key, once (ids are unique per creator),
                so nested maps never conflict; attributes are written one key
                at a time, so concurrent writers of different attributes never
                lose each other's writes.
``edges``       "src>dst>type" -> True: edge presence. Concurrent inserts of the
                same edge both survive as one edge (add wins over a concurrent delete).
``edge_attrs``  "src>dst>type.attr" -> value: flat, so concurrent inserts of the
                same edge merge attribute by attribute instead of one nested map
                replacing the other.
``deleted``     node id -> True: tombstones, so a deleted id is never re-created.

This module knows nothing of the ontology, events or transport: it writes,
and it records which keys a transaction touched so :mod:`wm.index` can turn
them into events once the transaction is over. The hot paths (observers,
attribute writes, reads) call pycrdt's integrated types directly: the Python
wrappers open a transaction and build event objects per call.
"""

from __future__ import annotations

from collections.abc import Callable, Iterable
from contextlib import AbstractContextManager
from dataclasses import dataclass, field
from typing import Any

from pycrdt import Doc, Map, TransactionEvent

from .errors import DecodeError

TYPE_KEY = "@type"
EMPTY_STATE_VECTOR = b"\x00"
NAME_KEY = "@name"


@dataclass(frozen=True)
class NodeContent:
    """A node map's head as stored: ``@type`` and ``@name`` as found (any type, or None), and its attribute names."""

    type: Any
    name: Any
    attrs: set[str]


@dataclass
class RawChanges:
    """The keys one or more transactions touched, in the order they were reported."""

    nodes_added: list[str] = field(default_factory=list)
    nodes_removed: list[str] = field(default_factory=list)
    node_attrs: dict[str, set[str]] = field(default_factory=dict)
    edges_added: list[str] = field(default_factory=list)
    edges_removed: list[str] = field(default_factory=list)
    edge_attrs: dict[str, set[str]] = field(default_factory=dict)
    malformed_edge_attrs: list[str] = field(
        default_factory=list
    )  # edge_attrs keys without a '.' (only a peer writes them)
    # pycrdt occasionally reports a nested change with no keys (seen when concurrent
    # writes to one key are merged); the index then re-checks every node's name.
    unreliable: bool = False

    def __bool__(self) -> bool:
        return bool(
            self.nodes_added
            or self.nodes_removed
            or self.node_attrs
            or self.edges_added
            or self.edges_removed
            or self.edge_attrs
            or self.malformed_edge_attrs
        )


class _Read:
    """A raw transaction to read in: the one open (a batch's), else a new one of its own.

    pycrdt's wrapper costs several times the read of a few values.
    """

    __slots__ = ("doc", "own")

    def __init__(self, doc: Doc[Any]) -> None:
        self.doc = doc

    def __enter__(self) -> Any:
        current = self.doc._txn
        if current is not None:
            self.own = None
            return current._txn
        self.own = self.doc._doc.create_transaction()
        return self.own

    def __exit__(self, *exc: Any) -> None:
        if self.own is not None:
            self.own.commit()
            self.own.drop()


class _Transaction:
    """:meth:`CrdtStore.transaction` (a class: a generator-based context manager costs more per write)."""

    __slots__ = ("store", "origin", "outer", "txn")

    def __init__(self, store: CrdtStore, origin: Any) -> None:
        self.store, self.origin = store, origin

    def __enter__(self) -> None:
        store = self.store
        self.outer = (store.current_origin, store._txn)
        store.current_origin = self.origin
        store._full = None
        self.txn = store.doc.transaction()  # the origin is ours to keep (current_origin), not pycrdt's
        try:
            store._txn = self.txn.__enter__()._txn
        except BaseException:
            store.current_origin, store._txn = self.outer
            raise

    def __exit__(self, *exc: Any) -> None:
        try:
            self.txn.__exit__(*exc)
        finally:
            self.store.current_origin, self.store._txn = self.outer


class _Recorder:
    """The document's observers: the keys each transaction touched, until :meth:`CrdtStore.take_changes`.

    Not the store's own methods: pycrdt keeps observers alive from the
    document, out of sight of Python's collector, so observers bound to the
    store would keep it and its whole document alive for good.
    """

    __slots__ = ("changes",)

    def __init__(self) -> None:
        self.changes = RawChanges()

    def _keys(self, event: Any) -> dict[str, Any]:
        """The keys a map event changed; none, and the change marked unreliable, if pycrdt cannot say.

        yrs 0.28 can panic while listing the keys of a map event that a merged remote update
        produced (``types/mod.rs``: ``Option::unwrap()`` on ``None``). The document itself is
        intact, so the index re-checks the whole document instead of trusting the event.
        """
        try:
            keys: dict[str, Any] = event.keys
        except BaseException as exc:  # pyo3 raises a Rust panic as PanicException, a BaseException
            if type(exc).__name__ != "PanicException":
                raise
            self.changes.unreliable = True
            return {}
        return keys

    def on_nodes(self, events: list[Any]) -> None:
        for event in events:
            path = event.path
            if not path:
                for key, change in self._keys(event).items():
                    action = change["action"]
                    if action in ("delete", "update"):
                        self.changes.nodes_removed.append(key)
                    if action in ("add", "update"):
                        self.changes.nodes_added.append(key)
            else:
                # a change inside an attribute's value (only a peer writes shared types there) touches that attribute
                changed = set(self._keys(event)) if len(path) == 1 else {str(path[1])}
                if not changed:
                    self.changes.unreliable = True
                self.changes.node_attrs.setdefault(str(path[0]), set()).update(changed)

    def on_edges(self, event: Any) -> None:
        for key, change in self._keys(event).items():
            if change["action"] == "delete":
                self.changes.edges_removed.append(key)
            else:  # "add", or "update" when a peer overwrote a marker
                self.changes.edges_added.append(key)

    def on_edge_attrs(self, event: Any) -> None:
        for flat_key in self._keys(event):
            key, dot, attr = flat_key.rpartition(".")
            if dot:
                self.changes.edge_attrs.setdefault(key, set()).add(attr)
            else:
                self.changes.malformed_edge_attrs.append(flat_key)


def _is_panic(exc: BaseException) -> bool:
    return type(exc).__name__ == "PanicException"


class CrdtStore:
    """One pycrdt document holding one graph."""

    def __init__(self, doc: Doc[Any] | None = None) -> None:
        self.doc = doc if doc is not None else Doc()
        self.nodes: Map[Any] = self.doc.get("nodes", type=Map)
        self.edges: Map[Any] = self.doc.get("edges", type=Map)
        self.edge_attrs: Map[Any] = self.doc.get("edge_attrs", type=Map)
        self.deleted: Map[Any] = self.doc.get("deleted", type=Map)
        self.recorder = _Recorder()
        self.pending = self.recorder.changes  # the recorder's, kept here too: every write reads it
        self.current_origin: Any = None
        self._txn: Any = None  # pycrdt's raw transaction while :meth:`transaction` is open
        self._full: bytes | None = None  # the whole state as one update, kept until the next transaction
        self._subscriptions: list[Any] = []
        self._observe()

    def _observe(self) -> None:
        # the raw events: pycrdt's wrappers would convert every field of every event first
        self._subscriptions = [
            self.nodes.integrated.observe_deep(self.recorder.on_nodes),
            self.edges.integrated.observe(self.recorder.on_edges),
            self.edge_attrs.integrated.observe(self.recorder.on_edge_attrs),
        ]

    def _unobserve(self) -> None:
        for subscription in self._subscriptions:
            subscription.drop()
        self._subscriptions = []

    def is_empty(self) -> bool:
        """Whether nothing was ever written to or applied on this document."""
        return self.doc.get_state() == EMPTY_STATE_VECTOR

    # -- change capture ------------------------------------------------------

    def take_changes(self) -> RawChanges:
        changes = self.pending
        self.pending = self.recorder.changes = RawChanges()
        return changes

    def transaction(self, origin: Any) -> AbstractContextManager[None]:
        """A document transaction whose changes are attributed to ``origin`` (a replica id)."""
        return _Transaction(self, origin)

    # -- reads ---------------------------------------------------------------

    def _read(self) -> _Read:
        return _Read(self.doc)

    def sizes(self) -> tuple[int, int]:
        """How many node keys and edge markers the document holds."""
        with self._read() as raw_txn:
            return self.nodes.integrated.len(raw_txn), self.edges.integrated.len(raw_txn)

    def has_node(self, key: str) -> bool:
        return key in self.nodes

    def node_map(self, key: str) -> Map[Any] | None:
        value = self.nodes.get(key)
        return value if isinstance(value, Map) else None

    def read_nodes(self, keys: Iterable[str], attr_names: bool = True) -> dict[str, NodeContent | None]:
        """What each present key holds, read in one transaction: its head if it is a map, else None.

        The pycrdt wrappers open a transaction per call (about 60 us per node);
        a catch-up reading thousands of new nodes goes through the integrated
        maps underneath them instead, the same objects the wrappers call.
        ``@type`` and ``@name`` come back as stored, whatever their type; the
        attribute names only with ``attr_names``.
        """
        contents: dict[str, NodeContent | None] = {}
        with self._read() as raw_txn:
            root = self.nodes.integrated
            raw_map, get = type(root), root.get
            for key in keys:
                try:  # a missing key raises ValueError: one call instead of has() and get()
                    node = get(raw_txn, key)
                except ValueError:
                    continue
                if type(node) is not raw_map:
                    contents[key] = None
                    continue
                node_type, name = _head(raw_txn, node)
                attrs = {k for k in node.keys(raw_txn) if not k.startswith("@")} if attr_names else set()
                contents[key] = NodeContent(node_type, name, attrs)
        return contents

    def read_heads(self) -> dict[str, tuple[Any, Any] | None]:
        """Every node key with its map's ``@type`` and ``@name`` as stored (None when missing), or None if not a map.

        One transaction and three calls per node (a catch-up reads thousands).
        """
        heads: dict[str, tuple[Any, Any] | None] = {}
        with self._read() as raw_txn:
            root = self.nodes.integrated
            raw_map, get = type(root), root.get
            for key in root.keys(raw_txn):
                node = get(raw_txn, key)
                if type(node) is not raw_map:
                    heads[key] = None
                    continue
                try:
                    heads[key] = node.get(raw_txn, TYPE_KEY), node.get(raw_txn, NAME_KEY)
                except ValueError:  # one of them is missing
                    heads[key] = _head(raw_txn, node)
        return heads

    def node_values(self, key: str) -> dict[str, Any] | None:
        """Every entry of one node map as stored (``@type`` and ``@name`` included), or None if it is not a map.

        One transaction on the integrated map: the wrappers' ``items()`` opens
        one per value.
        """
        with self._read() as raw_txn:
            root = self.nodes.integrated
            node = root.get(raw_txn, key) if root.has(raw_txn, key) else None
            if not isinstance(node, type(root)):
                return None
            return {k: node.get(raw_txn, k) for k in node.keys(raw_txn)}

    def read_node_attrs(self, wanted: dict[str, set[str]]) -> dict[str, dict[str, Any]]:
        """The stored values of some attributes of some nodes (absent ones left out), in one transaction."""
        values: dict[str, dict[str, Any]] = {}
        with self._read() as raw_txn:
            root = self.nodes.integrated
            raw_map = type(root)
            for key, attrs in wanted.items():
                node = root.get(raw_txn, key) if root.has(raw_txn, key) else None
                if isinstance(node, raw_map):
                    values[key] = {a: node.get(raw_txn, a) for a in attrs if node.has(raw_txn, a)}
        return values

    def read_flat(self, root_map: Map[Any], keys: Iterable[str]) -> dict[str, Any]:
        """The stored values of the present ``keys`` of a root map (edges or edge_attrs), in one transaction."""
        with self._read() as raw_txn:
            root = root_map.integrated
            return {key: root.get(raw_txn, key) for key in keys if root.has(raw_txn, key)}

    def is_deleted(self, key: str) -> bool:
        return key in self.deleted

    def edge_attr_values(self, key: str, attrs: set[str]) -> dict[str, Any]:
        """The stored values of some attributes of one edge, in one transaction."""
        with self._read() as raw_txn:
            root = self.edge_attrs.integrated
            return {attr: root.get(raw_txn, flat) for attr in attrs if root.has(raw_txn, flat := f"{key}.{attr}")}

    # -- writes (call inside a transaction) ----------------------------------

    def create_node(self, key: str, node_type: str, name: str, attrs: dict[str, Any]) -> None:
        self.nodes[key] = Map({TYPE_KEY: node_type, NAME_KEY: name, **attrs})

    def set_node_attrs(self, key: str, attrs: dict[str, Any]) -> bool:
        """Write plain values into a node's map (a tuple as a list); False if the document holds no such node map."""
        txn, root = self._txn, self.nodes.integrated
        try:
            node = root.get(txn, key)
        except ValueError:  # pycrdt's "Key error"
            return False
        if type(node) is not type(root):
            return False
        for attr, value in attrs.items():
            node.insert(txn, attr, list(value) if type(value) is tuple else value)
        return True

    def write_node_attrs(self, key: str, attrs: dict[str, Any], origin: Any) -> bool:
        """:meth:`set_node_attrs` in a transaction of its own, attributed to ``origin`` (the common write, in one call)."""
        outer = self.current_origin, self._txn
        self.current_origin, self._full = origin, None
        try:
            with self.doc.transaction() as txn:
                self._txn = txn._txn
                return self.set_node_attrs(key, attrs)
        finally:
            self.current_origin, self._txn = outer

    def delete_node_attr(self, key: str, attr: str) -> None:
        node = self.nodes[key]
        if attr in node:
            del node[attr]

    def delete_node(self, key: str) -> None:
        del self.nodes[key]
        self.deleted[key] = True

    def set_edge(self, key: str, attrs: dict[str, Any]) -> None:
        txn, edges = self._txn, self.edges.integrated
        if not edges.has(txn, key) or edges.get(txn, key) is not True:  # absent, or overwritten by a peer
            edges.insert(txn, key, True)
        flat = self.edge_attrs.integrated
        for attr, value in attrs.items():
            flat.insert(txn, f"{key}.{attr}", value)

    def delete_edge_attrs(self, key: str, attrs: set[str]) -> None:
        for attr in attrs:
            flat = f"{key}.{attr}"
            if flat in self.edge_attrs:
                del self.edge_attrs[flat]

    def delete_edge(self, key: str, attrs: set[str]) -> None:
        if key in self.edges:
            del self.edges[key]
        self.delete_edge_attrs(key, attrs)

    # -- sync ----------------------------------------------------------------

    def state_vector(self) -> bytes:
        return self.doc.get_state()

    def diff(self, state_vector: bytes | None = None) -> bytes:
        """The update that brings a replica with ``state_vector`` up to date (everything if None).

        The whole state is kept once computed, until the next transaction, so
        that a member answering several joiners (``wm serve``) encodes it once.
        """
        if not state_vector or state_vector == EMPTY_STATE_VECTOR:
            if self._full is None:
                self._full = self.doc.get_update()
            return self._full
        try:
            return self.doc.get_update(state_vector)
        except BaseException as exc:
            if isinstance(exc, Exception) or _is_panic(exc):
                raise DecodeError(f"malformed state vector: {exc}") from None
            raise

    def apply(self, update: bytes, origin: Any) -> None:
        """Apply a remote update; malformed bytes raise :class:`DecodeError` and change nothing."""
        try:
            with self.transaction(origin):
                self.doc._doc.apply_update(self._txn, update)  # in our transaction, without pycrdt's wrapper around it
        except BaseException as exc:
            if isinstance(exc, Exception) or _is_panic(exc):
                raise DecodeError(f"malformed CRDT update: {exc}") from None
            raise

    def apply_unobserved(self, update: bytes, origin: Any) -> None:
        """Apply an update without recording which keys it touched (the caller rebuilds the index)."""
        self._unobserve()
        try:
            self.apply(update, origin)
        finally:
            self._observe()
            self.take_changes()

    def observe_updates(self, callback: Callable[[bytes, Any], None]) -> Any:
        """Call ``callback(update, origin)`` after every transaction that changed the document."""

        def on_transaction(event: TransactionEvent) -> None:
            callback(event.update, self.current_origin)

        return self.doc.observe(on_transaction)

    def unobserve_updates(self, subscription: Any) -> None:
        """Drop a callback added with :meth:`observe_updates`."""
        self.doc.unobserve(subscription)


def _head(raw_txn: Any, node: Any) -> tuple[Any, Any]:
    """A node map's ``@type`` and ``@name`` as stored, None where missing (pycrdt's raw get raises ValueError)."""
    try:
        node_type = node.get(raw_txn, TYPE_KEY)
    except ValueError:
        node_type = None
    try:
        name = node.get(raw_txn, NAME_KEY)
    except ValueError:
        name = None
    return node_type, name
