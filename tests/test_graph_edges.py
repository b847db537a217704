"""Edges: insert_or_assign, get, find, delete, delete_edge_attr, edges(type, src, dst)."""

from __future__ import annotations

import pytest

import wm
from graph_helpers import Recorder, assert_refused


@pytest.fixture
def g() -> wm.Graph:
    graph = wm.Graph(replica_id="local")
    graph.insert_node("world", "world")
    graph.insert_node("person", "ann")
    graph.insert_node("object", "ball")
    graph.insert_node("object", "couch")
    return graph


@pytest.fixture
def rec(g: wm.Graph) -> Recorder:
    return Recorder(g)


def ids(g: wm.Graph, *names: str) -> list[int]:
    return [g.get_node(n).id for n in names]


def test_insert_then_assign_writes_per_attribute(g: wm.Graph, rec: Recorder) -> None:
    ann, ball = ids(g, "ann", "ball")
    g.insert_or_assign_edge("ann", "ball", "has_intention", {"risky": True, "path": [0, 0, 1, 1]})
    g.insert_or_assign_edge(ann, ball, "has_intention", {"time_to_collision": 2.5, "stamp": 7.0})
    edge = g.get_edge("ann", "ball", "has_intention")
    assert edge.key == (ann, ball, "has_intention")
    assert dict(edge.attrs) == {"risky": True, "path": (0.0, 0.0, 1.0, 1.0), "time_to_collision": 2.5, "stamp": 7.0}
    assert [(e.kind, e.attrs, e.src_name, e.dst_name) for e in rec.events] == [
        (wm.EventKind.EDGE_ADDED, frozenset({"risky", "path"}), "ann", "ball"),
        (wm.EventKind.EDGE_UPDATED, frozenset({"time_to_collision", "stamp"}), "ann", "ball"),
    ]


def test_edge_with_only_volatile_attrs_is_added(g: wm.Graph, rec: Recorder) -> None:
    g.insert_or_assign_edge("ann", "ball", "has_intention", {"stamp": 1.0})
    g.insert_or_assign_edge("ann", "ball", "has_intention", {"stamp": 2.0})
    assert g.get_edge("ann", "ball", "has_intention").attrs == {"stamp": 2.0}
    assert [(e.kind, e.attrs) for e in rec.events] == [
        (wm.EventKind.EDGE_ADDED, frozenset({"stamp"})),
        (wm.EventKind.EDGE_UPDATED, frozenset({"stamp"})),
    ]
    assert len(rec.updates) == 1  # the marker; the volatile write is not a CRDT update


def test_edges_are_keyed_by_src_dst_type(g: wm.Graph) -> None:
    g.insert_or_assign_edge("ann", "ball", "has_intention")
    g.insert_or_assign_edge("ann", "ball", "collision")
    g.insert_or_assign_edge("ball", "ann", "has_intention")
    g.insert_or_assign_edge("ann", "ball", "has_intention")
    assert len(g.edges()) == 3


def test_edges_filters(g: wm.Graph) -> None:
    world, ann, ball, couch = ids(g, "world", "ann", "ball", "couch")
    g.rt.set_pose2d(world, ann, 0, 0, 0)
    g.rt.set_pose2d(world, ball, 1, 0, 0)
    g.insert_or_assign_edge(ann, ball, "has_intention")
    g.insert_or_assign_edge(ann, couch, "has_intention")
    g.insert_or_assign_edge(ann, ball, "collision")
    keys = lambda edges: [e.key for e in edges]  # noqa: E731
    assert len(g.edges()) == 5
    assert keys(g.edges(type="RT")) == sorted([(world, ann, "RT"), (world, ball, "RT")])
    assert sorted(keys(g.edges(src="ann"))) == sorted(
        [(ann, ball, "has_intention"), (ann, couch, "has_intention"), (ann, ball, "collision")]
    )
    assert sorted(keys(g.edges(dst=ball))) == sorted(
        [(world, ball, "RT"), (ann, ball, "has_intention"), (ann, ball, "collision")]
    )
    assert keys(g.edges(type="has_intention", src=ann, dst="couch")) == [(ann, couch, "has_intention")]
    assert keys(g.edges(type="collision", src=world)) == []
    assert g.edges(type="has") == []
    with pytest.raises(wm.NodeNotFoundError):
        g.edges(src="nobody")


def test_get_and_find_edge(g: wm.Graph) -> None:
    g.insert_or_assign_edge("ann", "ball", "has_intention")
    assert g.find_edge("ann", "ball", "has_intention") == g.get_edge("ann", "ball", "has_intention")
    assert g.find_edge("ball", "ann", "has_intention") is None
    assert g.find_edge("ann", "nobody", "has_intention") is None
    with pytest.raises(wm.EdgeNotFoundError):
        g.get_edge("ann", "ball", "collision")
    with pytest.raises(wm.NodeNotFoundError):
        g.get_edge("ann", "nobody", "collision")


def test_delete_edge(g: wm.Graph, rec: Recorder) -> None:
    g.insert_or_assign_edge("ann", "ball", "has_intention", {"risky": True, "stamp": 1.0})
    rec.clear()
    g.delete_edge("ann", "ball", "has_intention")
    assert g.find_edge("ann", "ball", "has_intention") is None
    assert [(e.kind, e.type) for e in rec.events] == [(wm.EventKind.EDGE_REMOVED, "has_intention")]
    g.insert_or_assign_edge("ann", "ball", "has_intention")
    assert g.get_edge("ann", "ball", "has_intention").attrs == {}, "attributes of the deleted edge came back"


def test_delete_edge_errors(g: wm.Graph, rec: Recorder) -> None:
    assert_refused(g, rec, wm.EdgeNotFoundError, lambda: g.delete_edge("ann", "ball", "has_intention"))
    assert_refused(g, rec, wm.NodeNotFoundError, lambda: g.delete_edge("ann", "nobody", "has_intention"))


def test_delete_edge_attr(g: wm.Graph, rec: Recorder) -> None:
    g.insert_or_assign_edge("ann", "ball", "has_intention", {"risky": True, "gaze": 0.1, "stamp": 1.0})
    rec.clear()
    g.delete_edge_attr("ann", "ball", "has_intention", "risky")
    g.delete_edge_attr("ann", "ball", "has_intention", "stamp")
    assert g.get_edge("ann", "ball", "has_intention").attrs == {"gaze": 0.1}
    assert [(e.kind, e.attrs) for e in rec.events] == [
        (wm.EventKind.EDGE_UPDATED, frozenset({"risky"})),
        (wm.EventKind.EDGE_UPDATED, frozenset({"stamp"})),
    ]
    rec.clear()
    g.delete_edge_attr("ann", "ball", "has_intention", "stamp")  # already gone: nothing happens
    assert rec.events == []


def test_delete_edge_attr_errors(g: wm.Graph, rec: Recorder) -> None:
    g.insert_or_assign_edge("ann", "ball", "has_intention", {"risky": True})
    assert_refused(g, rec, wm.UnknownAttributeError, lambda: g.delete_edge_attr("ann", "ball", "has_intention", "kind"))
    assert_refused(g, rec, wm.EdgeNotFoundError, lambda: g.delete_edge_attr("ann", "ball", "collision", "updated_at"))


def test_insert_edge_errors_write_nothing(g: wm.Graph, rec: Recorder) -> None:
    assert_refused(g, rec, wm.UnknownTypeError, lambda: g.insert_or_assign_edge("ann", "ball", "likes"))
    assert_refused(
        g, rec, wm.UnknownAttributeError, lambda: g.insert_or_assign_edge("ann", "ball", "collision", {"risky": True})
    )
    assert_refused(
        g,
        rec,
        wm.AttributeTypeError,
        lambda: g.insert_or_assign_edge("ann", "ball", "has_intention", {"risky": True, "gaze": "up"}),
    )
    assert_refused(g, rec, wm.NodeNotFoundError, lambda: g.insert_or_assign_edge("ann", "nobody", "collision"))
    assert_refused(
        g,
        rec,
        wm.UnknownAttributeError,
        lambda: g.insert_or_assign_edge("ann", "ball", "has_intention", {"stamp": 1.0, "kind": "x"}),
    )


def test_edges_of_a_deleted_node_never_show_remotely() -> None:
    a, b = wm.Graph(replica_id="a"), wm.Graph(replica_id="b")
    ann, ball = a.insert_node("person", "ann"), a.insert_node("object", "ball")
    b.apply_update(a.diff(), "a")
    a.delete_node(ball)
    b.insert_or_assign_edge(ann, ball, "has_intention", {"risky": True})  # concurrent with the delete
    b_events = Recorder(b)
    b.apply_update(a.diff(b.state_vector()), "a")
    assert b.edges() == []
    assert wm.EventKind.EDGE_REMOVED in [e.kind for e in b_events.events]
    a_events = Recorder(a)
    a.apply_update(b.diff(a.state_vector()), "b")
    assert a.edges() == []
    assert wm.EventKind.EDGE_ADDED not in [e.kind for e in a_events.events]
    b.apply_update(a.diff(b.state_vector()), "a")
    assert a.to_dict() == b.to_dict()


def test_edge_reads_are_immutable(g: wm.Graph) -> None:
    g.insert_or_assign_edge("ann", "ball", "has_intention", {"path": [1, 2]})
    edge = g.get_edge("ann", "ball", "has_intention")
    with pytest.raises(TypeError):
        edge.attrs["path"] = (3.0,)  # type: ignore[index]
    g.insert_or_assign_edge("ann", "ball", "has_intention", {"path": [5, 6]})
    assert edge.attrs["path"] == (1.0, 2.0)
