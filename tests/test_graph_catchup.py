"""A fresh replica's catch-up: the index built in one pass shows what the general path shows, and nothing leaks."""

from __future__ import annotations

import gc
import weakref
from typing import Any

from hypothesis import HealthCheck, given, settings
from hypothesis import strategies as st
from pycrdt import Doc, Map

import wm
from wm.crdt_store import CrdtStore
from wm.view_rules import node_id_of

node_keys = st.one_of(
    st.integers(1, 2**53 + 2).map(str),
    st.sampled_from(["0", "007", "-4", "1.0", "", "٣", "１２", str(2**53 - 1), str(2**53), str(2**70), "@type"]),
    st.text(max_size=6),
)
names = st.one_of(
    st.text(max_size=12),
    st.sampled_from(["ball", "@ball", "", "é", "名前", "x" * 256, "x" * 257, "é" * 256, "é" * 257]),
    st.integers(-1000, 1000),
    st.none(),
)
node_types = st.one_of(
    st.sampled_from(["object", "person", "world", "bogus", "", "RT"]), st.integers(-1000, 1000), st.none()
)
heads = st.one_of(st.none(), st.tuples(node_types, names))


def document(entries: dict[str, tuple[Any, Any] | None]) -> bytes:
    """One update holding each entry as a node map with that head (None: a plain value instead of a map)."""
    doc: Doc[Any] = Doc()
    nodes = doc.get("nodes", type=Map)
    with doc.transaction():
        for key, head in entries.items():
            if head is None:
                nodes[key] = "not a map"
                continue
            node: dict[str, Any] = {"kind": "ball"}
            for field, value in zip(("@type", "@name"), head, strict=True):
                if value is not None:
                    node[field] = value
            nodes[key] = Map(node)
    return doc.get_update()


@settings(max_examples=150, deadline=None, suppress_health_check=[HealthCheck.too_slow])
@given(st.dictionaries(node_keys, heads, max_size=12))
def test_a_catch_up_shows_and_leaves_out_what_the_general_path_does(entries: dict[str, tuple[Any, Any] | None]) -> None:
    update = document(entries)
    caught_up, general = wm.Graph(replica_id="fresh"), wm.Graph(replica_id="general")
    caught_up.load_fresh(update, "peer")
    general.apply_update(update, "peer")
    assert sorted((n.id, n.type, n.name) for n in caught_up.nodes()) == sorted(
        (n.id, n.type, n.name) for n in general.nodes()
    )
    # the same entries for the same reasons (a catch-up checks attribute values as they are read, not from whom)
    assert sorted((e.kind, e.key, e.reason) for e in caught_up.left_out()) == sorted(
        (e.kind, e.key, e.reason) for e in general.left_out()
    )


@given(st.dictionaries(node_keys, heads, max_size=12))
def test_the_one_pass_sort_of_node_heads_admits_only_what_the_full_checks_admit(
    entries: dict[str, tuple[Any, Any] | None],
) -> None:
    rules = wm.Graph()._rules
    shown, others = rules.plain_nodes(entries)
    assert sorted([str(node_id) for node_id, _ in shown] + others) == sorted(entries)
    for node_id, head in shown:
        assert node_id_of(str(node_id)) == node_id and entries[str(node_id)] is head
        assert rules.node_problem(*head) is None


def test_a_dropped_replica_frees_its_document() -> None:
    store = CrdtStore()
    dropped = weakref.ref(store)
    del store
    assert dropped() is None  # pycrdt holds the observers from the document: they must not hold the store
    graph = wm.Graph()
    graph.insert_node("object", "ball")
    dropped = weakref.ref(graph._store)
    del graph
    gc.collect()
    assert dropped() is None
