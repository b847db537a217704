"""Well-formed CRDT updates with content the layout or the ontology does not allow, sent as raw Zenoh puts.

Each case is one DELTA whose envelope is valid and whose pycrdt update writes
something hostile into the document's root maps. It is put on the network
next to ``wm serve`` and a replica, each in its own process. Then:

* both stay up and still sync a later legitimate write;
* both show the same graph, the one they showed before plus that write, and
  ``wm dump --format json`` is strict JSON;
* ``wm serve`` logs what it left out with the sender's replica id;
* after ``kill -9``, ``wm check --data`` lists the entry with its sender, and
  ``wm serve`` restarts from disk with the same graph.
"""

from __future__ import annotations

import json
import math
import subprocess
import time
from collections.abc import Callable
from pathlib import Path
from typing import Any

import pytest
import zenoh
from pycrdt import Doc, Map, Text

from procs import PYTHON, REPO, WM, Proc, endpoint, free_port, read_dump, wait_until
from wm.net import sync_protocol as proto
from wm.net.zenoh_config import build_config

GRAPH = "hostile"
ATTACKER = "mallory"
REPLICA = str(REPO / "tests" / "replica_proc.py")
Craft = Callable[[Map, Map, Map, dict[str, int]], None]


def run_wm(*args: str, check: bool = True) -> subprocess.CompletedProcess[str]:
    result = subprocess.run([*WM, *args, "--graph", GRAPH], capture_output=True, text=True, timeout=60, cwd=REPO)
    if check:
        assert result.returncode == 0, result.stderr
    return result


def strict_json(text: str) -> Any:
    def refuse(constant: str) -> None:
        raise ValueError(f"not JSON: {constant}")

    return json.loads(text, parse_constant=refuse)


def dumped(port: int) -> dict[str, Any]:
    return strict_json(run_wm("dump", "--format", "json", "--connect", endpoint(port)).stdout)


def start_serve(spawner, data: Path, port: int, name: str) -> Proc:
    proc = spawner([*WM, "serve", "--data", str(data), "--graph", GRAPH, "--listen", endpoint(port)], name=name)
    proc.wait_line("wm serve: ready", 20)
    return proc


class Attacker:
    """A raw Zenoh session that fetches the document and puts crafted DELTAs under its own replica id."""

    def __init__(self, port: int) -> None:
        self.session = zenoh.open(build_config(mode="peer", connect=[endpoint(port)], listen=["tcp/127.0.0.1:0"]))
        self.seq = 0

    def document(self) -> Doc:
        request = proto.encode(proto.SyncRequest(ATTACKER, b"\x00"))
        for reply in self.session.get(proto_key("sync/*"), payload=request, timeout=5.0):
            if reply.ok is not None:
                message = proto.decode(reply.ok.payload.to_bytes())
                if isinstance(message, proto.SyncReply):
                    doc = Doc()
                    doc.apply_update(message.update)
                    return doc
        raise AssertionError("no member answered the attacker's sync request")

    def put(self, update: bytes | None, volatile: list[Any] | None = None) -> None:
        self.seq += 1
        self.session.put(
            proto_key(f"delta/{ATTACKER}"), proto.encode(proto.Delta(ATTACKER, self.seq, update, volatile or []))
        )

    def put_raw(self, payload: bytes) -> None:
        self.session.put(proto_key(f"delta/{ATTACKER}"), payload)

    def close(self) -> None:
        self.session.close()


def proto_key(suffix: str) -> str:
    return f"wm/{GRAPH}/{suffix}"


def crafted_update(doc: Doc, craft: Craft) -> bytes:
    """One transaction of hostile writes on top of the fetched document, as a well-formed pycrdt update."""
    nodes, edges, edge_attrs = (doc.get(root, type=Map) for root in ("nodes", "edges", "edge_attrs"))
    ids = {str(node["@name"]): int(key) for key, node in nodes.items() if isinstance(node, Map)}
    before = doc.get_state()
    with doc.transaction():
        craft(nodes, edges, edge_attrs, ids)
    return doc.get_update(before)


def set_in(node: str, attr: str, value: Any) -> Craft:
    return lambda nodes, _e, _a, ids: nodes[str(ids[node])].__setitem__(attr, value)


def new_node(key: str, content: Any) -> Craft:
    return lambda nodes, _e, _a, _ids: nodes.__setitem__(key, content)


def nan_and_inf(nodes: Map, _edges: Map, _attrs: Map, ids: dict[str, int]) -> None:
    ball = nodes[str(ids["n0"])]
    ball["pos_x"] = math.nan
    ball["pos_y"] = -math.inf


def edge_shapes(_nodes: Map, edges: Map, edge_attrs: Map, ids: dict[str, int]) -> None:
    world, ball = ids["world"], ids["n1"]
    edges[f"{world}>{ball}>has"] = "yes"  # a marker that is not true
    edge_attrs["no-dot-here"] = 1
    edge_attrs[f"{world}>{ids['n0']}>RT.bogus"] = 2


CASES: dict[str, Craft] = {
    "non_integer_node_key": new_node("not-an-int", Map({"@type": "object", "@name": "intruder"})),
    "garbage_edge_key": lambda _n, edges, _a, _i: edges.__setitem__("garbage", 5),
    "id_of_2_to_the_70": new_node(str(2**70), Map({"@type": "object", "@name": "huge"})),
    "node_that_is_not_a_map": new_node("77", 5),
    "node_without_type": new_node("78", Map({"@name": "typeless"})),
    "node_of_unknown_type": new_node("79", Map({"@type": "bogus_type", "@name": "bogus"})),
    "wrong_value_type": set_in("n0", "pos_x", "str"),
    "unknown_attribute": set_in("n0", "bogus", 1),
    "shared_type_as_value": set_in("n0", "texture", Text("not a plain str")),
    "value_too_large": set_in("n0", "texture", "x" * 1_200_000),
    "nan_and_inf": nan_and_inf,
    "edge_marker_and_attribute_shapes": edge_shapes,
}


@pytest.fixture
def network(spawner, tmp_path: Path):
    """``wm serve`` with a world, a replica that wrote n0 and n1, and an attacker; yields what the cases need."""
    port = free_port()
    data = tmp_path / "data"
    serve = start_serve(spawner, data, port, "serve")
    scene = tmp_path / "world.json"
    scene.write_text(
        '{"format": "cortex-wm", "version": 1, "nodes": [{"id": 1, "type": "world", "name": "world", "attrs": {}}], "edges": []}'
    )
    run_wm("load", str(scene), "--connect", endpoint(port))
    dump = tmp_path / "replica.json"
    replica = spawner(
        [
            PYTHON,
            REPLICA,
            "--graph",
            GRAPH,
            "--name",
            "honest",
            "--dump",
            str(dump),
            "--connect",
            endpoint(port),
            "--nodes",
            "2",
        ],
        name="replica",
    )
    assert replica.wait_line("wrote", 30) == "wrote True"
    wait_until(lambda: {"world", "n0", "n1"} <= names(view(dump)), 20, "the replica's first dump")
    attacker = Attacker(port)
    try:
        yield {
            "port": port,
            "data": data,
            "serve": serve,
            "replica": replica,
            "dump": dump,
            "attacker": attacker,
            "spawner": spawner,
        }
    finally:
        attacker.close()


def view(dump: Path) -> dict[str, Any] | None:
    return (read_dump(dump) or {}).get("graph")


def names(graph: dict[str, Any] | None) -> set[str]:
    return {n["name"] for n in (graph or {}).get("nodes", [])}


def with_color(graph: dict[str, Any], color: str) -> dict[str, Any]:
    expected = json.loads(json.dumps(graph))
    node = next(n for n in expected["nodes"] if n["name"] == "n1")
    node["attrs"] = dict(sorted({**node["attrs"], "color": color}.items()))
    return expected


def survive_and_restart(net: dict[str, Any], expected: dict[str, Any], left_out: bool = True) -> None:
    """The checks every case shares, after the hostile message was put."""
    port, serve, replica, dump = net["port"], net["serve"], net["replica"], net["dump"]
    run_wm("set", "n1", "color=red", "--connect", endpoint(port))
    wait_until(lambda: view(dump) == expected, 20, "the replica to show the legitimate write")
    assert serve.popen.poll() is None and replica.popen.poll() is None
    assert dumped(port) == expected
    if left_out:
        serve.wait_line("", 10, contains=f"sent by {ATTACKER}")
    time.sleep(0.3)  # wm serve's promise covers what it applied more than 100 ms before a kill
    replica.stop()
    serve.kill9()
    report = subprocess.run(
        [*WM, "check", "--data", str(net["data"]), "--graph", GRAPH],
        capture_output=True,
        text=True,
        timeout=60,
        cwd=REPO,
    )
    assert report.returncode == (2 if left_out else 0), report.stdout + report.stderr
    if left_out:
        assert f"sent by disk:{ATTACKER}" in report.stdout, report.stdout
    start_serve(net["spawner"], net["data"], port, "serve-again")
    assert dumped(port) == expected


@pytest.mark.parametrize("case", sorted(CASES))
def test_a_hostile_update_is_left_out_and_nothing_breaks(network: dict[str, Any], case: str) -> None:
    before = view(network["dump"])
    assert before is not None
    attacker: Attacker = network["attacker"]
    attacker.put(crafted_update(attacker.document(), CASES[case]))
    survive_and_restart(network, with_color(before, "red"))


def test_volatile_records_of_the_wrong_shape_are_refused(network: dict[str, Any]) -> None:
    before = view(network["dump"])
    assert before is not None
    ball = next(n["id"] for n in before["nodes"] if n["name"] == "n0")
    network["attacker"].put(
        None,
        [
            ["n:not-an-id", "last_seen", 1.0, 10**6, ATTACKER],
            [f"n:{ball}", "last_seen", "str", 10**6, ATTACKER],
            [f"n:{ball}", "bogus", 1.0, 10**6, ATTACKER],
            [f"n:{ball}", "stamp", math.nan, 10**6, ATTACKER],
        ],
    )
    network["serve"].wait_line("", 10, contains=f"refused 4 volatile record(s) from {ATTACKER}")
    survive_and_restart(network, with_color(before, "red"), left_out=False)


def test_a_lone_surrogate_in_an_update_is_refused(network: dict[str, Any]) -> None:
    """pycrdt cannot write a lone surrogate, so the attacker patches one into the update's bytes (as UTF-8)."""
    before = view(network["dump"])
    assert before is not None
    attacker: Attacker = network["attacker"]
    update = crafted_update(attacker.document(), set_in("n0", "texture", "XYZ"))
    attacker.put_raw(proto.encode(proto.Delta(ATTACKER, 1, update.replace(b"XYZ", b"\xed\xa0\x80"), [])))
    survive_and_restart(network, with_color(before, "red"), left_out=False)


def test_a_name_takeover_is_logged_with_its_writer_and_both_nodes_stay_reachable(network: dict[str, Any]) -> None:
    """The lowest id keeps a name (docs/replication.md, "Names"); the rename names who caused it."""
    before = view(network["dump"])
    assert before is not None
    ball = next(n for n in before["nodes"] if n["name"] == "n0")
    network["attacker"].put(
        crafted_update(network["attacker"].document(), new_node("5", Map({"@type": "object", "@name": "n0"})))
    )
    logged = f"node {ball['id']} is renamed 'n0~{ball['id']}' (conflict shown by a change from {ATTACKER})"
    # Whichever replica applies the attacker's change first logs the conflict; the other may get the repair with it.
    wait_until(
        lambda: any(logged in line for proc in (network["serve"], network["replica"]) for line in proc.lines),
        10,
        "the rename logged with its writer",
    )
    expected = with_color(before, "red")
    for node in expected["nodes"]:
        if node["id"] == ball["id"]:
            node["name"] = f"n0~{ball['id']}"
    expected["nodes"] = sorted(
        [*expected["nodes"], {"id": 5, "type": "object", "name": "n0", "attrs": {}}], key=lambda n: n["id"]
    )
    survive_and_restart(network, expected, left_out=False)
