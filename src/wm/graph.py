"""``wm.Graph``: the working-memory graph of one replica.

This is the public face of the library. It validates every write against the
ontology, writes durable attributes one key at a time into the CRDT document
(:mod:`wm.crdt_store`) and volatile ones into last-writer-wins registers
(:mod:`wm.volatile`), keeps the local index up to date (:mod:`wm.index`) and
publishes typed events (:mod:`wm.events`). Reads return immutable snapshots,
kept until a change touches their element (every remote transaction drops
them all: pycrdt does not report every change a remote update makes).

It knows nothing of the network: :mod:`wm.net.replication` moves its updates.
A Graph is not thread-safe; use it from one thread (the asyncio loop).
"""

from __future__ import annotations

import gc
import logging
import math
from collections import Counter
from collections.abc import Callable, Iterable, Iterator, Mapping
from contextlib import AbstractContextManager, contextmanager
from dataclasses import replace
from pathlib import Path
from typing import TYPE_CHECKING, Any

import msgpack

from . import scene_json
from .crdt_store import NAME_KEY, TYPE_KEY, CrdtStore, RawChanges
from .errors import (
    DecodeError,
    EdgeNotFoundError,
    NameExistsError,
    NodeExistsError,
    NodeNotFoundError,
    ValidationError,
)
from .events import Event, EventFilter, EventHub, EventKind, EventStream, Subscription
from .ids import IdAllocator
from .index import GraphIndex, IndexResult
from .limits import CONFLICT_SUFFIX_ROOM, FLOAT_BYTES
from .model import Edge, Node, edge_key, freeze
from .ontology import MAX_EXACT_INT, ElementType, Ontology, Value
from .rt import RTApi
from .view_rules import LeftOut, ViewRules
from .volatile import Record, VolatileStore, check_records, edge_owner, node_owner

if TYPE_CHECKING:
    from .net.replication import Replicator

NodeRef = int | str
SNAPSHOT_VERSION = 1
log = logging.getLogger(__name__)


class Graph:
    """A typed graph replica: nodes with unique names, edges keyed by (src, dst, type)."""

    def __init__(
        self, ontology: Ontology | None = None, *, replica_id: str | None = None, id_prefix: int | None = None
    ) -> None:
        """``id_prefix`` fixes the creator prefix of new ids (reproducible tests); by default it is random."""
        self.ontology = ontology if ontology is not None else Ontology.default()
        self._ids = IdAllocator(id_prefix)
        self.replica_id = replica_id or f"{self._ids.prefix:08x}"
        self._store = CrdtStore()
        self._rules = ViewRules(self.ontology)
        self._index = GraphIndex(self._rules)
        self.refused_volatile: Counter[str] = Counter()  # writer -> volatile records refused by the view rules
        self._volatile = VolatileStore(self.replica_id)
        self._hub = EventHub()
        self._depth = 0
        self._pending: list[Event] = []
        self._shared: AbstractContextManager[None] | None = None  # a batch's open transaction
        self._write_listeners: list[Callable[[], None]] = []
        self._members: dict[str, str] = {}
        self._checks = _WriteChecks(self.ontology)
        self._node_cache: dict[int, Node] = {}
        self._edge_cache: dict[str, Edge] = {}
        self.network: Replicator | None = None  # set while connected, see wm.connect
        self.rt = RTApi(self)

    # -- transactions and events --------------------------------------------

    @contextmanager
    def batch(self) -> Iterator[None]:
        """Group writes: attribute writes share one CRDT transaction and events wait for the end.

        Writes inside the block are visible to reads at once. Structural writes
        (creating or deleting nodes and edges, renames) commit the shared
        transaction first, so ids and names resolve straight away. Do not
        ``await`` inside a batch: a transaction must not span an await.
        """
        self._depth += 1
        outermost = self._depth == 1
        if outermost:
            self._open_shared_transaction()
        try:
            yield
        finally:
            self._depth -= 1
            if outermost:
                self._commit_shared_transaction()
                self._flush_events()

    def _open_shared_transaction(self) -> None:
        self._shared = self._store.transaction(self.replica_id)
        self._shared.__enter__()

    def _commit_shared_transaction(self) -> None:
        shared, self._shared = self._shared, None
        if shared is not None:
            shared.__exit__(None, None, None)
            self._settle(self.replica_id, local=True)

    def _transaction(self, crdt: bool = True, structural: bool = False) -> AbstractContextManager[None]:
        """One local write. ``crdt=False`` skips the CRDT transaction for volatile-only writes.

        Inside a batch, an attribute write joins the batch's shared transaction
        (settled when the batch ends); a structural one commits it first and
        reopens it after.
        """
        return _LocalWrite(self, crdt, structural)

    def _settle(self, writer: str, local: bool) -> None:
        """Turn what the last transaction touched into index updates and events, then repair."""
        changes = self._store.take_changes()
        repairs = [self._apply_to_index(changes, writer, local)]
        if not local and (changes.unreliable or self._index.out_of_step(self._store)):
            repairs.append(self._apply_to_index(self._index.missed_changes(self._store), writer, local))
        self._repair(repairs, writer)
        if local:
            self._wrote()
        elif self._depth == 0:
            self._flush_events()

    def reconcile(self) -> None:
        """Compare the whole index with the document and publish what differed (replication calls it now and then)."""
        self._repair(
            [self._apply_to_index(self._index.missed_changes(self._store), "reconcile", local=False)], "reconcile"
        )
        if self._depth == 0:
            self._flush_events()

    def _apply_to_index(
        self, changes: RawChanges, writer: str, local: bool, check_values: bool = True, describe: bool = True
    ) -> IndexResult | None:
        """Update the index and queue the events; the repairs it calls for come after, from :meth:`_repair`."""
        if not changes:
            return None
        self._forget_snapshots(changes, local)
        wants = self._hub.wants
        result = self._index.apply(
            self._store, changes, writer, local, self._volatile_attr_names, wants, check_values, describe
        )
        self._take(result, writer)
        return result

    def _take(self, result: IndexResult, writer: str) -> None:
        """Log what the index left out, forget the registers of removed elements, queue the events."""
        if result.left_out:
            first = result.left_out[0]
            log.warning(
                "left out %d entr%s of the document sent by %s, e.g. %s",
                len(result.left_out),
                "y" if len(result.left_out) == 1 else "ies",
                writer,
                first,
            )
        for node_id in result.removed_nodes:
            self._volatile.drop_owner(node_owner(node_id))
        for key in result.removed_edges:
            self._volatile.drop_owner(edge_owner(key))
        self._pending.extend(result.events)

    def _repair(self, results: list[IndexResult | None], writer: str) -> None:
        """Delete dangling edge markers and rename the losers of name conflicts, once the index is right."""
        dangling = [key for r in results if r for key in r.dangling_edges]
        conflicts = [name for r in results if r for name in r.name_conflicts]
        if dangling:
            self._delete_dangling(dangling)
        if conflicts:
            self._rename_losers(conflicts, writer)

    def _forget_snapshots(self, changes: RawChanges, local: bool) -> None:
        """Drop the cached snapshots of what changed: every one after a remote transaction, else those named."""
        if not local or changes.unreliable or changes.malformed_edge_attrs:
            self._node_cache.clear()
            self._edge_cache.clear()
            return
        nodes, edges = self._node_cache, self._edge_cache
        if nodes:
            for key in (*changes.nodes_added, *changes.nodes_removed, *changes.node_attrs):
                if key.isdecimal():
                    nodes.pop(int(key), None)
                else:
                    nodes.clear()
                    break
        if edges:
            for key in (*changes.edges_added, *changes.edges_removed, *changes.edge_attrs):
                edges.pop(key, None)

    def _flush_events(self) -> None:
        events, self._pending = self._pending, []
        if events and self._hub.has_consumers:
            self._hub.publish(_coalesce(events))

    def _volatile_attr_names(self, owner: str) -> Iterable[str]:
        return self._volatile.values(owner).keys()

    def events(
        self,
        kind: str | Iterable[str] | None = None,
        type: str | Iterable[str] | None = None,
        name: str | Iterable[str] | None = None,
        maxsize: int = 4096,
    ) -> EventStream:
        """An async iterator of matching events; when ``maxsize`` are pending the oldest is dropped."""
        return self._hub.stream(EventFilter.of(kind, type, name), maxsize)

    def on(
        self,
        callback: Callable[[Event], object],
        kind: str | Iterable[str] | None = None,
        type: str | Iterable[str] | None = None,
        name: str | Iterable[str] | None = None,
    ) -> Subscription:
        """Call ``callback(event)`` for every matching event, after the change is complete."""
        return self._hub.subscribe(callback, EventFilter.of(kind, type, name))

    def members(self) -> dict[str, str]:
        """Replica id -> agent name of every live replica of this graph that this one knows of."""
        return dict(self._members) if self._members else {self.replica_id: "local"}

    def note_member(self, replica: str, agent: str, joined: bool) -> None:
        """Record a replica joining or leaving (called by replication) and publish the event."""
        if joined == (replica in self._members):
            return
        if joined:
            self._members[replica] = agent
        else:
            self._members.pop(replica, None)
        kind = EventKind.MEMBER_JOINED if joined else EventKind.MEMBER_LEFT
        self._hub.publish([Event(kind, "member", replica, replica == self.replica_id, name=agent)])

    @property
    def callback_errors(self) -> int:
        return self._hub.callback_errors

    def left_out(self) -> list[LeftOut]:
        """Every entry of the document that this replica's view leaves out, now (a full scan).

        Each entry names the replica whose message brought it when this replica
        saw it arrive, else ``"unknown"`` (a catch-up, or a read from disk).
        """
        recorded = self._index.left_out.entries
        found = [entry for (kind, _), entry in recorded.items() if kind in ("node", "edge")]

        def entry(kind: str, key: str, problem: str) -> LeftOut:
            seen = recorded.get((kind, key))
            return LeftOut(kind, key, problem, seen.writer if seen is not None else "unknown")

        heads = self._store.read_nodes([str(node_id) for node_id in self._index.node_meta])
        stored = self._store.read_node_attrs(
            {key: content.attrs for key, content in heads.items() if content is not None}
        )
        for key, values in stored.items():
            element = self.ontology.node_types[self._index.node_meta[int(key)][0]]
            for attr, value in values.items():
                problem = self._rules.attr_problem(element, attr, value)
                if problem is not None:
                    found.append(entry("node_attr", f"{key}.{attr}", problem))
        for flat_key, value in self._store.read_flat(self._store.edge_attrs, self._store.edge_attrs.keys()).items():
            key, dot, attr = flat_key.rpartition(".")
            parsed = self._rules.edge_parts(key) if dot else None
            if parsed is None:
                found.append(
                    entry(
                        "edge_attr",
                        flat_key,
                        'the key is not "src>dst>type.attribute" with node ids and a known edge type',
                    )
                )
                continue
            problem = self._rules.attr_problem(self.ontology.edge_types[parsed[2]], attr, value)
            if problem is not None:
                found.append(entry("edge_attr", flat_key, problem))
        return sorted(found, key=lambda e: (e.kind, e.key))

    def delete_left_out(self, entries: Iterable[LeftOut]) -> None:
        """Delete from the document entries the view leaves out (``wm check --repair``).

        These are ordinary CRDT deletes, made by this replica, that every other
        replica receives; entries that are no longer there are skipped.
        """
        roots = {"node": self._store.nodes, "edge": self._store.edges, "edge_attr": self._store.edge_attrs}
        with self._transaction(structural=True):
            for entry in entries:
                if entry.kind == "node_attr":
                    node_key, _, attr = entry.key.partition(".")
                    if self._store.node_map(node_key) is not None:
                        self._store.delete_node_attr(node_key, attr)
                elif entry.key in roots[entry.kind]:
                    del roots[entry.kind][entry.key]

    def left_out_by_writer(self) -> dict[str, int]:
        """Writer -> how many document entries and volatile records it sent that the view left out (since start)."""
        return dict(self._index.left_out.by_writer + self.refused_volatile)

    # -- nodes ---------------------------------------------------------------

    def insert_node(self, type: str, name: str | None = None, attrs: Mapping[str, Any] | None = None) -> int:
        """Create a node and return its new id. Its name must be unique (default ``<type>_<id>``)."""
        element = self.ontology.node_type(type)
        values = self._checks.split(element, attrs)
        if name is not None:
            self.check_new_name(name)
        node_id = self._ids.next_id(self.id_taken)
        self._create_node(node_id, element, name if name is not None else f"{type}_{node_id}", *values)
        return node_id

    def id_taken(self, node_id: int) -> bool:
        """Whether ``node_id`` belongs to a live node or to a deleted one (ids are never reused)."""
        return node_id in self._index.node_meta or self._store.is_deleted(str(node_id))

    def check_new_id(self, node_id: int) -> None:
        """Refuse an explicit node id (scene import) that is malformed, live or deleted."""
        if isinstance(node_id, bool) or not isinstance(node_id, int) or not 0 < node_id < 2**53:
            raise ValidationError(f"a node id is an int in 1..2**53, got {node_id!r}")
        if self.id_taken(node_id):
            raise NodeExistsError(f"node id {node_id} is in use or was deleted")

    def check_new_name(self, name: str) -> None:
        """Refuse a name that is malformed, too long or already taken."""
        problem = self.ontology.limits.name_problem(name)
        if problem is not None:
            raise ValidationError(f"{problem}, got {name!r:.80}")
        if self._index.resolve_name(name) is not None:
            raise NameExistsError(f"a node named {name!r} already exists")

    def _create_node(
        self, node_id: int, element: ElementType, name: str, durable: dict[str, Value], volatile: dict[str, Value]
    ) -> None:
        key = str(node_id)
        with self._transaction(structural=True):
            self._store.create_node(key, element.name, name, _to_crdt(durable))
            for attr, value in volatile.items():
                self._volatile.write(node_owner(node_id), attr, value)

    def update_node(self, ref: NodeRef, attrs: Mapping[str, Any]) -> None:
        """Write the given attributes, one by one; attributes not named are left as they are."""
        node_id = self.resolve(ref)
        durable, volatile = self._checks.split(self.ontology.node_types[self._index.node_meta[node_id][0]], attrs)
        if self._shared is None and not self._store.pending:  # the common writes, without the general machinery
            if durable and not volatile:
                self._write_node_attrs(node_id, durable)
                return
            if volatile and not durable:
                self._write_volatile(node_owner(node_id), volatile)
                self._wrote()
                return
        written = True
        with self._transaction(crdt=bool(durable)):
            if durable:
                written = self._store.set_node_attrs(str(node_id), durable)
            if volatile and written:
                self._write_volatile(node_owner(node_id), volatile)
        if not written:
            self._lost_node(node_id)

    def _write_node_attrs(self, node_id: int, values: dict[str, Value]) -> None:
        """The common write, durable attributes of one node outside a batch, settled without the general diff.

        When the transaction reports anything but attributes of this node (a
        name, or changes left pending by a failed write), it settles as usual.
        """
        key, store = str(node_id), self._store
        written = store.write_node_attrs(key, values, self.replica_id)
        pending = store.pending
        attrs = pending.node_attrs.get(key)
        if (
            not written
            or attrs is None
            or NAME_KEY in attrs
            or TYPE_KEY in attrs
            or len(pending.node_attrs) > 1
            or pending.nodes_added
            or pending.nodes_removed
            or pending.edges_added
            or pending.edges_removed
            or pending.edge_attrs
            or pending.malformed_edge_attrs
        ):
            self._settle(self.replica_id, local=True)
            if not written:
                self._lost_node(node_id)
            return
        pending.node_attrs = {}
        self._node_cache.pop(node_id, None)
        event = self._index.local_node_update(key, attrs, self.replica_id, self._hub.wants)
        if event is not None:
            self._pending.append(event)
        self._wrote()

    def _wrote(self) -> None:
        """After a local write settled by its caller: tell the write listeners, publish the events."""
        for listener in self._write_listeners:
            listener()
        if self._depth == 0:
            self._flush_events()

    def delete_attr(self, ref: NodeRef, attr: str) -> None:
        """Remove one attribute of a node (a no-op if it is not set)."""
        node_id = self.resolve(ref)
        element = self.ontology.node_type(self._index.node_meta[node_id][0])
        spec = self.ontology.attribute_for(element, attr)
        if not spec.volatile:
            self._check_in_document(node_id)
        with self._transaction(crdt=not spec.volatile):
            if spec.volatile:
                if self._volatile.has(node_owner(node_id), attr):
                    self._write_volatile(node_owner(node_id), {attr: None})
            else:
                self._store.delete_node_attr(str(node_id), attr)

    def rename_node(self, ref: NodeRef, new_name: str) -> None:
        node_id = self.resolve(ref)
        self.check_new_name(new_name)
        self._check_in_document(node_id)
        with self._transaction(structural=True):
            self._store.set_node_attrs(str(node_id), {NAME_KEY: new_name})

    def delete_node(self, ref: NodeRef) -> None:
        """Delete a node and every edge to or from it. The id is never used again."""
        node_id = self.resolve(ref)
        self._check_in_document(node_id)
        with self._transaction(structural=True):
            for key in self._index.edges_of(node_id):
                self._store.delete_edge(key, self._index.edge_attr_names.get(key, set()))
            self._store.delete_node(str(node_id))

    def _check_in_document(self, node_id: int) -> None:
        """Before writing into a node's map: if a remote change removed it unreported, catch up and refuse."""
        if not self._store.has_node(str(node_id)):
            self._lost_node(node_id)

    def _lost_node(self, node_id: int) -> None:
        self.reconcile()
        raise NodeNotFoundError(f"node {node_id} was deleted")

    def resolve(self, ref: NodeRef) -> int:
        """The id of a live node given its id or name."""
        if isinstance(ref, bool) or not isinstance(ref, (int, str)):
            raise NodeNotFoundError(f"a node is referred to by int id or str name, got {type(ref).__name__}")
        if isinstance(ref, int):
            if ref in self._index.node_meta:
                return ref
            raise NodeNotFoundError(f"no node with id {ref}")
        node_id = self._index.resolve_name(ref)
        if node_id is None:
            raise NodeNotFoundError(f"no node named {ref!r}")
        return node_id

    def get_node(self, ref: NodeRef) -> Node:
        """A snapshot of the node; raises :class:`NodeNotFoundError`."""
        return self._node_snapshot(self.resolve(ref))

    def find_node(self, ref: NodeRef) -> Node | None:
        """A snapshot of the node, or None if there is no such node."""
        try:
            return self.get_node(ref)
        except NodeNotFoundError:
            return None

    def nodes(self, type: str | None = None) -> list[Node]:
        """Snapshots of every live node, or of one type, in id order."""
        ids = self._index.node_meta if type is None else self._index.by_type.get(type, ())
        return [self._node_snapshot(node_id) for node_id in sorted(ids)]

    def node_count(self) -> int:
        return len(self._index.node_meta)

    def _node_snapshot(self, node_id: int) -> Node:
        cached = self._node_cache.get(node_id)
        if cached is not None and self._shared is None:
            return cached
        node_type, name = self._index.node_meta[node_id]
        element = self.ontology.node_types[node_type]
        stored = self._store.node_values(str(node_id)) or {}
        decode, fits = self.ontology.decode, self._rules.attr_fits
        # the view rules, on every read: a peer's value that does not fit is never shown (docs/replication.md)
        attrs = {k: decode(k, v) for k, v in stored.items() if fits(element, k, v)}
        for attr, value in self._volatile.values(node_owner(node_id)).items():
            if attr in element.attributes:
                attrs[attr] = decode(attr, value)
        node = Node(node_id, node_type, name, freeze(attrs))
        if self._shared is None:  # inside a batch, what changed is known only when it commits
            self._node_cache[node_id] = node
        return node

    # -- edges ---------------------------------------------------------------

    def insert_or_assign_edge(
        self, src: NodeRef, dst: NodeRef, type: str, attrs: Mapping[str, Any] | None = None
    ) -> None:
        """Create the edge if needed and write the given attributes, one by one."""
        src_id, dst_id = self.resolve(src), self.resolve(dst)
        durable, volatile = self._checks.split(self.ontology.edge_type(type), attrs)
        key = edge_key(src_id, dst_id, type)
        if type == "RT" and key not in self._index.visible:  # re-assigning a pose cannot change the tree
            self.rt.check_new_edge(src_id, dst_id)
        new_edge = key not in self._index.markers
        with self._transaction(crdt=bool(durable) or new_edge, structural=new_edge):
            if durable or new_edge:
                self._store.set_edge(key, _to_crdt(durable))
                self._index.note_edge_attrs(key, durable)
            if volatile:
                self._write_volatile(edge_owner(key), volatile)

    def get_edge(self, src: NodeRef, dst: NodeRef, type: str) -> Edge:
        key = self._visible_edge_key(src, dst, type)
        return self._edge_snapshot(key)

    def find_edge(self, src: NodeRef, dst: NodeRef, type: str) -> Edge | None:
        try:
            return self.get_edge(src, dst, type)
        except (EdgeNotFoundError, NodeNotFoundError):
            return None

    def delete_edge(self, src: NodeRef, dst: NodeRef, type: str) -> None:
        key = self._visible_edge_key(src, dst, type)
        with self._transaction(structural=True):
            self._store.delete_edge(key, self._index.edge_attr_names.get(key, set()))

    def delete_edge_attr(self, src: NodeRef, dst: NodeRef, type: str, attr: str) -> None:
        key = self._visible_edge_key(src, dst, type)
        spec = self.ontology.attribute_for(self.ontology.edge_type(type), attr)
        with self._transaction(crdt=not spec.volatile):
            if spec.volatile:
                if self._volatile.has(edge_owner(key), attr):
                    self._write_volatile(edge_owner(key), {attr: None})
            else:
                self._store.delete_edge_attrs(key, {attr})

    def edges(self, type: str | None = None, src: NodeRef | None = None, dst: NodeRef | None = None) -> list[Edge]:
        """Snapshots of the visible edges matching every given filter."""
        index = self._index
        candidates: set[str] | None = None
        if src is not None:
            candidates = index.out_edges.get(self.resolve(src), set())
        if dst is not None:
            incoming = index.in_edges.get(self.resolve(dst), set())
            candidates = incoming if candidates is None else candidates & incoming
        if type is not None:
            of_type = index.edge_type.get(type, set())
            candidates = of_type if candidates is None else candidates & of_type
        keys = index.visible if candidates is None else candidates & index.visible
        return [self._edge_snapshot(key) for key in sorted(keys, key=index.markers.__getitem__)]

    def _visible_edge_key(self, src: NodeRef, dst: NodeRef, edge_type: str) -> str:
        key = edge_key(self.resolve(src), self.resolve(dst), edge_type)
        if key not in self._index.visible:
            raise EdgeNotFoundError(f"no edge {src!r} -[{edge_type}]-> {dst!r}")
        return key

    def _edge_snapshot(self, key: str) -> Edge:
        cached = self._edge_cache.get(key)
        if cached is not None and self._shared is None:
            return cached
        src, dst, edge_type = self._index.markers[key]
        element = self.ontology.edge_types[edge_type]
        decode, fits = self.ontology.decode, self._rules.attr_fits
        stored = self._store.edge_attr_values(key, self._index.edge_attr_names.get(key, set()))
        attrs = {k: decode(k, v) for k, v in stored.items() if fits(element, k, v)}
        for attr, value in self._volatile.values(edge_owner(key)).items():
            if attr in element.attributes:
                attrs[attr] = decode(attr, value)
        edge = Edge(src, dst, edge_type, freeze(attrs))
        if self._shared is None:
            self._edge_cache[key] = edge
        return edge

    # -- shared write helpers ------------------------------------------------

    def _write_volatile(self, owner: str, values: Mapping[str, Any]) -> None:
        for attr, value in values.items():
            self._volatile.write(owner, attr, value)
        self._forget_owner(owner)
        if self._hub.has_consumers:
            self._pending.extend(
                self._index.volatile_events([(owner, a) for a in values], self.replica_id, True, self._hub.wants)
            )

    def _forget_owner(self, owner: str) -> None:
        """Drop the cached snapshot of a volatile register's owner (``n:<id>`` or ``e:<key>``)."""
        if owner[0] == "n":
            self._node_cache.pop(int(owner[2:]), None)
        else:
            self._edge_cache.pop(owner[2:], None)

    def _delete_dangling(self, keys: list[str]) -> None:
        with self._transaction(structural=True):
            for key in keys:
                if key in self._store.edges:
                    self._store.delete_edge(key, self._index.edge_attr_names.get(key, set()))

    def _rename_losers(self, names: list[str], writer: str) -> None:
        """Every replica renames the same losers to the same names, so the repair converges.

        The lowest id keeps the name (docs/replication.md, "Names"). A loser's
        new name is ``<name>~<id>``, the name cut short if needed to stay
        within the name limit. ``writer`` sent the change that showed the conflict.
        """
        room = self.ontology.limits.max_name_length - CONFLICT_SUFFIX_ROOM
        with self._transaction(structural=True):
            for name in dict.fromkeys(names):
                ids = sorted(self._index.names.get(name, ()))
                for loser in ids[1:]:
                    new_name = f"{name[:room]}~{loser}"
                    log.warning(
                        "name %r: node %d keeps it, node %d is renamed %r (conflict shown by a change from %s)",
                        name,
                        ids[0],
                        loser,
                        new_name,
                        writer,
                    )
                    self._store.set_node_attrs(str(loser), {NAME_KEY: new_name})

    # -- replication hooks (used by wm.net.replication and wm.persistence) --------

    def state_vector(self) -> bytes:
        return self._store.state_vector()

    def diff(self, state_vector: bytes | None = None) -> bytes:
        """The CRDT update a replica with ``state_vector`` lacks (all of it when None)."""
        return self._store.diff(state_vector)

    def apply_update(self, update: bytes, writer: str) -> None:
        """Apply a CRDT update received from replica ``writer``; malformed bytes raise DecodeError."""
        try:
            self._store.apply(update, origin=writer)
        finally:
            self._settle(writer, local=False)

    def add_write_listener(self, listener: Callable[[], None]) -> None:
        """Call ``listener()`` after every local write (durable or volatile)."""
        self._write_listeners.append(listener)

    def remove_write_listener(self, listener: Callable[[], None]) -> None:
        """Stop calling a listener added with :meth:`add_write_listener` (a no-op if it is not there)."""
        if listener in self._write_listeners:
            self._write_listeners.remove(listener)

    def is_fresh(self) -> bool:
        """Whether this replica holds nothing yet (no write made, no update applied)."""
        return self._store.is_empty()

    def load_fresh(self, update: bytes, writer: str) -> None:
        """Catch a fresh replica up: apply a full update unobserved, then build the index from the document.

        Reporting the keys of thousands of new nodes one by one costs more than
        reading the document once; the index is built from it with the view
        rules (attribute values are checked when read, see :meth:`left_out`),
        in one pass over the node maps when nobody listens yet (the common
        case: ``wm.connect`` catches up before it hands the graph over).
        """
        if not self.is_fresh():
            self.apply_update(update, writer)
            return
        self._store.apply_unobserved(update, writer)
        self._node_cache.clear()
        self._edge_cache.clear()
        collecting = gc.isenabled()
        gc.disable()  # the index adds tens of thousands of objects without cycles: full collections would only rescan them
        try:
            if self._hub.has_consumers:  # their node_added events name attributes: the general diff reads them
                result = self._apply_to_index(
                    self._index.missed_changes(self._store), writer, False, check_values=False
                )
            else:
                result = self._index.load(self._store, writer, self._volatile_attr_names, self._hub.wants)
                self._take(result, writer)
        finally:
            if collecting:
                gc.enable()
        self._repair([result], writer)
        if self._depth == 0:
            self._flush_events()

    def observe_updates(self, callback: Callable[[bytes, Any], None]) -> Any:
        """``callback(update, origin)`` after every transaction; origin is the writer's replica id.

        Returns the subscription for :meth:`unobserve_updates`. Until then the document holds the callback
        (and whatever it refers to, this graph included) out of reach of Python's garbage collector.
        """
        return self._store.observe_updates(callback)

    def unobserve_updates(self, subscription: Any) -> None:
        """Drop a callback added with :meth:`observe_updates`."""
        self._store.unobserve_updates(subscription)

    def take_volatile_outbox(self) -> list[Record]:
        return self._volatile.take_outbox()

    def track_volatile_changes(self) -> None:
        """Remember which volatile registers change (for persistence)."""
        self._volatile.track_changes()

    def take_volatile_changes(self) -> list[Record]:
        return self._volatile.take_changes()

    def volatile_records(self) -> list[Record]:
        return self._volatile.records()

    def merge_volatile(self, records: Iterable[Record], writer: str) -> None:
        """Merge volatile registers received from ``writer`` (records of deleted nodes are ignored)."""
        accepted = []
        live = self._index.node_meta
        problem = self._rules.volatile_problem
        refused: list[str] = []
        for record in records:
            owner, attr, value = record[0], record[1], record[2]
            why = problem(owner, attr, value)
            if why is not None:
                refused.append(why)
                continue
            if owner.startswith("n:"):
                ident = owner[2:]
                # a live node is not deleted; only others need the (slower) look-up in the document
                if int(ident) not in live and self._store.is_deleted(ident):
                    continue
            accepted.append(record)
        if refused:
            self.refused_volatile[writer] += len(refused)
            log.warning("refused %d volatile record(s) from %s, e.g. %s", len(refused), writer, refused[0])
        changed = self._volatile.merge(accepted)
        for owner, _ in changed:
            self._forget_owner(owner)
        if changed and self._hub.has_consumers:
            self._pending.extend(self._index.volatile_events(changed, writer, False, self._hub.wants))
            if self._depth == 0:
                self._flush_events()

    def prune_volatile(self, older_than: float = 30.0) -> int:
        """Forget registers of elements that no longer exist; returns how many owners were dropped."""

        def alive(owner: str) -> bool:
            kind, ident = owner.split(":", 1)
            return int(ident) in self._index.node_meta if kind == "n" else ident in self._index.markers

        return self._volatile.prune(alive, older_than)

    def encode_state(self) -> bytes:
        """The whole replica (CRDT state and volatile registers) as one byte string."""
        packed: bytes = msgpack.packb(
            {"v": SNAPSHOT_VERSION, "crdt": self._store.diff(), "volatile": self._volatile.records()}, use_bin_type=True
        )
        return packed

    def load_state(self, data: bytes, writer: str = "snapshot") -> None:
        """Merge a byte string made by :meth:`encode_state` (into an empty or a live replica)."""
        try:
            snapshot = msgpack.unpackb(data, raw=False)
            crdt, records = snapshot["crdt"], check_records(snapshot["volatile"])
        except DecodeError:
            raise
        except Exception as exc:
            raise DecodeError(f"not a cortex-wm snapshot: {exc}") from None
        self.apply_update(crdt, writer)
        self.merge_volatile(records, writer)

    # -- JSON ----------------------------------------------------------------

    def to_dict(self) -> dict[str, Any]:
        return scene_json.graph_to_dict(self)

    def to_json(self, indent: int | None = 2) -> str:
        return scene_json.dumps(self.to_dict(), indent)

    def load_json(self, source: str | Path | Mapping[str, Any], *, keep_ids: bool = True) -> scene_json.LoadReport:
        """Insert a scene in our JSON format or DSR's (``{"DSRModel": {"symbols": ...}}``)."""
        return scene_json.load_into(self, source, keep_ids=keep_ids)

    def insert_node_with_id(self, node_id: int, type: str, name: str, attrs: Mapping[str, Any] | None = None) -> None:
        """Create a node with a given id (scene import). A live or deleted id is refused."""
        self.check_new_id(node_id)
        element = self.ontology.node_type(type)
        values = self._checks.split(element, attrs)
        self.check_new_name(name)
        self._create_node(node_id, element, name, *values)


class _LocalWrite:
    """:meth:`Graph._transaction` (a class: a generator-based context manager costs more per write)."""

    __slots__ = ("graph", "crdt", "structural", "joined", "reopen", "txn")

    def __init__(self, graph: Graph, crdt: bool, structural: bool) -> None:
        self.graph, self.crdt, self.structural = graph, crdt, structural

    def __enter__(self) -> None:
        graph = self.graph
        self.joined = graph._shared is not None and not self.structural
        if self.joined:
            return
        self.reopen = graph._shared is not None
        if self.reopen:
            graph._commit_shared_transaction()
        self.txn = graph._store.transaction(graph.replica_id) if self.crdt else None
        if self.txn is not None:
            try:
                self.txn.__enter__()
            except BaseException:
                if self.reopen:
                    graph._open_shared_transaction()
                raise

    def __exit__(self, exc_type: type[BaseException] | None, exc: BaseException | None, tb: Any) -> None:
        if self.joined:
            return
        graph = self.graph
        try:
            if self.txn is not None:
                self.txn.__exit__(exc_type, exc, tb)
            if exc_type is None:
                graph._settle(graph.replica_id, local=True)
        finally:
            if self.reopen:
                graph._open_shared_transaction()


class _WriteChecks:
    """How each attribute of each type is checked on write: a table precompiled per type, on first use.

    A value already in the form it is stored in goes through at once (a finite
    float, an int within 2**53, a bool, a tuple of finite floats of the right
    length); anything else goes through :meth:`wm.Ontology.check_attrs`, which
    coerces it or raises, so the outcome is the same.
    """

    def __init__(self, ontology: Ontology) -> None:
        self.ontology = ontology
        self._max_vec = ontology.limits.max_value_bytes // FLOAT_BYTES
        # (kind, type name) -> attribute -> (type stored as is or None, NaN allowed, volatile, vector length)
        self._tables: dict[tuple[str, str], dict[str, tuple[type | None, bool, bool, int | None]]] = {}

    def split(self, element: ElementType, attrs: Mapping[str, Any] | None) -> tuple[dict[str, Value], dict[str, Value]]:
        """The checked values of a write on an element of type ``element``, durable ones and volatile ones."""
        if type(attrs) is not dict:
            return self._by_tier(self.ontology.check_attrs(element, attrs))
        table = self._tables.get((element.kind, element.name))
        if table is None:
            table = self._tables[(element.kind, element.name)] = self._table(element)
        durable: dict[str, Value] = {}
        volatile: dict[str, Value] = {}
        for attr, value in attrs.items():
            entry = table.get(attr)
            if entry is None:  # not allowed on this type: raises UnknownAttributeError
                self.ontology.check_attrs(element, {attr: value})
                continue
            exact, nonfinite, is_volatile, length = entry
            kind = type(value)
            if kind is not exact or not (
                kind is float
                and (nonfinite or math.isfinite(value))
                or kind is int
                and -MAX_EXACT_INT <= value <= MAX_EXACT_INT
                or kind is bool
                or kind is tuple
                and self._vector_as_is(value, nonfinite, length)
            ):
                value = self.ontology.check_attrs(element, {attr: value})[attr]
            (volatile if is_volatile else durable)[attr] = value
        return durable, volatile

    def _vector_as_is(self, value: tuple[Any, ...], nonfinite: bool, length: int | None) -> bool:
        return (
            (len(value) == length if length is not None else len(value) <= self._max_vec)
            and all(type(x) is float for x in value)
            and (nonfinite or all(map(math.isfinite, value)))
        )

    def _table(self, element: ElementType) -> dict[str, tuple[type | None, bool, bool, int | None]]:
        table = {}
        for attr in element.attributes:
            spec = self.ontology.attribute_for(element, attr)
            exact = {"float": float, "int": int, "bool": bool, "vec": tuple}.get(spec.type)
            if spec.length is not None and spec.length > self._max_vec:
                exact = None  # always too big: the ontology says why
            table[attr] = (exact, spec.nonfinite, self.ontology.is_volatile(attr), spec.length)
        return table

    def _by_tier(self, values: dict[str, Value]) -> tuple[dict[str, Value], dict[str, Value]]:
        durable: dict[str, Value] = {}
        volatile: dict[str, Value] = {}
        for attr, value in values.items():
            (volatile if self.ontology.is_volatile(attr) else durable)[attr] = value
        return durable, volatile


def _to_crdt(values: Mapping[str, Value]) -> dict[str, Any]:
    """Vectors are stored as lists; everything else as is."""
    return {k: list(v) if isinstance(v, tuple) else v for k, v in values.items()}


def _coalesce(events: list[Event]) -> list[Event]:
    """Merge repeated updates of one element within one transaction into one event."""
    if len(events) < 2:
        return events
    slots: dict[tuple[Any, ...], int] = {}
    result: list[Event] = []
    for event in events:
        if event.kind in (EventKind.NODE_UPDATED, EventKind.EDGE_UPDATED):
            key = (event.kind, event.id, event.src, event.dst, event.type)
            slot = slots.get(key)
            if slot is not None:
                result[slot] = replace(result[slot], attrs=result[slot].attrs | event.attrs)
                continue
            slots[key] = len(result)
        result.append(event)
    return result
