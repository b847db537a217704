"""Events: typed kinds, changed attributes, writer and local flag, filters, async streams, batch()."""

from __future__ import annotations

import asyncio

import pytest

import wm
from graph_helpers import Recorder
from wm import EventKind as K


@pytest.fixture
def g() -> wm.Graph:
    return wm.Graph(replica_id="here")


def test_local_events_are_typed_and_name_the_changed_attributes(g: wm.Graph) -> None:
    rec = Recorder(g)
    ann = g.insert_node("person", "ann", {"radius": 0.3, "velocity": (0, 1)})
    ball = g.insert_node("object", "ball")
    g.update_node(ann, {"speed": 1.0})
    g.insert_or_assign_edge(ann, ball, "has_intention", {"risky": True, "stamp": 1.0})
    g.insert_or_assign_edge(ann, ball, "has_intention", {"gaze": 0.2})
    g.delete_edge(ann, ball, "has_intention")
    g.delete_node(ball)
    got = [(e.kind, e.type, e.attrs, e.writer, e.local) for e in rec.events]
    assert got == [
        (K.NODE_ADDED, "person", frozenset({"radius", "velocity"}), "here", True),
        (K.NODE_ADDED, "object", frozenset(), "here", True),
        (K.NODE_UPDATED, "person", frozenset({"speed"}), "here", True),
        (K.EDGE_ADDED, "has_intention", frozenset({"risky", "stamp"}), "here", True),
        (K.EDGE_UPDATED, "has_intention", frozenset({"gaze"}), "here", True),
        (K.EDGE_REMOVED, "has_intention", frozenset(), "here", True),
        (K.NODE_REMOVED, "object", frozenset(), "here", True),
    ]
    assert rec.events[0].id == ann and rec.events[0].name == "ann"
    edge_event = rec.events[3]
    assert (edge_event.src, edge_event.dst, edge_event.src_name, edge_event.dst_name) == (ann, ball, "ann", "ball")
    assert str(edge_event) == "edge_added ann-[has_intention]->ball ['risky', 'stamp'] (local)"


def test_remote_events_carry_the_writer_and_are_not_local(g: wm.Graph) -> None:
    other = wm.Graph(replica_id="there")
    ann = other.insert_node("person", "ann", {"radius": 0.3, "last_seen": 1.0})
    ball = other.insert_node("object", "ball")
    other.insert_or_assign_edge(ann, ball, "has_intention", {"risky": True})
    rec = Recorder(g)
    g.apply_update(other.diff(), "there")
    g.merge_volatile(other.take_volatile_outbox(), "there")
    assert [(e.kind, e.writer, e.local) for e in rec.events] == [
        (K.NODE_ADDED, "there", False),
        (K.NODE_ADDED, "there", False),
        (K.EDGE_ADDED, "there", False),
        (K.NODE_UPDATED, "there", False),
    ]
    assert rec.events[2].attrs == {"risky"}
    assert rec.events[3].attrs == {"last_seen"}
    rec.clear()
    before = other.state_vector()
    other.update_node(ann, {"speed": 2.0})
    other.delete_node(ball)
    g.apply_update(other.diff(before), "there")
    assert [(e.kind, e.attrs, e.local) for e in rec.events] == [
        (K.NODE_UPDATED, frozenset({"speed"}), False),
        (K.EDGE_REMOVED, frozenset(), False),
        (K.NODE_REMOVED, frozenset(), False),
    ]


def test_filters_by_kind_type_and_name(g: wm.Graph) -> None:
    by_kind, by_type, by_name, combined = [], [], [], []
    g.on(by_kind.append, kind=["node_removed", "edge_added"])
    g.on(by_type.append, type="object")
    g.on(by_name.append, name="ann")
    g.on(combined.append, kind="node_updated", type="person", name=["bob", "ann"])
    ann = g.insert_node("person", "ann")
    ball = g.insert_node("object", "ball")
    g.insert_or_assign_edge(ball, ann, "has")
    g.update_node(ann, {"speed": 1.0})
    g.update_node(ball, {"kind": "ball"})
    g.delete_node(ball)
    assert [e.kind for e in by_kind] == [K.EDGE_ADDED, K.NODE_REMOVED]
    assert [(e.kind, e.type) for e in by_type] == [
        (K.NODE_ADDED, "object"),
        (K.NODE_UPDATED, "object"),
        (K.NODE_REMOVED, "object"),
    ]
    assert [e.kind for e in by_name] == [K.NODE_ADDED, K.EDGE_ADDED, K.NODE_UPDATED, K.EDGE_REMOVED]
    assert [(e.kind, e.name) for e in combined] == [(K.NODE_UPDATED, "ann")]
    with pytest.raises(ValueError):
        g.on(print, kind="node_changed")


def test_callback_that_raises_does_not_break_the_writer(g: wm.Graph) -> None:
    seen = []

    def broken(event: wm.Event) -> None:
        raise RuntimeError("consumer bug")

    g.on(broken)
    g.on(seen.append)
    ann = g.insert_node("person", "ann")
    g.update_node(ann, {"speed": 1.0})
    assert g.get_node(ann).attrs == {"speed": 1.0}
    assert g.callback_errors == 2
    assert len(seen) == 2


def test_cancelled_subscription_gets_nothing(g: wm.Graph) -> None:
    seen = []
    sub = g.on(seen.append)
    g.insert_node("person")
    sub.cancel()
    g.insert_node("person")
    assert len(seen) == 1


async def test_async_events_iterator(g: wm.Graph) -> None:
    stream = g.events(kind="node_added", type="person")

    async def writer() -> None:
        for i in range(3):
            await asyncio.sleep(0)
            g.insert_node("object")
            g.insert_node("person", f"p{i}")

    task = asyncio.create_task(writer())
    got = [await stream.next(timeout=5) for _ in range(3)]
    await task
    assert [e.name for e in got] == ["p0", "p1", "p2"]
    stream.close()
    assert [e async for e in stream] == []
    g.insert_node("person")
    assert len(stream) == 0


async def test_slow_consumer_queue_drops_the_oldest_and_counts(g: wm.Graph) -> None:
    with g.events(maxsize=3) as stream:
        ids = [g.insert_node("object") for _ in range(5)]
        assert stream.dropped == 2 and len(stream) == 3
        assert [(await stream.next(timeout=1)).id for _ in range(3)] == ids[2:]
        assert stream.get_nowait() is None
    with pytest.raises(ValueError):
        g.events(maxsize=0)


def test_batch_holds_events_until_the_end_and_coalesces_updates(g: wm.Graph) -> None:
    rec = Recorder(g)
    with g.batch():
        ann = g.insert_node("person", "ann")
        g.update_node(ann, {"speed": 1.0})
        g.update_node(ann, {"fov": 1.0, "last_seen": 2.0})
        with g.batch():
            g.update_node(ann, {"radius": 0.2})
        assert g.get_node(ann).attrs["radius"] == 0.2  # visible to reads at once
        assert rec.events == []
    assert [(e.kind, e.attrs) for e in rec.events] == [
        (K.NODE_ADDED, frozenset()),
        (K.NODE_UPDATED, frozenset({"speed", "fov", "last_seen", "radius"})),
    ]


def test_batch_flushes_events_even_when_the_block_raises(g: wm.Graph) -> None:
    rec = Recorder(g)
    with pytest.raises(wm.UnknownTypeError):
        with g.batch():
            g.insert_node("person", "ann")
            g.insert_node("dragon")
    assert rec.kinds() == ["node_added"]
    assert g.find_node("ann") is not None
