"""Scenes as JSON (ours and DSR's), atomic loads, and the binary state (encode_state / load_state)."""

from __future__ import annotations

import json
from pathlib import Path

import msgpack
import pytest

import wm
from graph_helpers import Recorder, assert_refused


def sample_graph() -> wm.Graph:
    g = wm.Graph(replica_id="src")
    world = g.insert_node("world", "world", {"room_size": (6, 4), "description": "flat"})
    robot = g.insert_node("robot", "robot", {"max_speed": 1.0, "velocity": (0.1, 0.0)})
    ann = g.insert_node("person", "ann", {"track_id": 7, "gaze_range": (-0.5, 0.2), "last_seen": 3.5})
    ball = g.insert_node("object", "ball", {"kind": "ball", "is_obstacle": True, "size": (0.2, 0.2, 0.2)})
    g.rt.set_pose2d(world, robot, 1, 2, 0.5)
    g.rt.set_pose2d(world, ann, 3, 1, -1.0)
    g.rt.set_pose2d(world, ball, 2, 2, 0)
    g.insert_or_assign_edge(ann, ball, "has_intention", {"risky": True, "path": [0, 0, 1, 1], "stamp": 2.0})
    return g


def test_json_round_trip_gives_an_identical_graph(tmp_path: Path) -> None:
    g = sample_graph()
    text = g.to_json()
    fresh = wm.Graph()
    report = fresh.load_json(text)
    assert (report.nodes, report.edges, report.skipped) == (4, 4, [])
    assert fresh.to_dict() == g.to_dict()
    path = tmp_path / "scene.json"
    path.write_text(text)
    from_file = wm.Graph()
    from_file.load_json(path)
    assert from_file.to_dict() == g.to_dict()
    from_str_path = wm.Graph()
    from_str_path.load_json(str(path))
    assert from_str_path.to_dict() == json.loads(text)


def test_load_without_keeping_ids_remaps_them() -> None:
    g = sample_graph()
    fresh = wm.Graph()
    report = fresh.load_json(g.to_dict(), keep_ids=False)
    assert set(report.id_map) == {n.id for n in g.nodes()}
    assert set(report.id_map.values()) == {n.id for n in fresh.nodes()}
    assert sorted(n.name for n in fresh.nodes()) == sorted(n.name for n in g.nodes())
    assert fresh.rt.pose2d("world", "ann") == pytest.approx(g.rt.pose2d("world", "ann"))


DSR_SCENE = {
    "DSRModel": {
        "symbols": {
            "100": {
                "id": "100",
                "name": "world",
                "type": "world",
                "attribute": {
                    "level": {"type": 1, "value": 0},
                    "parent": {"type": 7, "value": "0"},
                    "pos_x": {"type": 2, "value": -350},
                    "pos_y": {"type": 2, "value": 12.5},
                    "color": {"type": 0, "value": "SeaGreen"},
                    "OuterRegionLeft": {"type": 1, "value": -5000},
                },
                "links": [
                    {
                        "src": "100",
                        "dst": "200",
                        "label": "RT",
                        "linkAttribute": {
                            "rt_translation": {"type": 3, "value": [1.5, -2.0, 0.0]},
                            "rt_rotation_euler_xyz": {"type": 3, "value": [0.0, 0.0, 1.5707963]},
                        },
                    },
                    {
                        "src": "100",
                        "dst": "300",
                        "label": "RT",
                        "linkAttribute": {
                            "rt_translation": {"type": 3, "value": [0.0, 3.0, 0.0]},
                            "rt_rotation_euler_xyz": {"type": 3, "value": [0.0, 0.0, 0.0]},
                            "rt_parent_id": {"type": 7, "value": "100"},
                        },
                    },
                ],
            },
            "200": {
                "id": "200",
                "name": "robot",
                "type": "omnirobot",
                "attribute": {
                    "level": {"type": 1, "value": 1},
                    "parent": {"type": 7, "value": "100"},
                    "max_speed": {"type": 2, "value": 0.8},
                    "base_target_x": {"type": 2, "value": 0},
                },
                "links": [
                    {
                        "src": "200",
                        "dst": "201",
                        "label": "RT",
                        "linkAttribute": {
                            "rt_translation": {"type": 3, "value": [0.1, 0, 1.0]},
                            "rt_rotation_euler_xyz": {"type": 3, "value": [0, 0, 0]},
                        },
                    }
                ],
            },
            "201": {
                "id": "201",
                "name": "camera",
                "type": "rgbd",
                "attribute": {
                    "level": {"type": 1, "value": 2},
                    "parent": {"type": 7, "value": "200"},
                    "cam_rgb": {"type": 5, "value": [1, 2]},
                },
                "links": [],
            },
            "300": {
                "id": "300",
                "name": "wall_1",
                "type": "wall",
                "attribute": {"size": {"type": 3, "value": [4.0, 0.1, 2.5]}, "parent": {"type": 7, "value": "100"}},
            },
        }
    }
}


def test_dsr_scene_imports_with_skipped_attributes_reported() -> None:
    g = wm.Graph()
    report = g.load_json(json.dumps(DSR_SCENE))
    assert (report.nodes, report.edges) == (4, 3)
    assert sorted(report.skipped) == sorted(
        [
            "edge 100-[RT]->300.rt_parent_id",
            "node 'robot'.base_target_x",
            "node 'robot'.max_speed",
            "node 'wall_1'.size",
        ]
    )
    world = g.get_node(100)
    assert (world.type, world.name) == ("world", "world")
    assert world.attrs == {
        "level": 0,
        "parent": 0,
        "pos_x": -350.0,
        "pos_y": 12.5,
        "color": "SeaGreen",
        "OuterRegionLeft": -5000,
    }
    assert g.get_node("robot").attrs == {"level": 1, "parent": 100}
    assert g.get_node("camera").attrs["cam_rgb"] == bytes([1, 2])
    x, y, yaw = g.rt.pose2d("world", "camera")
    assert (x, y, yaw) == pytest.approx((1.5, -1.9, 1.5707963))
    assert g.rt.transform("world", "camera")[2] == pytest.approx(1.0)


def test_dsr_symbols_as_a_list_import() -> None:
    scene = {"DSRModel": {"symbol": list(DSR_SCENE["DSRModel"]["symbols"].values())}}
    g = wm.Graph()
    assert g.load_json(scene).nodes == 4


def test_dsr_byte_vectors_import_as_bytes() -> None:
    ontology = wm.Ontology.from_dict(
        {"attributes": {"blob": {"type": "bytes"}}, "nodes": {"camera": {"attributes": ["blob"]}}}
    )
    symbol = {
        "id": "7",
        "name": "cam",
        "type": "camera",
        "attribute": {"blob": {"type": 5, "value": [0, 1, 255]}},
        "links": [],
    }
    g = wm.Graph(ontology)
    g.load_json({"DSRModel": {"symbols": {"7": symbol}}})
    assert g.get_node("cam").attrs["blob"] == b"\x00\x01\xff"
    symbol["attribute"]["blob"]["value"] = [256]
    with pytest.raises(wm.SceneFormatError):
        wm.Graph(ontology).load_json({"DSRModel": {"symbols": {"7": symbol}}})


def _bad_scenes() -> list[tuple[object, type]]:
    good = sample_graph().to_dict()
    dup_name = json.loads(json.dumps(good))
    dup_name["nodes"][-1]["name"] = "world"
    dangling = json.loads(json.dumps(good))
    dangling["edges"].append({"src": good["nodes"][0]["id"], "dst": 999, "type": "has", "attrs": {}})
    bad_attr = json.loads(json.dumps(good))
    bad_attr["nodes"][-1]["attrs"]["kind"] = 5
    bad_name = json.loads(json.dumps(good))
    bad_name["nodes"][-1]["name"] = "@ball"
    bad_id = json.loads(json.dumps(good))
    bad_id["nodes"][-1]["id"] = 0
    two_parents = json.loads(json.dumps(good))
    ids = [n["id"] for n in good["nodes"]]
    two_parents["edges"].append({"src": ids[1], "dst": ids[2], "type": "RT", "attrs": {}})
    cycle = json.loads(json.dumps(good))
    cycle["edges"].append({"src": ids[2], "dst": ids[0], "type": "RT", "attrs": {}})
    dsr_big_int = json.loads(json.dumps(DSR_SCENE))
    dsr_big_int["DSRModel"]["symbols"]["300"]["attribute"]["parent"]["value"] = (
        "18446744073709551616"  # 2**64: past uint64
    )
    dsr_unknown_type = json.loads(json.dumps(DSR_SCENE))
    dsr_unknown_type["DSRModel"]["symbols"]["300"]["type"] = "dragon"
    dsr_no_name = json.loads(json.dumps(DSR_SCENE))
    del dsr_no_name["DSRModel"]["symbols"]["300"]["name"]
    return [
        (dup_name, wm.NameExistsError),
        (dangling, wm.SceneFormatError),
        (bad_attr, wm.AttributeTypeError),
        (bad_name, wm.ValidationError),
        (bad_id, wm.ValidationError),
        (two_parents, wm.SceneFormatError),
        (cycle, wm.SceneFormatError),
        (dsr_big_int, wm.AttributeTypeError),
        (dsr_unknown_type, wm.UnknownTypeError),
        (dsr_no_name, wm.SceneFormatError),
        ({"format": "cortex-wm", "version": 2, "nodes": []}, wm.SceneFormatError),
        ({"nodes": []}, wm.SceneFormatError),
        ("{not json", wm.SceneFormatError),
        ("[1, 2]", wm.SceneFormatError),
        ("/no/such/scene.json", wm.SceneFormatError),
    ]


@pytest.mark.parametrize(("scene", "error"), _bad_scenes())
def test_a_bad_scene_writes_nothing(scene: object, error: type) -> None:
    g = wm.Graph()
    g.insert_node("object", "existing")
    assert_refused(g, Recorder(g), error, lambda: g.load_json(scene))  # type: ignore[arg-type]


def test_a_scene_clashing_with_the_graph_writes_nothing() -> None:
    g = sample_graph()
    assert_refused(g, Recorder(g), wm.NameExistsError, lambda: g.load_json(g.to_dict(), keep_ids=False))
    deleted = wm.Graph()
    node = deleted.insert_node("object", "gone")
    deleted.delete_node(node)
    scene = {
        "format": "cortex-wm",
        "version": 1,
        "nodes": [{"id": node, "type": "object", "name": "back"}],
        "edges": [],
    }
    assert_refused(deleted, Recorder(deleted), wm.NodeExistsError, lambda: deleted.load_json(scene))


def test_state_round_trip_includes_volatile_registers() -> None:
    g = sample_graph()
    g.delete_attr("ann", "last_seen")
    data = g.encode_state()
    fresh = wm.Graph()
    fresh.load_state(data)
    assert fresh.to_dict() == g.to_dict()
    assert fresh.get_node("robot").attrs["velocity"] == (0.1, 0.0)
    assert "last_seen" not in fresh.get_node("ann").attrs
    assert sorted(map(repr, fresh.volatile_records())) == sorted(map(repr, g.volatile_records()))
    fresh.load_state(data)  # loading twice changes nothing
    assert fresh.to_dict() == g.to_dict()


def test_state_merge_into_a_live_replica_keeps_newer_volatile_values() -> None:
    g = sample_graph()
    old = g.encode_state()
    g.update_node("robot", {"velocity": (9.0, 9.0)})
    g.load_state(old, writer="disk")
    assert g.get_node("robot").attrs["velocity"] == (9.0, 9.0)


def _malformed() -> list[bytes]:
    g = sample_graph()
    return [
        b"",
        b"\xc1",
        b"garbage!",
        msgpack.packb([1, 2, 3]),
        msgpack.packb({"v": 1, "crdt": b"\x01\x02", "volatile": []}),
        msgpack.packb({"v": 1, "crdt": "text", "volatile": []}),
        msgpack.packb({"v": 1, "crdt": g.diff(), "volatile": [["n:1", "speed", 1.0, 1]]}),
        msgpack.packb({"v": 1, "crdt": g.diff(), "volatile": [[1, "speed", 1.0, 1, "w"]]}),
        msgpack.packb({"v": 1, "crdt": g.diff(), "volatile": [["x:1", "speed", 1.0, 1, "w"]]}),
        msgpack.packb({"v": 1, "crdt": g.diff(), "volatile": [["n:1", "speed", 1.0, "1", "w"]]}),
        msgpack.packb({"v": 1, "crdt": g.diff(), "volatile": "none"}),
    ]


@pytest.mark.parametrize("data", _malformed())
def test_malformed_state_raises_decode_error_and_leaves_the_graph_intact(data: bytes) -> None:
    g = wm.Graph(replica_id="victim")
    g.insert_node("person", "ann", {"speed": 1.0, "last_seen": 2.0})
    assert_refused(g, Recorder(g), wm.DecodeError, lambda: g.load_state(data))


@pytest.mark.parametrize("data", [b"\x01", b"\x05\x02\x03", b"not an update", b"\x01\x01\xff\xff\xff\xff\x0f"])
def test_malformed_update_raises_decode_error_and_leaves_the_graph_intact(data: bytes) -> None:
    g = wm.Graph(replica_id="victim")
    g.insert_node("person", "ann", {"speed": 1.0})
    assert_refused(g, Recorder(g), wm.DecodeError, lambda: g.apply_update(data, "evil"))
    g.update_node("ann", {"speed": 2.0})  # the replica still works
    assert g.get_node("ann").attrs["speed"] == 2.0


@pytest.mark.parametrize("state_vector", [b"\x01", b"\x05\x02\x03", b"not a state vector"])
def test_malformed_state_vector_raises_decode_error(state_vector: bytes) -> None:
    g = sample_graph()
    assert_refused(g, Recorder(g), wm.DecodeError, lambda: g.diff(state_vector))


def test_diff_brings_a_replica_up_to_date_and_updates_are_idempotent() -> None:
    a, b = sample_graph(), wm.Graph(replica_id="b")
    b.apply_update(a.diff(b.state_vector()), "src")
    b.merge_volatile(a.volatile_records(), "src")
    b.apply_update(a.diff(), "src")
    assert b.to_dict() == a.to_dict()
    assert a.diff(b.state_vector()) == a.diff(a.state_vector())
