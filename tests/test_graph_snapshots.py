"""Kept snapshots and the lean write path: reads see every change, the check table agrees with the ontology."""

from __future__ import annotations

import math

import numpy as np
import pytest

import wm
from wm.events import EventFilter, EventHub, EventKind


@pytest.fixture
def g() -> wm.Graph:
    g = wm.Graph(replica_id="local")
    world = g.insert_node("world", "world")
    ann = g.insert_node("person", "ann", {"radius": 0.3})
    g.insert_or_assign_edge(world, ann, "RT", {"rt_translation": (1.0, 2.0, 0.0)})
    return g


def test_a_snapshot_is_kept_until_its_node_changes(g: wm.Graph) -> None:
    first = g.get_node("ann")
    assert g.get_node("ann") is first
    g.update_node("ann", {"radius": 0.5})
    assert g.get_node("ann").attrs["radius"] == 0.5
    g.update_node("ann", {"last_seen": 3.0})  # volatile
    assert g.get_node("ann").attrs["last_seen"] == 3.0
    g.delete_attr("ann", "radius")
    assert "radius" not in g.get_node("ann").attrs
    g.rename_node("ann", "anna")
    assert g.get_node("anna").name == "anna"


def test_an_edge_snapshot_is_kept_until_its_edge_changes(g: wm.Graph) -> None:
    first = g.get_edge("world", "ann", "RT")
    assert g.edges(src="world") == [first] and g.edges(src="world")[0] is first
    g.rt.set_pose2d("world", "ann", 4.0, 0.0, 0.0)
    assert g.get_edge("world", "ann", "RT").attrs["rt_translation"] == (4.0, 0.0, 0.0)
    g.insert_or_assign_edge("world", "ann", "RT", {"rt_translation": (5.0, 0.0, 0.0)})
    assert g.edges(src="world")[0].attrs["rt_translation"] == (5.0, 0.0, 0.0)
    g.delete_edge("world", "ann", "RT")
    assert g.edges(src="world") == []


def test_reads_inside_a_batch_see_its_writes(g: wm.Graph) -> None:
    g.get_node("ann")
    with g.batch():
        g.update_node("ann", {"radius": 0.7, "last_seen": 1.0})
        assert dict(g.get_node("ann").attrs) == {"radius": 0.7, "last_seen": 1.0}
        g.update_node("ann", {"radius": 0.8})
        assert g.get_node("ann").attrs["radius"] == 0.8
    assert g.get_node("ann").attrs["radius"] == 0.8


def test_remote_changes_reach_kept_snapshots(g: wm.Graph) -> None:
    other = wm.Graph(replica_id="other")
    other.apply_update(g.diff(), "local")
    before = other.get_node("ann")
    g.update_node("ann", {"radius": 0.9})
    other.apply_update(g.diff(other.state_vector()), "local")
    assert other.get_node("ann").attrs["radius"] == 0.9 and before.attrs["radius"] == 0.3
    g.update_node("ann", {"velocity": (1.0, 0.0)})
    other.merge_volatile(g.take_volatile_outbox(), "local")
    assert other.get_node("ann").attrs["velocity"] == (1.0, 0.0)
    g.delete_node("ann")
    other.apply_update(g.diff(other.state_vector()), "local")
    assert other.find_node("ann") is None and other.edges() == []


@pytest.mark.parametrize(
    ("attr", "value", "stored"),
    [
        ("radius", 2, 2.0),
        ("radius", np.float64(0.25), 0.25),
        ("track_id", np.int64(7), 7),
        ("velocity", [1, 2], (1.0, 2.0)),
        ("velocity", np.array([0.5, 1.5]), (0.5, 1.5)),
        ("velocity", (0.5, 1.5), (0.5, 1.5)),
    ],
)
def test_values_not_in_stored_form_are_coerced_as_the_ontology_says(
    g: wm.Graph, attr: str, value: object, stored: object
) -> None:
    g.update_node("ann", {attr: value})
    got = g.get_node("ann").attrs[attr]
    assert got == stored and type(got) is type(stored)


@pytest.mark.parametrize(
    ("attrs", "error"),
    [
        ({"radius": math.nan}, wm.AttributeTypeError),
        ({"radius": True}, wm.AttributeTypeError),
        ({"track_id": 2**53 + 1}, wm.AttributeTypeError),
        ({"velocity": (1.0, math.inf)}, wm.AttributeTypeError),
        ({"velocity": (1.0, 2.0, 3.0)}, wm.AttributeTypeError),
        ({"radius": 0.1, "kind": "ball"}, wm.UnknownAttributeError),  # kind is not a person's
    ],
)
def test_a_refused_write_writes_nothing(g: wm.Graph, attrs: dict, error: type[Exception]) -> None:
    before = g.get_node("ann")
    with pytest.raises(error):
        g.update_node("ann", attrs)
    assert g.get_node("ann") == before


def test_update_events_are_built_only_for_consumers_that_may_match() -> None:
    hub = EventHub()
    assert not hub.wants(EventKind.NODE_UPDATED, "person")
    sub = hub.subscribe(lambda event: None, EventFilter.of(kind="node_updated", type="object"))
    assert hub.wants(EventKind.NODE_UPDATED, "object")
    assert not hub.wants(EventKind.NODE_UPDATED, "person") and not hub.wants(EventKind.NODE_ADDED, "object")
    stream = hub.stream(EventFilter.of(name="ann"), 8)  # names are not looked at: any kind, any type
    assert hub.wants(EventKind.EDGE_UPDATED, "RT")
    stream.close()
    sub.cancel()
    assert not hub.wants(EventKind.NODE_UPDATED, "object")
