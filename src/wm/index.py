"""The local index of one replica: who exists, by type, by name and by endpoint.

It is rebuilt incrementally from the keys each transaction touched
(:class:`wm.crdt_store.RawChanges`) by comparing, key by key, what was visible
before with what is visible now. That comparison is what turns raw CRDT
changes, whatever their order, into typed events, and it is where the
visibility rules live:

* an edge is visible only while its marker exists **and** both its endpoints
  are live nodes, so a dangling edge left by a concurrent delete is never seen;
* a name belongs to the live node with the **lowest id** carrying it; the
  others are reported as conflicts so the graph can rename them.
"""

from __future__ import annotations

from collections.abc import Callable, Iterable
from dataclasses import dataclass, field
from typing import Any

from .crdt_store import NAME_KEY, TYPE_KEY, CrdtStore, RawChanges
from .events import Event, EventKind
from .model import parse_edge_key


@dataclass
class IndexResult:
    """What one round of changes produced."""

    events: list[Event] = field(default_factory=list)
    removed_nodes: list[int] = field(default_factory=list)
    removed_edges: list[str] = field(default_factory=list)
    dangling_edges: list[str] = field(default_factory=list)
    name_conflicts: list[str] = field(default_factory=list)


class GraphIndex:
    """Types, names and adjacency of the live graph, as this replica sees it."""

    def __init__(self) -> None:
        self.node_meta: dict[int, tuple[str, str]] = {}
        self.names: dict[str, set[int]] = {}
        self.by_type: dict[str, set[int]] = {}
        self.edge_type: dict[str, set[str]] = {}
        self.markers: dict[str, tuple[int, int, str]] = {}  # every edge marker, visible or not
        self.out_edges: dict[int, set[str]] = {}
        self.in_edges: dict[int, set[str]] = {}
        self.visible: set[str] = set()
        self.edge_attr_names: dict[str, set[str]] = {}

    # -- queries -------------------------------------------------------------

    def resolve_name(self, name: str) -> int | None:
        ids = self.names.get(name)
        return min(ids) if ids else None

    def edges_of(self, node_id: int) -> set[str]:
        return self.out_edges.get(node_id, set()) | self.in_edges.get(node_id, set())

    def node_name(self, node_id: int) -> str | None:
        meta = self.node_meta.get(node_id)
        return meta[1] if meta else None

    # -- heads: the index itself, for a replica that starts from nothing ---

    def heads(self) -> tuple[list[list[Any]], list[list[Any]]]:
        """What a fresh replica needs to rebuild this index without reading the document.

        Nodes as ``[id, type, name]``, edge markers as ``[key, [durable attribute names]]``.
        """
        nodes = [[node_id, node_type, name] for node_id, (node_type, name) in self.node_meta.items()]
        edges = [[key, sorted(self.edge_attr_names.get(key, ()))] for key in self.markers]
        return nodes, edges

    def install(self, nodes: list[list[Any]], edges: list[list[Any]], writer: str, with_events: bool) -> list[Event]:
        """Fill an empty index from :meth:`heads` of a peer; returns the *added* events (without attribute names)."""
        events = []
        for node_id, node_type, name in nodes:
            self._add_node(node_id, node_type, name)
            if with_events:
                events.append(Event(EventKind.NODE_ADDED, node_type, writer, False, frozenset(), node_id, name))
        for key, attrs in edges:
            src, dst, edge_type = self._add_marker(key)
            if attrs:
                self.edge_attr_names[key] = set(attrs)
            if src in self.node_meta and dst in self.node_meta:
                self._set_visible(key, True)
                if with_events:
                    events.append(
                        Event(EventKind.EDGE_ADDED, edge_type, writer, False, frozenset(attrs), None, None,
                              src, dst, self.node_name(src), self.node_name(dst))
                    )
        return events

    # -- maintenance ---------------------------------------------------------

    def note_edge_attrs(self, key: str, attrs: Iterable[str]) -> None:
        """Record attributes this replica just wrote on an edge, before the transaction settles."""
        if attrs:
            self.edge_attr_names.setdefault(key, set()).update(attrs)

    def _add_node(self, node_id: int, node_type: str, name: str) -> None:
        self.node_meta[node_id] = (node_type, name)
        self.names.setdefault(name, set()).add(node_id)
        self.by_type.setdefault(node_type, set()).add(node_id)

    def _remove_node(self, node_id: int) -> tuple[str, str]:
        node_type, name = self.node_meta.pop(node_id)
        self._discard(self.names, name, node_id)
        self._discard(self.by_type, node_type, node_id)
        return node_type, name

    def _rename(self, node_id: int, new_name: str) -> None:
        node_type, old_name = self.node_meta[node_id]
        self._discard(self.names, old_name, node_id)
        self.node_meta[node_id] = (node_type, new_name)
        self.names.setdefault(new_name, set()).add(node_id)

    def _add_marker(self, key: str) -> tuple[int, int, str]:
        src, dst, edge_type = parsed = parse_edge_key(key)
        self.markers[key] = parsed
        self.out_edges.setdefault(src, set()).add(key)
        self.in_edges.setdefault(dst, set()).add(key)
        return parsed

    def _remove_marker(self, key: str) -> None:
        src, dst, _ = self.markers.pop(key)
        self._discard(self.out_edges, src, key)
        self._discard(self.in_edges, dst, key)

    def _set_visible(self, key: str, visible: bool) -> None:
        edge_type = self.markers[key][2] if key in self.markers else parse_edge_key(key)[2]
        if visible:
            self.visible.add(key)
            self.edge_type.setdefault(edge_type, set()).add(key)
        else:
            self.visible.discard(key)
            self._discard(self.edge_type, edge_type, key)

    @staticmethod
    def _discard(index: dict, key: object, value: object) -> None:
        members = index.get(key)
        if members is not None:
            members.discard(value)
            if not members:
                del index[key]

    # -- the diff ------------------------------------------------------------

    def apply(
        self,
        store: CrdtStore,
        changes: RawChanges,
        writer: str,
        local: bool,
        volatile_attrs: Callable[[str], Iterable[str]],
    ) -> IndexResult:
        """Bring the index up to date with ``changes`` and return the events they amount to.

        ``volatile_attrs(owner)`` names the volatile attributes an owner has, so
        that an *added* event lists every attribute the element carries.
        """
        result = IndexResult()
        added_nodes: list[Event] = []
        removed_nodes: list[Event] = []
        gone_names: dict[int, str] = {}

        touched_nodes = list(dict.fromkeys(changes.nodes_added + changes.nodes_removed))
        heads = store.node_heads(touched_nodes) if touched_nodes else {}
        for key in touched_nodes:
            node_id = int(key)
            before = node_id in self.node_meta
            head = heads.get(key)
            if head is not None and not before:
                node_type, name, attr_names = head
                self._add_node(node_id, node_type, name)
                attrs = frozenset(attr_names) | frozenset(volatile_attrs(f"n:{key}"))
                added_nodes.append(Event(EventKind.NODE_ADDED, node_type, writer, local, attrs, node_id, name))
                if len(self.names[name]) > 1:
                    result.name_conflicts.append(name)
            elif head is None and before:
                node_type, name = self._remove_node(node_id)
                gone_names[node_id] = name
                result.removed_nodes.append(node_id)
                removed_nodes.append(Event(EventKind.NODE_REMOVED, node_type, writer, local, frozenset(), node_id, name))

        self._note_edge_attrs(store, changes)
        touched_edges = dict.fromkeys(changes.edges_added + changes.edges_removed)
        for event in added_nodes + removed_nodes:
            touched_edges.update(dict.fromkeys(self.edges_of(event.id)))  # type: ignore[arg-type]
        added_edges, removed_edges = [], []
        for key in touched_edges:
            present = key in store.edges
            if present and key not in self.markers:
                self._add_marker(key)
            elif not present and key in self.markers:
                self._remove_marker(key)
            src, dst, edge_type = parse_edge_key(key)
            before = key in self.visible
            after = present and src in self.node_meta and dst in self.node_meta
            if after == before:
                if present and not after and (store.is_deleted(str(src)) or store.is_deleted(str(dst))):
                    result.dangling_edges.append(key)
                continue
            self._set_visible(key, after)
            names = (self.node_name(src) or gone_names.get(src), self.node_name(dst) or gone_names.get(dst))
            if after:
                attrs = frozenset(self.edge_attr_names.get(key, ())) | frozenset(volatile_attrs(f"e:{key}"))
                added_edges.append(Event(EventKind.EDGE_ADDED, edge_type, writer, local, attrs, None, None, src, dst, *names))
            else:
                result.removed_edges.append(key)
                removed_edges.append(Event(EventKind.EDGE_REMOVED, edge_type, writer, local, frozenset(), None, None, src, dst, *names))
                if present:
                    result.dangling_edges.append(key)

        updated = self._attribute_updates(store, changes, writer, local, added_nodes, added_edges, result)
        result.events = added_nodes + added_edges + updated + removed_edges + removed_nodes
        return result

    def _note_edge_attrs(self, store: CrdtStore, changes: RawChanges) -> None:
        """Track which durable attributes each edge carries (before events list them)."""
        for key, attrs in changes.edge_attrs.items():
            known = self.edge_attr_names.setdefault(key, set())
            for attr in attrs:
                if f"{key}.{attr}" in store.edge_attrs:
                    known.add(attr)
                else:
                    known.discard(attr)
            if not known:
                del self.edge_attr_names[key]

    def out_of_step(self, store: CrdtStore) -> bool:
        """Whether the document holds a different number of nodes or edge markers than the index."""
        return len(store.nodes) != len(self.node_meta) or len(store.edges) != len(self.markers)

    def missed_changes(self, store: CrdtStore) -> RawChanges:
        """Everything in which the document and the index differ, as changes to apply (a full scan).

        pycrdt does not report every change of a remote transaction: deletions
        it held back until their items arrived, and some merges of concurrent
        writes to one key, change the document without an event.
        """
        names = store.node_names()
        known = {str(node_id): name for node_id, (_, name) in self.node_meta.items()}
        markers = set(store.edges.keys())
        return RawChanges(
            nodes_added=[key for key in names if key not in known],
            nodes_removed=[key for key in known if key not in names],
            node_attrs={key: {NAME_KEY} for key, name in names.items() if key in known and known[key] != name},
            edges_added=[key for key in markers if key not in self.markers],
            edges_removed=[key for key in self.markers if key not in markers],
        )

    def _attribute_updates(
        self,
        store: CrdtStore,
        changes: RawChanges,
        writer: str,
        local: bool,
        added_nodes: list[Event],
        added_edges: list[Event],
        result: IndexResult,
    ) -> list[Event]:
        events = []
        fresh_nodes = {e.id for e in added_nodes}
        for key, attrs in changes.node_attrs.items():
            node_id = int(key)
            if node_id in fresh_nodes or node_id not in self.node_meta:
                continue
            if NAME_KEY in attrs:
                node = store.node_map(key)
                if node is not None:
                    new_name = str(node.get(NAME_KEY))
                    self._rename(node_id, new_name)
                    if len(self.names[new_name]) > 1:
                        result.name_conflicts.append(new_name)
            node_type, name = self.node_meta[node_id]
            events.append(Event(EventKind.NODE_UPDATED, node_type, writer, local, frozenset(attrs - {TYPE_KEY}), node_id, name))

        fresh_edges = {(e.src, e.dst, e.type) for e in added_edges}
        for key, attrs in changes.edge_attrs.items():
            if key in self.visible and self.markers[key] not in fresh_edges:
                src, dst, edge_type = self.markers[key]
                events.append(
                    Event(EventKind.EDGE_UPDATED, edge_type, writer, local, frozenset(attrs), None, None,
                          src, dst, self.node_name(src), self.node_name(dst))
                )
        return events

    def volatile_events(self, changed: Iterable[tuple[str, str]], writer: str, local: bool) -> list[Event]:
        """NODE_UPDATED / EDGE_UPDATED events for volatile registers that changed."""
        by_owner: dict[str, set[str]] = {}
        for owner, attr in changed:
            by_owner.setdefault(owner, set()).add(attr)
        events = []
        for owner, attrs in by_owner.items():
            kind, ident = owner.split(":", 1)
            if kind == "n":
                node_id = int(ident)
                meta = self.node_meta.get(node_id)
                if meta:
                    events.append(Event(EventKind.NODE_UPDATED, meta[0], writer, local, frozenset(attrs), node_id, meta[1]))
            elif ident in self.visible:
                src, dst, edge_type = self.markers[ident]
                events.append(
                    Event(EventKind.EDGE_UPDATED, edge_type, writer, local, frozenset(attrs), None, None,
                          src, dst, self.node_name(src), self.node_name(dst))
                )
        return events
