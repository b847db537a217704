"""The packaged DSR ontology: complete against DSR's registry, every value type round-trips, real scenes load."""

from __future__ import annotations

import json
import re
from pathlib import Path
from typing import Any

import numpy as np
import pytest

import wm
from graph_helpers import Recorder, assert_refused
from wm import dsr_json

DATA = Path(__file__).resolve().parents[1] / "data" / "dsr"
TYPES_MD = (DATA / "types.md").read_text(encoding="utf-8")
AUTONOMY_LAB = DATA / "autonomyLab_objects.simscene.json"
# DSR's value type -> (our value type, fixed vector length)
HELD_AS = {
    "string": ("str", None),
    "int": ("int", None),
    "float": ("float", None),
    "float vector": ("vec", None),
    "bool": ("bool", None),
    "byte vector": ("bytes", None),
    "uint32": ("int", None),
    "uint64": ("u64", None),
    "double": ("float", None),
    "uint64 vector": ("u64vec", None),
    "float[2]": ("vec", 2),
    "float[3]": ("vec", 3),
    "float[4]": ("vec", 4),
    "float[6]": ("vec", 6),
}


def _listed(title: str) -> list[str]:
    match = re.search(rf"^## {title} \((\d+)\)\n\n(.+)$", TYPES_MD, re.M)
    assert match is not None, title
    names = [name.strip() for name in match.group(2).split(",")]
    assert len(names) == int(match.group(1))
    return names


def _attribute_rows() -> list[tuple[str, str, bool]]:
    rows = re.findall(r"^\| (\w+) \| ([^|]+?) \| (yes|no) \|$", TYPES_MD, re.M)
    assert len(rows) == int(re.search(r"^## Attributes \((\d+)\)", TYPES_MD, re.M).group(1))  # type: ignore[union-attr]
    return [(name, value_type, stream == "yes") for name, value_type, stream in rows]


@pytest.mark.parametrize("name", ["dsr", "default"])
def test_every_dsr_type_and_attribute_is_declared_with_its_value_type(name: str) -> None:
    ontology = wm.Ontology.named(name)
    node_types, edge_types, rows = _listed("Node types"), _listed("Edge types"), _attribute_rows()
    assert set(node_types) <= set(ontology.node_types)
    assert set(edge_types) <= set(ontology.edge_types)
    for attr, dsr_type, stream in rows:
        for element in (ontology.node_type("mesh"), ontology.edge_type("RT")):
            spec = ontology.attribute_for(element, attr)  # DSR allows any attribute on any node or edge
            if name == "dsr" or attr not in {"rt_translation", "rt_rotation_euler_xyz"}:
                assert (spec.type, spec.length) == HELD_AS[dsr_type], attr
            assert spec.dsr == dsr_type, attr
            assert spec.volatile == stream, attr
    dsr = wm.Ontology.named("dsr")
    assert (len(dsr.node_types), len(dsr.edge_types), len(dsr.attributes)) == (
        len(node_types),
        len(edge_types),
        len(rows),
    )
    for type_name in node_types:
        assert dsr.node_type(type_name).attributes == {attr for attr, _, _ in rows}


def test_ontologies_are_selected_by_name_and_by_path(tmp_path: Path) -> None:
    assert wm.Ontology.load("dsr").source == "dsr"
    with pytest.raises(wm.OntologyError, match="known: base, caregiving, default, dsr"):
        wm.Ontology.named("dragon")
    mine = tmp_path / "mine.yaml"
    mine.write_text(
        "include: [dsr]\nattributes:\n  wheel_radius: float\nnodes:\n  omnirobot: {attributes: [wheel_radius]}\n"
    )
    ontology = wm.Ontology.load(mine)
    assert {"wheel_radius", "robot_ref_adv_speed"} <= ontology.node_type("omnirobot").attributes
    assert "person" in ontology.node_types


def test_the_caregiving_path_and_dsr_path_keep_their_own_types_in_the_default_ontology() -> None:
    g = wm.Graph()
    mesh = g.insert_node("mesh", "cup_mesh", {"path": "/meshes/cup.ive"})
    person, ball = g.insert_node("person", "alice"), g.insert_node("object", "ball")
    g.insert_or_assign_edge(person, ball, "has_intention", {"path": [0.0, 0.0, 1.0, 1.0]})
    assert g.get_node(mesh).attrs["path"] == "/meshes/cup.ive"
    assert g.get_edge(person, ball, "has_intention").attrs["path"] == (0.0, 0.0, 1.0, 1.0)
    with pytest.raises(wm.AttributeTypeError):
        g.update_node(mesh, {"path": [1.0, 2.0]})
    copy = wm.Graph()
    copy.load_state(g.encode_state())
    assert copy.get_node(mesh).attrs["path"] == "/meshes/cup.ive"


def _every_value_type() -> dict[str, dict[str, Any]]:
    """One DSR attribute of each of DSR's 14 value types, as DSR writes them, including the extremes."""
    return {
        "name": {"type": 0, "value": "kitchen robot"},
        "level": {"type": 1, "value": -2147483648},
        "pos_x": {"type": 2, "value": -121.546974},
        "laser_angles": {"type": 3, "value": [0.5, -1.25, 3.0]},
        "active": {"type": 4, "value": True},
        "cam_rgb": {"type": 5, "value": [0, 7, 255]},
        "agent_id": {"type": 6, "value": -1},  # uint32 4294967295, written as its int32 bit pattern
        "timestamp_creation": {"type": 7, "value": "18446744073709551615"},
        "test_double_type": {"type": 8, "value": 0.1234567890123},
        "test_uint64_vec_type": {"type": 9, "value": ["18446744073709551615", "0", "9007199254740993"]},
        "test_vec2_type": {"type": 10, "value": [1.5, 2.5]},
        "test_vec3_type": {"type": 11, "value": [1.0, 2.0, 3.0]},
        "test_vec4_type": {"type": 12, "value": [1.0, 2.0, 3.0, 4.0]},
        "test_vec6_type": {"type": 13, "value": [1.0, 2.0, 3.0, 4.0, 5.0, 6.0]},
    }


def _scene() -> dict[str, Any]:
    link = {
        "dst": "9007199254740000",
        "label": "RT",
        "src": "1",
        "linkAttribute": {
            **_every_value_type(),
            "rt_translation": {"type": 3, "value": [1.0, 2.0, 0.0]},
            "rt_rotation_euler_xyz": {"type": 3, "value": [0.0, 0.0, 1.5]},
        },
    }
    return {
        "DSRModel": {
            "symbols": {
                "1": {"attribute": _every_value_type(), "id": "1", "links": [link], "name": "root", "type": "root"},
                "9007199254740000": {
                    "attribute": {"parent": {"type": 7, "value": "1"}},
                    "id": "9007199254740000",
                    "links": [],
                    "name": "robot",
                    "type": "omnirobot",
                },
            }
        }
    }


@pytest.mark.parametrize("name", ["dsr", "default"])
def test_every_dsr_value_type_loads_and_is_written_back_the_same(name: str, tmp_path: Path) -> None:
    g = wm.Graph(wm.Ontology.named(name))
    report = g.load_json(_scene())
    assert (report.nodes, report.edges, report.skipped) == (2, 1, [])
    root = g.get_node("root").attrs
    assert root["timestamp_creation"] == 2**64 - 1
    assert root["agent_id"] == 2**32 - 1
    assert root["test_uint64_vec_type"] == (2**64 - 1, 0, 2**53 + 1)
    assert root["cam_rgb"] == bytes([0, 7, 255])
    assert (
        root["level"] == -(2**31)
        and root["active"] is True
        and root["test_vec6_type"] == (1.0, 2.0, 3.0, 4.0, 5.0, 6.0)
    )
    assert g.get_edge("root", "robot", "RT").attrs["timestamp_creation"] == 2**64 - 1
    assert dsr_json.graph_to_dsr(g) == _scene()

    replica = wm.Graph(wm.Ontology.named(name))  # and through the CRDT and the volatile registers
    replica.load_state(g.encode_state())
    assert dsr_json.graph_to_dsr(replica) == _scene()


def test_a_dsr_file_of_a_graph_built_natively_loads_back(tmp_path: Path) -> None:
    g = wm.Graph()
    world = g.insert_node("world", "world", {"room_size": [6.0, 4.0], "episode": 3})
    alice = g.insert_node("person", "alice", {"radius": 0.3, "person_id": 7, "track_id": 2**40})
    g.rt.set_pose2d(world, alice, 1.0, 2.0, 0.5)
    g.insert_or_assign_edge(alice, world, "has_intention", {"path": np.array([0.0, 1.0, 2.0, 3.0]), "risky": True})
    written = dsr_json.graph_to_dsr(g)
    assert written["DSRModel"]["symbols"][str(alice)]["attribute"]["track_id"] == {"type": 7, "value": str(2**40)}
    copy = wm.Graph()
    copy.load_json(json.loads(json.dumps(written)))
    assert copy.to_dict() == g.to_dict()


def test_the_real_autonomy_lab_scene_loads_with_either_ontology() -> None:
    for name in ("default", "dsr"):
        g = wm.Graph(wm.Ontology.named(name))
        report = g.load_json(AUTONOMY_LAB)
        assert (report.nodes, report.edges) == (41, 43)
        assert {n.type for n in g.nodes()} == {
            "root",
            "transform",
            "plane",
            "mesh",
            "omnirobot",
            "laser",
            "rgbd",
            "pan_tilt",
            "left_hand",
            "room",
            "object",
        }
        assert g.get_node("viriato_mesh").attrs["path"] == "../../etc/viriato_base_concept_3/viriato_mesh.ive"
        assert g.get_node("viriato_head_camera_sensor").attrs["cam_depth_focalx"] == 554
        assert g.get_node("fridge").attrs["obj_interaction_shape"] == "trapezoid"
        assert g.find_edge("fridge", "fridge", "interactive") is not None
        # the laser sits 400 mm ahead on the body, which the robot places at (1324.5, 238.8), turned by -0.6996 rad
        x, y, _ = g.rt.pose2d("root", "laser")
        yaw = -0.6995884776115417
        assert (x, y) == pytest.approx((1324.4864501953125 - 400 * np.sin(yaw), 238.7539825439453 + 400 * np.cos(yaw)))
        # attributes DSR does not register either (viewer and simulator settings) are listed, not dropped silently
        assert "node 'viriato_head_camera_sensor'.ifconfig" in report.skipped


def test_a_file_dsr_wrote_with_node_id_0_loads_with_fresh_ids() -> None:
    path = DATA / "write_initial_dsr2.json"
    g = wm.Graph()
    with pytest.raises(wm.ValidationError, match="--new-ids"):
        g.load_json(path)
    assert g.node_count() == 0
    report = g.load_json(path, keep_ids=False)
    assert report.nodes == 1 and g.get_node("world").attrs["OuterRegionRight"] == 7500


@pytest.mark.parametrize(
    ("ontology", "node_type", "edge_type", "expected"),
    [
        (
            "dsr",
            "world",
            "RT",
            "node type 'world', which ontology 'dsr' does not declare; use the ontology that declares it: --ontology default",
        ),
        (
            "default",
            "dragon",
            "RT",
            "node type 'dragon', which ontology 'default' does not declare; no packaged ontology declares it",
        ),
        (
            "dsr",
            "root",
            "risky_to",
            "edge type 'risky_to', which ontology 'dsr' does not declare; no packaged ontology",
        ),
        ("dsr", "root", "collision", None),
    ],
)
def test_a_dsr_file_with_an_undeclared_type_is_refused_in_one_line_and_writes_nothing(
    ontology: str, node_type: str, edge_type: str, expected: str | None
) -> None:
    g = wm.Graph(wm.Ontology.named(ontology))
    g.insert_node("root", "existing")
    scene = _scene()
    scene["DSRModel"]["symbols"]["1"]["type"] = node_type
    scene["DSRModel"]["symbols"]["1"]["links"][0]["label"] = edge_type
    if expected is None:
        g.load_json(scene)
        return
    error = assert_refused(g, Recorder(g), wm.UnknownTypeError, lambda: g.load_json(scene))
    assert expected in str(error) and "\n" not in str(error)


@pytest.mark.parametrize(
    ("entry", "error"),
    [
        ({"type": 14, "value": 1}, "unknown DSR attribute type code 14"),
        ({"type": 7, "value": "twelve"}, "uint64"),
        ({"type": 5, "value": "abc"}, "byte vector"),
        ({"type": 1, "value": 1.5}, "not an integer"),
    ],
)
def test_a_malformed_dsr_value_is_refused_and_writes_nothing(entry: dict[str, Any], error: str) -> None:
    g = wm.Graph()
    scene = _scene()
    scene["DSRModel"]["symbols"]["1"]["attribute"]["level"] = entry
    refused = assert_refused(g, Recorder(g), wm.SceneFormatError, lambda: g.load_json(scene))
    assert error in str(refused) and "node 'root'.level" in str(refused)


def test_a_value_past_the_dsr_type_is_refused() -> None:
    g = wm.Graph()
    scene = _scene()
    scene["DSRModel"]["symbols"]["1"]["attribute"]["timestamp_creation"]["value"] = str(2**64)
    assert_refused(g, Recorder(g), wm.AttributeTypeError, lambda: g.load_json(scene))
