"""The local index of one replica: who exists, by type, by name and by endpoint.

It is rebuilt incrementally from the keys each transaction touched
(:class:`wm.crdt_store.RawChanges`) by comparing, key by key, what was visible
before with what is visible now. That comparison is what turns raw CRDT
changes, whatever their order, into typed events, and it is where the
visibility rules live:

* an edge is visible only while its marker exists **and** both its endpoints
  are live nodes, so a dangling edge left by a concurrent delete is never seen;
* a name belongs to the live node with the **lowest id** carrying it; the
  others are reported as conflicts so the graph can rename them;
* a document entry the view rules (:mod:`wm.view_rules`) refuse is left out,
  and kept in :class:`LeftOutEntries` with the replica that sent it. Remote
  changes are checked; a local one was checked by the ontology before it was
  made, so the write path pays nothing for the rules.
"""

from __future__ import annotations

from collections import Counter
from collections.abc import Callable, Iterable
from dataclasses import dataclass, field
from typing import Any

from .crdt_store import NAME_KEY, TYPE_KEY, CrdtStore, NodeContent, RawChanges
from .events import Event, EventKind
from .view_rules import LeftOut, ViewRules, node_id_of


@dataclass
class IndexResult:
    """What one round of changes produced."""

    events: list[Event] = field(default_factory=list)
    removed_nodes: list[int] = field(default_factory=list)
    removed_edges: list[str] = field(default_factory=list)
    dangling_edges: list[str] = field(default_factory=list)
    name_conflicts: list[str] = field(default_factory=list)
    left_out: list[LeftOut] = field(default_factory=list)  # entries newly left out by this round


LEFT_OUT_KINDS = ("node", "edge", "node_attr", "edge_attr")


class LeftOutEntries:
    """The document entries the view currently leaves out, by (kind, key), and how many each writer sent."""

    def __init__(self) -> None:
        self.entries: dict[tuple[str, str], LeftOut] = {}
        self.counts = dict.fromkeys(LEFT_OUT_KINDS, 0)  # kind -> entries now (a plain dict: read on every write)
        self.by_writer: Counter[str] = Counter()  # writer -> entries ever left out

    def add(self, entry: LeftOut, result: IndexResult) -> None:
        slot = (entry.kind, entry.key)
        previous = self.entries.get(slot)
        if previous is not None and previous.reason == entry.reason:
            return
        if previous is None:
            self.counts[entry.kind] += 1
        self.entries[slot] = entry
        self.by_writer[entry.writer] += 1
        result.left_out.append(entry)

    def discard(self, kind: str, key: str) -> None:
        if self.counts[kind] and self.entries.pop((kind, key), None) is not None:
            self.counts[kind] -= 1

    def keys(self, kind: str) -> list[str]:
        return [key for k, key in self.entries if k == kind] if self.counts[kind] else []


class GraphIndex:
    """Types, names and adjacency of the live graph, as this replica sees it."""

    def __init__(self, rules: ViewRules) -> None:
        self.rules = rules
        self.node_meta: dict[int, tuple[str, str]] = {}
        self.names: dict[str, set[int]] = {}
        self.by_type: dict[str, set[int]] = {}
        self.edge_type: dict[str, set[str]] = {}
        self.markers: dict[str, tuple[int, int, str]] = {}  # every valid edge marker, visible or not
        self.out_edges: dict[int, set[str]] = {}
        self.in_edges: dict[int, set[str]] = {}
        self.visible: set[str] = set()
        self.edge_attr_names: dict[str, set[str]] = {}
        self.left_out = LeftOutEntries()

    # -- queries -------------------------------------------------------------

    def resolve_name(self, name: str) -> int | None:
        ids = self.names.get(name)
        return min(ids) if ids else None

    def edges_of(self, node_id: int) -> set[str]:
        return self.out_edges.get(node_id, set()) | self.in_edges.get(node_id, set())

    def node_name(self, node_id: int) -> str | None:
        meta = self.node_meta.get(node_id)
        return meta[1] if meta else None

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

    def _add_marker(self, key: str, parsed: tuple[int, int, str]) -> None:
        src, dst, _ = parsed
        self.markers[key] = parsed
        self.out_edges.setdefault(src, set()).add(key)
        self.in_edges.setdefault(dst, set()).add(key)

    def _remove_marker(self, key: str) -> None:
        src, dst, _ = self.markers.pop(key)
        self._discard(self.out_edges, src, key)
        self._discard(self.in_edges, dst, key)

    def _set_visible(self, key: str, edge_type: str, visible: bool) -> None:
        if visible:
            self.visible.add(key)
            self.edge_type.setdefault(edge_type, set()).add(key)
        else:
            self.visible.discard(key)
            self._discard(self.edge_type, edge_type, key)

    @staticmethod
    def _discard(index: dict[Any, set[Any]], key: object, value: object) -> None:
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
        wants: Callable[[EventKind, str], bool],
        check_values: bool = True,
        describe: bool = True,
    ) -> IndexResult:
        """Bring the index up to date with ``changes`` and return the events they amount to.

        ``volatile_attrs(owner)`` names the volatile attributes an owner has, so
        that an *added* event lists every attribute the element carries. Remote
        content is checked against :class:`wm.view_rules.ViewRules`; attribute
        values of added nodes only when ``check_values`` (a catch-up skips it:
        reads check values anyway, see :meth:`wm.Graph.left_out`). Without
        ``describe`` (nobody listens), added events carry no attribute names.
        Update events are built only if ``wants(kind, type)``: a consumer may
        match them.
        """
        result = IndexResult()
        if not (
            changes.nodes_added
            or changes.nodes_removed
            or changes.edges_added
            or changes.edges_removed
            or changes.edge_attrs
            or changes.malformed_edge_attrs
            or any(NAME_KEY in attrs or TYPE_KEY in attrs for attrs in changes.node_attrs.values())
        ):
            # the common change, attributes of nodes and nothing else: no node or edge can appear or go
            result.events = self._attribute_updates(store, changes, writer, local, set(), set(), {}, wants, result)
            return result
        check = check_values and not local
        new_ids, added_nodes, removed_nodes, retyped = self._apply_nodes(
            store, changes, writer, local, check, volatile_attrs if describe else None, wants, result
        )
        gone_names = {e.id: e.name for e in removed_nodes + retyped}
        accepted_edge_attrs = self._note_edge_attrs(store, changes, writer, local, result)
        touched_edges = dict.fromkeys(changes.edges_added + changes.edges_removed)
        out_edges, in_edges = self.out_edges, self.in_edges
        for node_id in new_ids + [e.id for e in removed_nodes]:
            if node_id in out_edges or node_id in in_edges:
                touched_edges.update(dict.fromkeys(self.edges_of(node_id)))
        present = self._present_markers(store, touched_edges, writer, local, result) if touched_edges else set()
        added_edges, removed_edges, new_edges = [], [], set()
        for key in touched_edges:
            parsed = self.markers.get(key) or self.rules.edge_parts(key)
            if parsed is None:
                continue
            is_present = key in present
            if is_present and key not in self.markers:
                self._add_marker(key, parsed)
            elif not is_present and key in self.markers:
                self._remove_marker(key)
            src, dst, edge_type = parsed
            before = key in self.visible
            after = is_present and src in self.node_meta and dst in self.node_meta
            if after == before:
                if is_present and not after and (store.is_deleted(str(src)) or store.is_deleted(str(dst))):
                    result.dangling_edges.append(key)
                continue
            self._set_visible(key, edge_type, after)
            names = (self.node_name(src) or gone_names.get(src), self.node_name(dst) or gone_names.get(dst))
            if after:
                new_edges.add(key)
                if not wants(EventKind.EDGE_ADDED, edge_type):
                    continue
                attrs = frozenset(self.edge_attr_names.get(key, ())) | frozenset(volatile_attrs(f"e:{key}"))
                added_edges.append(
                    Event(EventKind.EDGE_ADDED, edge_type, writer, local, attrs, None, None, src, dst, *names)
                )
            else:
                result.removed_edges.append(key)
                removed_edges.append(
                    Event(EventKind.EDGE_REMOVED, edge_type, writer, local, frozenset(), None, None, src, dst, *names)
                )
                if is_present:
                    result.dangling_edges.append(key)

        updated = self._attribute_updates(
            store, changes, writer, local, set(new_ids), new_edges, accepted_edge_attrs, wants, result
        )
        result.events = retyped + added_nodes + added_edges + updated + removed_edges + removed_nodes
        return result

    def local_node_update(
        self, key: str, attrs: set[str], writer: str, wants: Callable[[EventKind, str], bool]
    ) -> Event | None:
        """This replica wrote attributes (not ``@name`` or ``@type``) of a node: the event, if the node is live and wanted."""
        head = self.node_meta.get(int(key))
        if head is None:
            return None
        if self.left_out.counts["node_attr"]:
            for attr in attrs:
                self.left_out.discard("node_attr", f"{key}.{attr}")
        if not wants(EventKind.NODE_UPDATED, head[0]):
            return None
        return Event(EventKind.NODE_UPDATED, head[0], writer, True, frozenset(attrs), int(key), head[1])

    def _apply_nodes(
        self,
        store: CrdtStore,
        changes: RawChanges,
        writer: str,
        local: bool,
        check_values: bool,
        volatile_attrs: Callable[[str], Iterable[str]] | None,
        wants: Callable[[EventKind, str], bool],
        result: IndexResult,
    ) -> tuple[list[int], list[Event], list[Event], list[Event]]:
        """Add, remove, rename and re-type nodes whose key, ``@type`` or ``@name`` changed.

        Returns the ids of the added nodes, their events (those wanted), and
        the removed and re-typed (removed, then added again) events.
        """
        heads = [key for key, attrs in changes.node_attrs.items() if NAME_KEY in attrs or TYPE_KEY in attrs]
        if not (changes.nodes_added or changes.nodes_removed or heads):
            return [], [], [], []
        touched = list(dict.fromkeys(changes.nodes_added + changes.nodes_removed + heads))
        contents = store.read_nodes(touched, attr_names=check_values or volatile_attrs is not None)
        new: list[tuple[str, int]] = []
        removed: list[Event] = []
        retyped: list[Event] = []
        for key in touched:
            node_id, head = self._admit_node(key, contents, writer, result)
            if node_id is None:
                continue
            before = self.node_meta.get(node_id)
            if head == before:
                continue
            if before is not None and (head is None or head[0] != before[0]):
                node_type, name = self._remove_node(node_id)
                result.removed_nodes.append(node_id)
                event = Event(EventKind.NODE_REMOVED, node_type, writer, local, frozenset(), node_id, name)
                (retyped if head is not None else removed).append(event)
                before = None
            if head is None:
                continue
            node_type, name = head
            if before is None:
                self._add_node(node_id, node_type, name)
                new.append((key, node_id))
            else:
                self._rename(node_id, name)
            if len(self.names[name]) > 1:
                result.name_conflicts.append(name)
        shown = self._check_new_nodes(store, new, contents, writer, result) if check_values and new else {}
        added = []
        for key, node_id in new:
            node_type, name = self.node_meta[node_id]
            if not wants(EventKind.NODE_ADDED, node_type):
                continue
            attrs: frozenset[str] = frozenset()
            if volatile_attrs is not None:
                attrs = shown.get(key, frozenset(contents[key].attrs)) | frozenset(volatile_attrs(f"n:{key}"))  # type: ignore[union-attr]  # new nodes have content
            added.append(Event(EventKind.NODE_ADDED, node_type, writer, local, attrs, node_id, name))
        return [node_id for _, node_id in new], added, removed, retyped

    def _admit_node(
        self, key: str, contents: dict[str, NodeContent | None], writer: str, result: IndexResult
    ) -> tuple[int | None, tuple[str, str] | None]:
        """(id, (type, name)) of a node key the view shows, (id, None) for one it does not; records what it leaves out."""
        node_id = node_id_of(key)
        if key not in contents:
            self.left_out.discard("node", key)
            return node_id, None
        content = contents[key]
        problem = self._head_problem(node_id, None if content is None else (content.type, content.name))
        if problem is not None:
            self.left_out.add(LeftOut("node", key, problem, writer), result)
            return node_id, None
        self.left_out.discard("node", key)
        assert content is not None
        return node_id, (content.type, content.name)

    def _head_problem(self, node_id: int | None, head: tuple[Any, Any] | None) -> str | None:
        """Why the view leaves out a node key with this id (None: not an id) and map head (None: not a map), or None."""
        if node_id is None:
            return "the key is not a node id (a decimal int in 1..2**53)"
        if head is None:
            return "the value is not a map"
        return self.rules.node_problem(*head)

    def load(
        self,
        store: CrdtStore,
        writer: str,
        volatile_attrs: Callable[[str], Iterable[str]],
        wants: Callable[[EventKind, str], bool],
    ) -> IndexResult:
        """Index the whole document of a fresh replica that nobody listens to yet (so no node events).

        One pass over the node maps to read each head once, the view rules'
        one pass to sort them (:meth:`ViewRules.plain_nodes`), each shown node
        straight into the index, then the edges as in :meth:`apply`. Attribute
        values are checked when read (see :meth:`wm.Graph.left_out`).
        """
        result = IndexResult()
        heads = store.read_heads()
        shown, others = self.rules.plain_nodes(heads)
        for key in others:
            node_id, head = node_id_of(key), heads[key]
            problem = self._head_problem(node_id, head)
            if problem is not None:
                self.left_out.add(LeftOut("node", key, problem, writer), result)
                continue
            assert node_id is not None and head is not None  # what _head_problem found no problem with
            shown.append((node_id, head))
        meta, names, by_type, conflicts = self.node_meta, self.names, self.by_type, result.name_conflicts
        for node_id, head in shown:
            node_type, name = meta[node_id] = head
            same_name = names.get(name)
            if same_name is None:
                names[name] = {node_id}
            else:
                same_name.add(node_id)
                conflicts.append(name)
            of_type = by_type.get(node_type)
            if of_type is None:
                by_type[node_type] = {node_id}
            else:
                of_type.add(node_id)
        edges = self.missed_changes(store, nodes=False)
        if edges:
            rest = self.apply(store, edges, writer, False, volatile_attrs, wants, check_values=False, describe=False)
            result.events += rest.events
            result.dangling_edges += rest.dangling_edges
            result.left_out += rest.left_out
            result.removed_edges += rest.removed_edges
        return result

    def _check_new_nodes(
        self,
        store: CrdtStore,
        new: list[tuple[str, int]],
        contents: dict[str, NodeContent | None],
        writer: str,
        result: IndexResult,
    ) -> dict[str, frozenset[str]]:
        """The attributes of new remote nodes that the view shows; records the others."""
        stored = store.read_node_attrs({key: contents[key].attrs for key, _ in new})  # type: ignore[union-attr]  # new nodes have content
        shown = {}
        for key, node_id in new:
            element = self.rules.ontology.node_types[self.node_meta[node_id][0]]
            keep = []
            for attr, value in stored.get(key, {}).items():
                problem = self.rules.attr_problem(element, attr, value)
                if problem is None:
                    keep.append(attr)
                    self.left_out.discard("node_attr", f"{key}.{attr}")
                else:
                    self.left_out.add(LeftOut("node_attr", f"{key}.{attr}", problem, writer), result)
            shown[key] = frozenset(keep)
        return shown

    def _present_markers(
        self, store: CrdtStore, keys: dict[str, None], writer: str, local: bool, result: IndexResult
    ) -> set[str]:
        """The keys whose edge marker exists and is valid; records the markers the view leaves out."""
        if local:  # this replica only deletes markers or writes valid ones
            if self.left_out.counts["edge"]:
                for key in keys:
                    self.left_out.discard("edge", key)
            return {key for key in keys if key in store.edges}
        stored = store.read_flat(store.edges, keys)
        present = set()
        for key in keys:
            if key not in stored:
                self.left_out.discard("edge", key)
                continue
            value = stored[key]
            if self.rules.edge_parts(key) is None:
                problem = 'the key is not "src>dst>type" with node ids and a known edge type'
            elif value is not True:
                problem = f"the marker is {type(value).__name__}, not true"
            else:
                present.add(key)
                self.left_out.discard("edge", key)
                continue
            self.left_out.add(LeftOut("edge", key, problem, writer), result)
        return present

    def _note_edge_attrs(
        self, store: CrdtStore, changes: RawChanges, writer: str, local: bool, result: IndexResult
    ) -> dict[str, set[str]]:
        """Track which durable attributes each edge carries; returns, per edge, the changed attributes the view shows."""
        if local:
            if changes.edge_attrs:
                self._note_local_edge_attrs(store, changes)
            for flat_key in changes.malformed_edge_attrs:  # only `wm check --repair` deletes these locally
                self.left_out.discard("edge_attr", flat_key)
            return {}
        for flat_key in changes.malformed_edge_attrs:
            if flat_key in store.edge_attrs:
                self.left_out.add(LeftOut("edge_attr", flat_key, "the key has no '.attribute'", writer), result)
            else:
                self.left_out.discard("edge_attr", flat_key)
        if not changes.edge_attrs:
            return {}
        flat = [f"{key}.{attr}" for key, attrs in changes.edge_attrs.items() for attr in attrs]
        stored = store.read_flat(store.edge_attrs, flat)
        accepted: dict[str, set[str]] = {}
        for key, attrs in changes.edge_attrs.items():
            parsed = self.rules.edge_parts(key)
            element = None if parsed is None else self.rules.ontology.edge_types[parsed[2]]
            known = self.edge_attr_names.setdefault(key, set())
            shown = accepted.setdefault(key, set())
            for attr in attrs:
                flat_key = f"{key}.{attr}"
                present = flat_key in stored
                if element is None:
                    problem: str | None = 'the key is not "src>dst>type.attribute" with node ids and a known edge type'
                elif present or attr not in element.attributes:
                    problem = self.rules.attr_problem(element, attr, stored.get(flat_key))
                else:
                    problem = None
                if problem is None:
                    shown.add(attr)
                    (known.add if present else known.discard)(attr)
                    self.left_out.discard("edge_attr", flat_key)
                    continue
                known.discard(attr)
                if present:
                    self.left_out.add(LeftOut("edge_attr", flat_key, problem, writer), result)
                else:
                    self.left_out.discard("edge_attr", flat_key)
            if not known:
                del self.edge_attr_names[key]
        return accepted

    def _note_local_edge_attrs(self, store: CrdtStore, changes: RawChanges) -> None:
        for key, attrs in changes.edge_attrs.items():
            known = self.edge_attr_names.setdefault(key, set())
            for attr in attrs:
                flat_key = f"{key}.{attr}"
                if flat_key in store.edge_attrs:
                    known.add(attr)
                else:
                    known.discard(attr)
                if self.left_out.counts["edge_attr"]:
                    self.left_out.discard("edge_attr", flat_key)
            if not known:
                del self.edge_attr_names[key]

    def out_of_step(self, store: CrdtStore) -> bool:
        """Whether the document holds a different number of nodes or edge markers than the index and its left-outs."""
        counts = self.left_out.counts
        nodes, edges = store.sizes()
        return nodes != len(self.node_meta) + counts["node"] or edges != len(self.markers) + counts["edge"]

    def missed_changes(self, store: CrdtStore, nodes: bool = True) -> RawChanges:
        """Every node key (unless not ``nodes``) and edge marker of the document or the index, to evaluate again.

        pycrdt does not report every change of a remote transaction: deletions
        it held back until their items arrived, and some merges of concurrent
        writes to one key, change the document without an event. Evaluating a
        key that did not change costs a read and produces nothing.
        """
        node_keys = (
            set(store.nodes.keys()) | {str(node_id) for node_id in self.node_meta} | set(self.left_out.keys("node"))
            if nodes
            else ()
        )
        edge_keys = set(store.edges.keys()) | set(self.markers) | set(self.left_out.keys("edge"))
        known = {f"{key}.{attr}" for key, attrs in self.edge_attr_names.items() for attr in attrs}
        changes = RawChanges(nodes_added=sorted(node_keys) if nodes else [], edges_added=sorted(edge_keys))
        for flat_key in sorted(set(store.edge_attrs.keys()) ^ (known | set(self.left_out.keys("edge_attr")))):
            key, dot, attr = flat_key.rpartition(".")
            if dot:
                changes.edge_attrs.setdefault(key, set()).add(attr)
            else:
                changes.malformed_edge_attrs.append(flat_key)
        return changes

    def _attribute_updates(
        self,
        store: CrdtStore,
        changes: RawChanges,
        writer: str,
        local: bool,
        fresh_nodes: set[int],
        fresh_edges: set[str],
        accepted_edge_attrs: dict[str, set[str]],
        wants: Callable[[EventKind, str], bool],
        result: IndexResult,
    ) -> list[Event]:
        events = []
        shown_attrs = self._shown_node_attrs(store, changes, writer, local, fresh_nodes, result)
        updated = EventKind.NODE_UPDATED
        for key, attrs in shown_attrs.items():
            node_type, name = self.node_meta[int(key)]
            if wants(updated, node_type):
                events.append(Event(updated, node_type, writer, local, frozenset(attrs - {TYPE_KEY}), int(key), name))

        for key, attrs in changes.edge_attrs.items():
            shown = attrs if local else accepted_edge_attrs.get(key)
            if shown and key in self.visible and key not in fresh_edges:
                src, dst, edge_type = self.markers[key]
                if not wants(EventKind.EDGE_UPDATED, edge_type):
                    continue
                events.append(
                    Event(
                        EventKind.EDGE_UPDATED,
                        edge_type,
                        writer,
                        local,
                        frozenset(shown),
                        None,
                        None,
                        src,
                        dst,
                        self.node_name(src),
                        self.node_name(dst),
                    )
                )
        return events

    def _shown_node_attrs(
        self, store: CrdtStore, changes: RawChanges, writer: str, local: bool, fresh: set[int], result: IndexResult
    ) -> dict[str, set[str]]:
        """Per node in the view, the changed attributes an update event lists (remote values checked)."""
        if local:  # this replica writes only into its live nodes
            meta = self.node_meta
            live = {
                key: attrs for key, attrs in changes.node_attrs.items() if (i := int(key)) in meta and i not in fresh
            }
            if self.left_out.counts["node_attr"]:
                for key, attrs in live.items():
                    for attr in attrs:
                        self.left_out.discard("node_attr", f"{key}.{attr}")
            return live
        live = {
            key: attrs
            for key, attrs in changes.node_attrs.items()
            if (node_id := node_id_of(key)) is not None and node_id in self.node_meta and node_id not in fresh
        }
        stored = store.read_node_attrs({key: {a for a in attrs if type(a) is str} for key, attrs in live.items()})
        shown: dict[str, set[str]] = {}
        left_out = self.left_out
        for key, attrs in live.items():
            element = self.rules.ontology.node_types[self.node_meta[int(key)][0]]
            values = stored.get(key, {})
            keep = set()
            for attr in attrs:
                if type(attr) is not str:
                    continue
                if attr.startswith("@"):
                    keep.add(attr)
                    continue
                if attr in values:
                    problem = self.rules.attr_problem(element, attr, values[attr])
                    if problem is not None:
                        left_out.add(LeftOut("node_attr", f"{key}.{attr}", problem, writer), result)
                        continue
                elif attr not in element.attributes:
                    if left_out.counts["node_attr"]:
                        left_out.discard("node_attr", f"{key}.{attr}")
                    continue
                if left_out.counts["node_attr"]:
                    left_out.discard("node_attr", f"{key}.{attr}")
                keep.add(attr)
            if keep - {TYPE_KEY}:
                shown[key] = keep
        return shown

    def volatile_events(
        self, changed: Iterable[tuple[str, str]], writer: str, local: bool, wants: Callable[[EventKind, str], bool]
    ) -> list[Event]:
        """NODE_UPDATED / EDGE_UPDATED events for volatile registers that changed (those someone ``wants``)."""
        by_owner: dict[str, set[str]] = {}
        for owner, attr in changed:
            by_owner.setdefault(owner, set()).add(attr)
        events = []
        for owner, attrs in by_owner.items():
            kind, ident = owner.split(":", 1)
            if kind == "n":
                node_id = int(ident)
                meta = self.node_meta.get(node_id)
                if meta and wants(EventKind.NODE_UPDATED, meta[0]):
                    events.append(
                        Event(EventKind.NODE_UPDATED, meta[0], writer, local, frozenset(attrs), node_id, meta[1])
                    )
            elif ident in self.visible and wants(EventKind.EDGE_UPDATED, self.markers[ident][2]):
                src, dst, edge_type = self.markers[ident]
                events.append(
                    Event(
                        EventKind.EDGE_UPDATED,
                        edge_type,
                        writer,
                        local,
                        frozenset(attrs),
                        None,
                        None,
                        src,
                        dst,
                        self.node_name(src),
                        self.node_name(dst),
                    )
                )
        return events
