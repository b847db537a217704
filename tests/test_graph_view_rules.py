"""Values and names: NaN and infinity, lone surrogates, size limits, and the same rules on remote content."""

from __future__ import annotations

import json
import math
import subprocess
from pathlib import Path

import pytest
from pycrdt import Doc, Map

import wm
from procs import REPO, WM
from wm.check import check
from wm.persistence import DiskLog, Persister


def strict(text: str) -> object:
    def refuse(constant: str) -> None:
        raise ValueError(constant)

    return json.loads(text, parse_constant=refuse)


def hostile(graph: wm.Graph, craft) -> bytes:
    """A well-formed update, made on a copy of ``graph``'s document, holding ``craft``'s writes."""
    doc = Doc()
    doc.apply_update(graph.diff())
    before = doc.get_state()
    with doc.transaction():
        craft(doc.get("nodes", type=Map), doc.get("edges", type=Map), doc.get("edge_attrs", type=Map))
    return doc.get_update(before)


@pytest.fixture
def g() -> wm.Graph:
    graph = wm.Graph(replica_id="local")
    graph.insert_node("world", "world")
    graph.insert_node("object", "ball", {"kind": "ball"})
    return graph


@pytest.mark.parametrize(
    "attrs", [{"pos_x": math.nan}, {"pos_x": math.inf}, {"size": (1.0, -math.inf, 0.0)}, {"last_seen": math.nan}]
)
def test_nan_and_infinity_are_refused(g: wm.Graph, attrs: dict) -> None:
    with pytest.raises(wm.AttributeTypeError, match="NaN and infinity"):
        g.update_node("ball", attrs)
    with pytest.raises(wm.AttributeTypeError, match="NaN and infinity"):
        g.insert_or_assign_edge("world", "ball", "has_intention", {"time_to_collision": math.inf})
    assert "pos_x" not in g.get_node("ball").attrs and g.find_edge("world", "ball", "has_intention") is None


def test_an_entry_may_allow_nan_and_the_json_dump_stays_strict_and_round_trips() -> None:
    ontology = wm.Ontology.from_dict(
        {
            "attributes": {
                "reading": {"type": "float", "nonfinite": True},
                "samples": {"type": "vec", "nonfinite": True},
            },
            "nodes": {"sensor": {"attributes": ["reading", "samples"]}},
        }
    )
    g = wm.Graph(ontology)
    g.insert_node("sensor", "s", {"reading": math.nan, "samples": [1.0, math.inf, -math.inf]})
    dumped = strict(g.to_json())
    assert dumped["nodes"][0]["attrs"] == {
        "reading": {"$float": "nan"},
        "samples": [1.0, {"$float": "inf"}, {"$float": "-inf"}],
    }
    copy = wm.Graph(ontology)
    copy.load_json(dumped)
    assert math.isnan(copy.get_node("s").attrs["reading"]) and copy.get_node("s").attrs["samples"][1:] == (
        math.inf,
        -math.inf,
    )


def test_only_a_float_or_a_vec_may_allow_nan() -> None:
    with pytest.raises(wm.OntologyError, match="nonfinite"):
        wm.Ontology.from_dict({"attributes": {"n": {"type": "int", "nonfinite": True}}})


def test_a_lone_surrogate_is_a_wm_error_and_writes_nothing(g: wm.Graph) -> None:
    with pytest.raises(wm.AttributeTypeError, match="surrogate"):
        g.update_node("ball", {"color": "red\ud800"})
    with pytest.raises(wm.ValidationError, match="surrogate"):
        g.insert_node("object", "ball\udc00")
    with pytest.raises(wm.ValidationError, match="surrogate"):
        g.rename_node("ball", "\ud83d")
    assert g.get_node("ball").attrs == {"kind": "ball"} and g.node_count() == 2


def test_values_and_names_beyond_the_default_limits_are_refused(g: wm.Graph) -> None:
    with pytest.raises(wm.AttributeTypeError, match="exceeds the limit of 1000000 bytes"):
        g.update_node("ball", {"color": "x" * 1_000_001})
    with pytest.raises(wm.AttributeTypeError, match="exceeds"):
        g.update_node("ball", {"color": "é" * 600_000})  # 1.2 MB in UTF-8
    g.update_node("ball", {"color": "x" * 1_000_000})  # exactly at the limit
    with pytest.raises(wm.ValidationError, match="256"):
        g.insert_node("object", "n" * 257)
    g.insert_node("object", "n" * 256)


def test_limits_are_configured_in_the_ontology_and_apply_to_every_kind_of_value() -> None:
    ontology = wm.Ontology.from_dict(
        {
            "limits": {"max_value_bytes": 16, "max_name_length": 20},
            "attributes": {"label": "str", "blob": "bytes", "path": "vec"},
            "nodes": {"thing": {"attributes": ["label", "blob", "path"]}},
        }
    )
    g = wm.Graph(ontology)
    for attrs in ({"label": "x" * 17}, {"blob": b"x" * 17}, {"path": [0.0, 1.0, 2.0]}):  # a vec element is 8 bytes
        with pytest.raises(wm.AttributeTypeError, match="exceeds the limit of 16 bytes"):
            g.insert_node("thing", "t", attrs)
    with pytest.raises(wm.ValidationError, match="limit of 20"):
        g.insert_node("thing", "t" * 21)
    g.insert_node("thing", "t", {"label": "x" * 16, "blob": b"x" * 16, "path": [0.0, 1.0]})


@pytest.mark.parametrize(
    "limits", [{"max_value_bytes": 0}, {"max_name_length": "long"}, {"max_name_length": 17}, {"max_list": 3}, [1]]
)
def test_malformed_limits_are_refused(limits: object) -> None:
    with pytest.raises(wm.OntologyError, match="limits"):
        wm.Ontology.from_dict({"limits": limits})


def test_remote_content_beyond_the_limits_is_left_out(g: wm.Graph) -> None:
    ball = str(g.get_node("ball").id)

    def craft(nodes: Map, _edges: Map, _attrs: Map) -> None:
        nodes[ball]["color"] = "x" * 1_000_001
        nodes["4242"] = Map({"@type": "object", "@name": "n" * 257})

    g.apply_update(hostile(g, craft), "mallory")
    assert g.get_node("ball").attrs == {"kind": "ball"} and g.find_node("n" * 257) is None
    assert [(e.kind, e.key, e.writer) for e in g.left_out()] == [
        ("node", "4242", "mallory"),
        ("node_attr", f"{ball}.color", "mallory"),
    ]
    assert g.left_out_by_writer() == {"mallory": 2}


def test_a_local_write_replaces_a_value_the_view_left_out(g: wm.Graph) -> None:
    ball = str(g.get_node("ball").id)
    g.apply_update(hostile(g, lambda nodes, _e, _a: nodes[ball].__setitem__("pos_x", "far")), "mallory")
    assert "pos_x" not in g.get_node("ball").attrs and len(g.left_out()) == 1
    g.update_node("ball", {"pos_x": 1.5})
    assert g.get_node("ball").attrs["pos_x"] == 1.5 and g.left_out() == []


def test_a_remote_rename_to_an_invalid_name_removes_the_node_from_the_view_and_a_valid_one_brings_it_back(
    g: wm.Graph,
) -> None:
    ball = str(g.get_node("ball").id)
    events: list[wm.Event] = []
    g.on(events.append)
    g.apply_update(hostile(g, lambda nodes, _e, _a: nodes[ball].__setitem__("@name", "@hidden")), "mallory")
    assert g.find_node(int(ball)) is None and [e.kind for e in events] == ["node_removed"]
    g.apply_update(hostile(g, lambda nodes, _e, _a: nodes[ball].__setitem__("@name", "ball2")), "mallory")
    assert g.get_node("ball2").attrs == {"kind": "ball"} and g.left_out() == []


def test_a_conflict_rename_of_a_name_at_the_limit_stays_within_it() -> None:
    a, b = wm.Graph(replica_id="a"), wm.Graph(replica_id="b")
    name = "n" * 256
    a.insert_node("object", name)
    b.insert_node("object", name)
    a.apply_update(b.diff(a.state_vector()), "b")
    b.apply_update(a.diff(b.state_vector()), "a")
    assert a.to_dict() == b.to_dict()
    renamed = [n.name for n in a.nodes() if n.name != name]
    assert len(renamed) == 1 and len(renamed[0]) <= 256 and "~" in renamed[0]


def test_wm_check_lists_what_is_left_out_with_its_sender_and_repair_deletes_it(tmp_path: Path) -> None:
    data = tmp_path / "data"
    disk = DiskLog(data / "home")
    g = wm.Graph(replica_id="local")
    persister = Persister(g, disk)
    g.insert_node("world", "world")
    ball = str(g.insert_node("object", "ball", {"kind": "ball"}))

    def craft(nodes: Map, edges: Map, _attrs: Map) -> None:
        nodes["not-an-int"] = Map({"@type": "object", "@name": "x"})
        nodes[ball]["bogus"] = 1
        edges["garbage"] = 5

    g.apply_update(hostile(g, craft), "mallory")
    view = g.to_dict()
    persister.flush()
    disk.close()

    def wm_check(*extra: str) -> subprocess.CompletedProcess[str]:
        return subprocess.run(
            [*WM, "check", "--data", str(data), "--graph", "home", *extra],
            capture_output=True,
            text=True,
            timeout=60,
            cwd=REPO,
        )

    listed = wm_check()
    assert listed.returncode == 2, listed.stderr
    assert "3 entries left out" in listed.stdout and "sent by disk:mallory: 3" in listed.stdout
    repaired = wm_check("--repair")
    assert repaired.returncode == 0 and "deleted 3 entries" in repaired.stdout, repaired.stdout + repaired.stderr
    assert check(data, "home").left_out == []
    reloaded = wm.Graph()
    DiskLog(data / "home").load_into(reloaded)
    assert reloaded.to_dict() == view


def test_wm_check_names_a_missing_graph_in_one_line(tmp_path: Path) -> None:
    result = subprocess.run(
        [*WM, "check", "--data", str(tmp_path), "--graph", "nope"], capture_output=True, text=True, timeout=60, cwd=REPO
    )
    assert result.returncode == 1 and result.stderr.count("\n") == 1 and "no graph 'nope'" in result.stderr
