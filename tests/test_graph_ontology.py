"""The ontology as data: loading errors name the offending key; every write is validated."""

from __future__ import annotations

from pathlib import Path

import numpy as np
import pytest

import wm
from graph_helpers import Recorder, assert_refused

GOOD = """
attributes:
  n: int
  x: {type: float}
  flag: bool
  label: str
  blob: bytes
  pose: {type: vec, length: 3, volatile: true}
  path: vec
nodes:
  thing: {attributes: [n, x, flag, label, blob, pose, path]}
  other: {}
edges:
  link: {attributes: [x, pose]}
"""


@pytest.fixture
def g(tmp_path: Path) -> wm.Graph:
    path = tmp_path / "ontology.yaml"
    path.write_text(GOOD)
    return wm.Graph(wm.Ontology.load(path), replica_id="local")


@pytest.fixture
def rec(g: wm.Graph) -> Recorder:
    return Recorder(g)


def test_default_ontology_covers_the_caregiving_scenario() -> None:
    ontology = wm.Ontology.default()
    assert {"world", "robot", "person", "object", "intention", "agent"} <= set(ontology.node_types)
    assert {"RT", "has_intention", "collision", "has"} <= set(ontology.edge_types)
    assert ontology.is_volatile("rt_translation") and not ontology.is_volatile("radius")


def test_a_loaded_file_replaces_the_default(g: wm.Graph) -> None:
    assert set(g.ontology.node_types) == {"thing", "other"}
    assert g.ontology.attributes["pose"] == wm.AttributeSpec("pose", "vec", 3, True)
    with pytest.raises(wm.UnknownTypeError):
        g.insert_node("person")


def test_json_ontology_loads(tmp_path: Path) -> None:
    path = tmp_path / "o.json"
    path.write_text('{"attributes": {"n": "int"}, "nodes": {"t": {"attributes": ["n"]}}, "edges": {}}')
    assert wm.Ontology.load(path).node_types["t"].attributes == {"n"}


@pytest.mark.parametrize(
    ("text", "key"),
    [
        ("attributes: {n: {type: integer}}", "attributes.n.type"),
        ("attributes: {n: {type: vec, length: 0}}", "attributes.n.length"),
        ("attributes: {n: {type: int, length: 3}}", "attributes.n.length"),
        ("attributes: {n: {type: int, volatile: maybe}}", "attributes.n.volatile"),
        ("attributes: {n: {type: int, unit: m}}", "attributes.n.unit"),
        ("attributes: {n: 5}", "attributes.n"),
        ("attributes: [n]", "attributes"),
        ("attributes: {'bad name': int}", "attributes.bad name"),
        ("attributes: {n: int}\nnodes: {t: {attributes: [n, m]}}", "nodes.t.attributes[1]"),
        ("nodes: {t: {attributes: n}}", "nodes.t.attributes"),
        ("nodes: {t: {attrs: []}}", "nodes.t.attrs"),
        ("nodes: {t: 3}", "nodes.t"),
        ("edges: {e: {attributes: [ghost]}}", "edges.e.attributes[0]"),
        ("relations: {}", "relations"),
        ("[1, 2]", "mapping"),
        ("attributes: {n: [unclosed", "YAML"),
    ],
)
def test_a_broken_file_names_the_offending_key(tmp_path: Path, text: str, key: str) -> None:
    path = tmp_path / "broken.yaml"
    path.write_text(text)
    with pytest.raises(wm.OntologyError) as info:
        wm.Ontology.load(path)
    assert key in str(info.value)
    assert str(path) in str(info.value)


def test_a_missing_file_is_an_ontology_error(tmp_path: Path) -> None:
    with pytest.raises(wm.OntologyError, match="cannot read"):
        wm.Ontology.load(tmp_path / "missing.yaml")


@pytest.mark.parametrize(
    ("attrs", "error"),
    [
        ({"n": 1.0}, wm.AttributeTypeError),
        ({"n": True}, wm.AttributeTypeError),
        ({"n": np.bool_(True)}, wm.AttributeTypeError),
        ({"n": "3"}, wm.AttributeTypeError),
        ({"n": 2**53 + 1}, wm.AttributeTypeError),
        ({"n": -(2**53) - 1}, wm.AttributeTypeError),
        ({"n": 2**64}, wm.AttributeTypeError),
        ({"x": True}, wm.AttributeTypeError),
        ({"x": "1.5"}, wm.AttributeTypeError),
        ({"x": None}, wm.AttributeTypeError),
        ({"flag": 1}, wm.AttributeTypeError),
        ({"flag": "true"}, wm.AttributeTypeError),
        ({"label": b"abc"}, wm.AttributeTypeError),
        ({"label": 3}, wm.AttributeTypeError),
        ({"blob": "abc"}, wm.AttributeTypeError),
        ({"blob": [1, 2]}, wm.AttributeTypeError),
        ({"pose": (1.0, 2.0)}, wm.AttributeTypeError),
        ({"pose": (1.0, 2.0, 3.0, 4.0)}, wm.AttributeTypeError),
        ({"pose": "abc"}, wm.AttributeTypeError),
        ({"pose": (True, False, True)}, wm.AttributeTypeError),
        ({"pose": [[1.0, 2.0, 3.0]]}, wm.AttributeTypeError),
        ({"path": ["a", "b"]}, wm.AttributeTypeError),
        ({"path": {"x": 1.0}}, wm.AttributeTypeError),
        ({"path": 3.0}, wm.AttributeTypeError),
        ({"speed": 1.0}, wm.UnknownAttributeError),
        ({"x": 1.0, "speed": 1.0}, wm.UnknownAttributeError),
    ],
)
def test_wrong_values_are_refused_and_nothing_is_written(g: wm.Graph, rec: Recorder, attrs: dict, error: type) -> None:
    thing = g.insert_node("thing", "t", {"x": 0.5})
    good = {"x": 9.0, "pose": (1.0, 2.0, 3.0)}  # a valid durable and volatile write alongside the bad one
    assert_refused(g, rec, error, lambda: g.update_node(thing, {**good, **attrs}))
    assert_refused(g, rec, error, lambda: g.insert_node("thing", "u", {**good, **attrs}))
    g.insert_node("other", "o")
    if error is wm.AttributeTypeError:
        assert_refused(g, rec, error, lambda: g.insert_or_assign_edge("t", "o", "link", {"x": attrs.get("x", "bad")}))


def test_unknown_type_and_attribute_messages(g: wm.Graph, rec: Recorder) -> None:
    err = assert_refused(g, rec, wm.UnknownTypeError, lambda: g.insert_node("robot", "r"))
    assert "'robot'" in str(err)
    err = assert_refused(g, rec, wm.UnknownAttributeError, lambda: g.insert_node("other", "o", {"n": 1}))
    assert "'n'" in str(err) and "'other'" in str(err)
    assert_refused(g, rec, wm.AttributeTypeError, lambda: g.insert_node("thing", "t", [("n", 1)]))  # type: ignore[arg-type]
    assert isinstance(err, wm.ValidationError) and isinstance(err, wm.WMError)


def test_every_value_type_round_trips(g: wm.Graph) -> None:
    values = {"n": -(2**53), "x": 2, "flag": False, "label": "é", "blob": b"\x00\xff", "pose": [0, 1, 2], "path": []}
    node = g.get_node(g.insert_node("thing", "t", values))
    assert node.attrs == {
        "n": -(2**53),
        "x": 2.0,
        "flag": False,
        "label": "é",
        "blob": b"\x00\xff",
        "pose": (0.0, 1.0, 2.0),
        "path": (),
    }
    assert type(node.attrs["n"]) is int and type(node.attrs["x"]) is float and type(node.attrs["flag"]) is bool
    replica = wm.Graph(g.ontology)
    replica.load_state(g.encode_state())
    assert replica.get_node("t") == node
