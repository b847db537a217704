"""A fuzzer of hostile documents: random pycrdt updates written into the layout's root maps.

Three replicas make legitimate writes while a hostile writer, synced from one
of them, writes random keys, shapes and values into ``nodes``, ``edges``,
``edge_attrs`` and ``deleted`` (also inside existing node maps). Every update
travels to every replica in a random order, duplicated or late. Then:

* no exception escapes ``apply_update`` or ``merge_volatile``;
* after a full exchange every replica shows the same graph, reports the same
  left-out entries, and dumps strict JSON;
* a replica rebuilt from the log that :class:`wm.persistence.Persister` wrote
  shows the same graph.

Draws never depend on the replicas' state, so that Hypothesis replays an
example exactly even though pycrdt draws its client ids at random.
"""

from __future__ import annotations

import json
import math
import tempfile
from pathlib import Path
from typing import Any

from hypothesis import HealthCheck, given, settings
from hypothesis import strategies as st
from pycrdt import Array, Doc, Map, Text

import wm
from test_graph_properties import REPLICAS
from test_graph_properties import Net as ReplicaNet
from wm.persistence import DiskLog, Persister

ROOTS = ("nodes", "edges", "edge_attrs", "deleted")

plain_values = st.one_of(
    st.none(),
    st.booleans(),
    st.integers(-(2**63) + 1, 2**63 - 1),
    st.floats(allow_nan=True, allow_infinity=True),
    st.text(max_size=8),
    st.binary(max_size=8),
    st.lists(st.floats(-10, 10), max_size=4),
    st.sampled_from(["object", "person", "bogus_type", "RT", "has", "", "@x"]),
)
real_ids = st.builds(
    lambda prefix, counter: str(prefix << 21 | counter), st.integers(1000, 1002), st.integers(1, 4)
)  # ids in use
keys = st.one_of(
    real_ids,
    st.builds(
        lambda a, b, t: f"{a}>{b}>{t}", real_ids, real_ids, st.sampled_from(["has", "RT", "has.status", "has.bogus"])
    ),
    st.sampled_from(["1", "2", "3", "0", "007", "-4", str(2**53), str(2**70), "not-an-int", "", "@type", "@name"]),
    st.integers(1, 2**60).map(str),
    st.text(max_size=10),
    st.builds(
        lambda a, b, t: f"{a}>{b}>{t}",
        st.sampled_from(["1", "2", "x", str(2**70)]),
        st.sampled_from(["1", "3", ""]),
        st.sampled_from(["RT", "has", "bogus", "has.status", ""]),
    ),
    st.builds(
        lambda k, a: f"{k}.{a}",
        st.sampled_from(["1>2>has", "1>2>RT", "x>y>z", "2>1>has"]),
        st.sampled_from(["status", "bogus", "rt_translation", "updated_at", ""]),
    ),
)
attr_names = st.sampled_from(["@type", "@name", "kind", "pos_x", "track_id", "size", "bogus", "radius", "texture", ""])


@st.composite
def shaped_values(draw: st.DrawFn) -> Any:
    """A value as a hostile writer would store it: plain, or a shared type (a node-like map, text, array)."""
    shape = draw(st.sampled_from(["plain", "plain", "plain", "map", "text", "array"]))
    if shape == "map":
        entries = draw(st.dictionaries(attr_names, plain_values, max_size=4))
        return Map(entries)
    if shape == "text":
        return Text(draw(st.text(max_size=5)))
    if shape == "array":
        return Array(draw(st.lists(plain_values, max_size=3)))
    return draw(plain_values)


class Net(ReplicaNet):
    """The property tests' three replicas and messages in flight, plus a hostile writer."""

    def hostile(self, base: int, writes: list[tuple[str, str, str | None, Any]]) -> None:
        """One update of ``writes``, made on a copy of replica ``base``'s document, sent to every replica."""
        doc = Doc()
        doc.apply_update(self.graphs[base].diff())
        before = doc.get_state()
        roots = {name: doc.get(name, type=Map) for name in ROOTS}
        with doc.transaction():
            for root, key, attr, value in writes:
                target = roots[root]
                if attr is not None and isinstance(target.get(key), Map):
                    target[key][attr] = value
                else:
                    target[key] = value
        update = doc.get_update(before)
        self.in_flight += [(dst, "crdt", update, "mallory") for dst in range(REPLICAS)]


def legitimate(net: Net, r: int, op: str, pick: int, value: float) -> None:
    graph = net.graphs[r]
    nodes = graph.nodes()
    node = nodes[pick % len(nodes)].id if nodes else None
    try:
        if op == "insert" or node is None:
            graph.insert_node("object", None, {"kind": "ball", "pos_x": value})
        elif op == "update":
            graph.update_node(node, {"pos_x": value, "last_seen": value})
        elif op == "edge":
            graph.insert_or_assign_edge(nodes[0].id, node, "has", {"status": "seen"})
        elif op == "delete":
            graph.delete_node(node)
    except wm.WMError:
        pass


def strict_json(graph: wm.Graph) -> str:
    return json.dumps(graph.to_dict(), allow_nan=False, sort_keys=True)


writes = st.lists(
    st.tuples(st.sampled_from(ROOTS), keys, st.one_of(st.none(), attr_names), shaped_values()), min_size=1, max_size=5
)


@settings(max_examples=40, deadline=None, suppress_health_check=[HealthCheck.too_slow])
@given(st.data())
def test_hostile_documents_never_break_a_replica_and_every_replica_shows_the_same_graph(data: st.DataObject) -> None:
    net = Net.build()
    with tempfile.TemporaryDirectory() as tmp:
        disk = DiskLog(Path(tmp))
        persister = Persister(net.graphs[0], disk)
        for _ in range(data.draw(st.integers(1, 25))):
            action = data.draw(st.sampled_from(["op", "op", "hostile", "deliver", "deliver", "volatile"]))
            r = data.draw(st.integers(0, REPLICAS - 1))
            if action == "op":
                op = data.draw(st.sampled_from(["insert", "update", "edge", "delete"]))
                legitimate(net, r, op, data.draw(st.integers(0, 50)), data.draw(st.floats(-5, 5)))
            elif action == "hostile":
                net.hostile(r, data.draw(writes))
            elif action == "volatile":
                owner = data.draw(st.sampled_from(["n:1", "n:x", "e:1>2>has", "e:garbage", "q:1"]))
                record = (
                    owner,
                    data.draw(attr_names),
                    data.draw(plain_values),
                    data.draw(st.integers(0, 9)),
                    "mallory",
                )
                net.graphs[r].merge_volatile([record], "mallory")
            elif net.in_flight:
                net.deliver(data.draw(st.integers(0, 10**6)) % len(net.in_flight), keep_copy=data.draw(st.booleans()))
            persister.flush()
        net.full_exchange()
        persister.flush()
        views = [strict_json(graph) for graph in net.graphs]
        assert views[1] == views[0] and views[2] == views[0]
        left_out = [[(e.kind, e.key, e.reason) for e in graph.left_out()] for graph in net.graphs]
        assert left_out[1] == left_out[0] and left_out[2] == left_out[0]
        disk.close()
        reloaded = wm.Graph(replica_id="reloaded")
        DiskLog(Path(tmp)).load_into(reloaded)
        assert strict_json(reloaded) == views[0]
        assert [(e.kind, e.key, e.reason) for e in reloaded.left_out()] == left_out[0]
        for graph in net.graphs:
            for node in graph.nodes():
                assert all(not isinstance(v, float) or math.isfinite(v) for v in node.attrs.values())
