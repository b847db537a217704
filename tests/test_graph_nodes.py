"""Nodes: insert, update per attribute, delete_attr, rename, delete (cascade), get, find, nodes(type)."""

from __future__ import annotations

import dataclasses

import numpy as np
import pytest

import wm
from graph_helpers import Recorder, assert_refused
from wm.ids import COUNTER_BITS, IdAllocator


@pytest.fixture
def g() -> wm.Graph:
    return wm.Graph(replica_id="local")


@pytest.fixture
def rec(g: wm.Graph) -> Recorder:
    return Recorder(g)


def test_insert_returns_a_fresh_id_and_stores_type_name_attrs(g: wm.Graph) -> None:
    a = g.insert_node("person", "ann", {"radius": 0.3, "track_id": 4, "velocity": (1, 2)})
    b = g.insert_node("person", "bob")
    assert a != b
    node = g.get_node(a)
    assert (node.id, node.type, node.name) == (a, "person", "ann")
    assert dict(node.attrs) == {"radius": 0.3, "track_id": 4, "velocity": (1.0, 2.0)}
    assert type(node.attrs["track_id"]) is int
    assert g.get_node("ann") == node


def test_insert_without_name_gets_type_and_id(g: wm.Graph) -> None:
    node_id = g.insert_node("object")
    assert g.get_node(node_id).name == f"object_{node_id}"


def test_ids_are_unique_per_creator_and_below_2_53() -> None:
    graphs = [wm.Graph() for _ in range(5)]
    ids = [graph.insert_node("object") for graph in graphs for _ in range(20)]
    assert len(set(ids)) == len(ids)
    assert all(0 < i < 2**53 for i in ids)


def test_id_allocator_skips_taken_ids_and_changes_prefix_when_full() -> None:
    alloc = IdAllocator(prefix=7)
    first = alloc.next_id(lambda i: i == (7 << COUNTER_BITS) | 1)
    assert first == (7 << COUNTER_BITS) | 2
    alloc._counter = (1 << COUNTER_BITS) - 1
    node_id = alloc.next_id(lambda i: False)
    assert node_id == (alloc.prefix << COUNTER_BITS) | 1
    assert node_id < 2**53


def test_insert_with_taken_name_is_refused(g: wm.Graph, rec: Recorder) -> None:
    g.insert_node("person", "ann")
    assert_refused(g, rec, wm.NameExistsError, lambda: g.insert_node("object", "ann"))


@pytest.mark.parametrize("name", ["", "@type", 5, None.__class__])
def test_insert_with_malformed_name_is_refused(g: wm.Graph, rec: Recorder, name: object) -> None:
    assert_refused(g, rec, wm.ValidationError, lambda: g.insert_node("person", name))  # type: ignore[arg-type]


def test_update_writes_per_attribute_and_keeps_the_others(g: wm.Graph, rec: Recorder) -> None:
    node_id = g.insert_node("person", "ann", {"radius": 0.3, "speed": 1.0})
    rec.clear()
    g.update_node("ann", {"speed": 2.0})
    g.update_node(node_id, {"fov": 1.5, "last_seen": 12.5})
    assert dict(g.get_node(node_id).attrs) == {"radius": 0.3, "speed": 2.0, "fov": 1.5, "last_seen": 12.5}
    assert [(e.kind, e.attrs) for e in rec.events] == [
        (wm.EventKind.NODE_UPDATED, frozenset({"speed"})),
        (wm.EventKind.NODE_UPDATED, frozenset({"fov", "last_seen"})),
    ]


def test_concurrent_updates_of_different_attributes_both_survive() -> None:
    a, b = wm.Graph(replica_id="a"), wm.Graph(replica_id="b")
    node_id = a.insert_node("person", "ann", {"radius": 0.3})
    b.apply_update(a.diff(), "a")
    a.update_node(node_id, {"speed": 1.0})
    b.update_node(node_id, {"fov": 2.0})
    a.apply_update(b.diff(a.state_vector()), "b")
    b.apply_update(a.diff(b.state_vector()), "a")
    assert (
        dict(a.get_node(node_id).attrs) == dict(b.get_node(node_id).attrs) == {"radius": 0.3, "speed": 1.0, "fov": 2.0}
    )


def test_update_with_empty_attrs_writes_nothing(g: wm.Graph, rec: Recorder) -> None:
    g.insert_node("person", "ann")
    rec.clear()
    g.update_node("ann", {})
    assert rec.events == [] and rec.updates == []


def test_update_of_missing_node_is_refused(g: wm.Graph, rec: Recorder) -> None:
    assert_refused(g, rec, wm.NodeNotFoundError, lambda: g.update_node("nobody", {"speed": 1.0}))
    assert_refused(g, rec, wm.NodeNotFoundError, lambda: g.update_node(12345, {"speed": 1.0}))


def test_delete_attr_durable_and_volatile(g: wm.Graph, rec: Recorder) -> None:
    g.insert_node("person", "ann", {"radius": 0.3, "last_seen": 1.0, "speed": 2.0})
    rec.clear()
    g.delete_attr("ann", "radius")
    g.delete_attr("ann", "last_seen")
    assert dict(g.get_node("ann").attrs) == {"speed": 2.0}
    assert [(e.kind, e.attrs) for e in rec.events] == [
        (wm.EventKind.NODE_UPDATED, frozenset({"radius"})),
        (wm.EventKind.NODE_UPDATED, frozenset({"last_seen"})),
    ]
    rec.clear()
    g.delete_attr("ann", "radius")  # not set: a no-op
    g.delete_attr("ann", "velocity")
    assert rec.events == [] and rec.updates == []


def test_delete_attr_errors(g: wm.Graph, rec: Recorder) -> None:
    g.insert_node("person", "ann", {"radius": 0.3})
    assert_refused(g, rec, wm.UnknownAttributeError, lambda: g.delete_attr("ann", "kind"))
    assert_refused(g, rec, wm.NodeNotFoundError, lambda: g.delete_attr("bob", "radius"))


def test_rename_moves_the_name(g: wm.Graph, rec: Recorder) -> None:
    node_id = g.insert_node("person", "ann")
    rec.clear()
    g.rename_node("ann", "anna")
    assert g.get_node("anna").id == node_id
    assert g.find_node("ann") is None
    assert [(e.kind, e.name, e.attrs) for e in rec.events] == [
        (wm.EventKind.NODE_UPDATED, "anna", frozenset({"@name"}))
    ]
    g.insert_node("person", "ann")  # the old name is free again


def test_rename_errors(g: wm.Graph, rec: Recorder) -> None:
    g.insert_node("person", "ann")
    g.insert_node("person", "bob")
    assert_refused(g, rec, wm.NameExistsError, lambda: g.rename_node("ann", "bob"))
    assert_refused(g, rec, wm.ValidationError, lambda: g.rename_node("ann", "@x"))
    assert_refused(g, rec, wm.NodeNotFoundError, lambda: g.rename_node("carl", "dan"))


def test_delete_node_cascades_to_its_edges(g: wm.Graph, rec: Recorder) -> None:
    w = g.insert_node("world", "world")
    p = g.insert_node("person", "ann")
    o = g.insert_node("object", "ball")
    g.rt.set_pose2d(w, p, 1, 2, 0)
    g.rt.set_pose2d(w, o, 3, 4, 0)
    g.insert_or_assign_edge(p, o, "has_intention", {"risky": True})
    rec.clear()
    g.delete_node(p)
    assert g.find_node(p) is None
    assert [e.key for e in g.edges()] == [(w, o, "RT")]
    assert sorted(rec.kinds()) == ["edge_removed", "edge_removed", "node_removed"]
    assert rec.kinds()[-1] == "node_removed"
    removed = {(e.src, e.dst, e.type) for e in rec.events if e.kind is wm.EventKind.EDGE_REMOVED}
    assert removed == {(w, p, "RT"), (p, o, "has_intention")}


def test_deleted_id_is_never_reused_or_reinserted(g: wm.Graph, rec: Recorder) -> None:
    p = g.insert_node("person", "ann")
    g.delete_node(p)
    assert g.id_taken(p)
    assert_refused(g, rec, wm.NodeExistsError, lambda: g.insert_node_with_id(p, "person", "ann"))
    assert_refused(g, rec, wm.NodeNotFoundError, lambda: g.delete_node(p))
    assert_refused(g, rec, wm.NodeNotFoundError, lambda: g.update_node(p, {"speed": 1.0}))


def test_a_late_update_does_not_resurrect_a_deleted_node() -> None:
    a, b = wm.Graph(replica_id="a"), wm.Graph(replica_id="b")
    p = a.insert_node("person", "ann")
    b.apply_update(a.diff(), "a")
    b.update_node(p, {"speed": 3.0, "last_seen": 1.0})
    late_crdt, late_volatile = b.diff(a.state_vector()), b.take_volatile_outbox()
    a.delete_node(p)
    a.apply_update(late_crdt, "b")
    a.merge_volatile(late_volatile, "b")
    b.apply_update(a.diff(b.state_vector()), "a")
    assert a.find_node(p) is None and b.find_node(p) is None
    assert a.to_dict() == b.to_dict()


def test_insert_node_with_id_errors(g: wm.Graph, rec: Recorder) -> None:
    g.insert_node_with_id(42, "person", "ann")
    assert g.get_node(42).name == "ann"
    for bad in (0, -1, 2**53, True, "43"):
        assert_refused(g, rec, wm.ValidationError, lambda bad=bad: g.insert_node_with_id(bad, "person", "x"))
    assert_refused(g, rec, wm.NodeExistsError, lambda: g.insert_node_with_id(42, "person", "x"))


def test_get_and_find(g: wm.Graph) -> None:
    p = g.insert_node("person", "ann")
    assert g.find_node("ann") == g.get_node(p)
    assert g.find_node("nobody") is None and g.find_node(999) is None
    with pytest.raises(wm.NodeNotFoundError):
        g.get_node("nobody")
    with pytest.raises(wm.NodeNotFoundError):
        g.get_node(3.5)  # type: ignore[arg-type]
    with pytest.raises(wm.NodeNotFoundError):
        g.get_node(True)
    with pytest.raises(KeyError):  # NotFoundError is also a KeyError
        g.get_node("nobody")


def test_nodes_by_type_in_id_order(g: wm.Graph) -> None:
    ids = [g.insert_node("person"), g.insert_node("object"), g.insert_node("person")]
    assert [n.id for n in g.nodes()] == sorted(ids)
    assert [n.id for n in g.nodes("person")] == sorted([ids[0], ids[2]])
    assert g.nodes("robot") == []
    assert g.node_count() == 3


def test_reads_are_immutable_snapshots(g: wm.Graph) -> None:
    p = g.insert_node("person", "ann", {"speed": 1.0, "velocity": [1.0, 2.0]})
    node = g.get_node(p)
    with pytest.raises(TypeError):
        node.attrs["speed"] = 2.0  # type: ignore[index]
    with pytest.raises(dataclasses.FrozenInstanceError):
        node.name = "bob"  # type: ignore[misc]
    assert isinstance(node.attrs["velocity"], tuple)
    g.update_node(p, {"speed": 5.0, "velocity": (3.0, 4.0)})
    assert node.attrs["speed"] == 1.0 and node.attrs["velocity"] == (1.0, 2.0)


def test_numpy_values_are_accepted_and_stored_as_python(g: wm.Graph) -> None:
    p = g.insert_node(
        "person", "ann", {"track_id": np.int64(3), "speed": np.float32(1.5), "velocity": np.array([1, 2])}
    )
    node = g.get_node(p)
    assert node.attrs == {"track_id": 3, "speed": 1.5, "velocity": (1.0, 2.0)}
    assert type(node.attrs["track_id"]) is int
