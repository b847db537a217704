"""The sync protocol's pure functions, without a network."""

from __future__ import annotations

import msgpack
import pytest

import wm
from wm.net import sync_protocol as proto


def sample() -> wm.Graph:
    g = wm.Graph()
    world = g.insert_node("world", "world")
    for i in range(20):
        node = g.insert_node("object", f"o{i}", {"kind": "ball", "track_id": i})
        g.rt.set_pose2d(world, node, i, 0.0, 0.1)
        g.insert_or_assign_edge(world, node, "has", {"status": "seen"})
    g.delete_node("o3")
    g.rename_node("o4", "four")
    return g


@pytest.mark.parametrize(
    "message",
    [
        proto.Delta("a1", 3, b"\x00\x00", [("n:1", "stamp", 1.5, 7, "a1")]),
        proto.Delta("a1", 4, None, []),
        proto.Heartbeat("a1", 9, wm.Graph().state_vector()),
        proto.SyncRequest("a1", wm.Graph().state_vector()),
        proto.SyncReply("a1", 2, b"\x00\x00", []),
        proto.SyncReply("a1", 2, b"\x00\x00", [("n:1", "stamp", 1.5, 7, "a1")]),
        proto.AckRequest("a1", 5),
        proto.AckReply("a1", 5, 4),
        proto.AckReply("a1", 5, -1),
    ],
)
def test_every_message_round_trips(message: proto.Message) -> None:
    assert proto.decode(proto.encode(message)) == message


def test_a_fresh_replica_catches_up_by_reading_the_document() -> None:
    source, fresh = sample(), wm.Graph()
    reply = proto.decode(
        proto.encode(proto.answer_sync(source, proto.SyncRequest(fresh.replica_id, fresh.state_vector()), 1))
    )
    assert isinstance(reply, proto.SyncReply)
    added = []
    fresh.on(added.append, kind=["node_added", "edge_added"])
    proto.apply_delta(fresh, reply)
    assert fresh.to_dict() == source.to_dict()
    assert fresh.get_node("four").attrs["kind"] == "ball" and fresh.find_node("o3") is None
    assert len(added) == len(source.nodes()) + len(source.edges())
    fresh.update_node("four", {"track_id": 40})  # the installed index serves writes too
    assert fresh.get_node("four").attrs["track_id"] == 40


def test_a_replica_that_holds_something_gets_a_plain_diff() -> None:
    source, other = sample(), wm.Graph()
    other.insert_node("person", "alice")
    reply = proto.answer_sync(source, proto.SyncRequest(other.replica_id, other.state_vector()), 1)
    proto.apply_delta(other, reply)
    assert {n.name for n in other.nodes()} == {n.name for n in source.nodes()} | {"alice"}


def test_a_reply_for_a_replica_that_is_no_longer_fresh_is_merged() -> None:
    source, late = sample(), wm.Graph()
    reply = proto.answer_sync(source, proto.SyncRequest(late.replica_id, late.state_vector()), 1)
    late.insert_node("person", "bob")
    proto.apply_delta(late, reply)
    assert late.find_node("bob") is not None and late.find_node("four") is not None


def test_a_message_has_exactly_its_fields() -> None:
    for fields in ([7], [7, 4, 1]):  # ACK_REPLY: acked and on_disk, both
        with pytest.raises(wm.DecodeError):
            proto.decode(msgpack.packb([proto.VERSION, int(proto.Kind.ACK_REPLY), "a1", *fields]))
    with pytest.raises(wm.DecodeError):  # a SYNC_REPLY carries no index of the replier (version 1 did)
        proto.decode(msgpack.packb([proto.VERSION, int(proto.Kind.SYNC_REPLY), "a1", 1, b"\x00\x00", [], None]))


def test_a_message_of_version_1_is_refused() -> None:
    reply = msgpack.packb([1, int(proto.Kind.SYNC_REPLY), "a1", 1, b"\x00\x00", [], [[[1, "world", "w"]], []]])
    with pytest.raises(wm.DecodeError, match="version"):
        proto.decode(reply)


def test_sequence_tracker_sees_gaps_and_tails() -> None:
    tracker = proto.SequenceTracker()
    assert not tracker.on_delta("a", 1)
    assert not tracker.on_delta("a", 2)
    assert tracker.on_delta("a", 5)
    assert not tracker.on_heartbeat("a", 5) and tracker.on_heartbeat("a", 6)
    tracker.on_sync("a", 9)
    assert tracker.last["a"] == 9
    assert not tracker.on_heartbeat("b", 3), "an unknown sender is not behind by sequence"
