"""``wm.dsr``: every method of pydsr's API, between two agents joined over Zenoh on loopback."""

from __future__ import annotations

import json
import threading
from collections.abc import Callable, Iterator
from pathlib import Path
from typing import Any

import numpy as np
import pytest

import wm
from procs import endpoint, free_port, wait_until
from wm.dsr import Attribute, DSRGraph, Edge, Node, inner_api, rt_api, signals

SCENE = Path(__file__).resolve().parents[1] / "data" / "dsr" / "autonomyLab_objects.simscene.json"
WAIT = 20.0


def eventually(check: Callable[[], Any], what: str) -> Any:
    """Poll ``check`` until it returns something truthy, and return that; fail naming ``what`` after a bounded wait."""
    results: list[Any] = []
    wait_until(lambda: bool(results.append(check()) or results[-1]), WAIT, what, step=0.02)
    return results[-1]


@pytest.fixture(scope="module")
def agents() -> Iterator[tuple[DSRGraph, DSRGraph]]:
    """Agent 1 loads the real autonomy-lab scene and listens; agent 2 joins it."""
    port = free_port()
    first = DSRGraph(0, "first", 1, str(SCENE), graph="pydsr", listen=[endpoint(port)])
    second = DSRGraph(0, "second", 2, graph="pydsr", connect=[endpoint(port)])
    eventually(lambda: second.get_node("viriato"), "the second agent holds the scene")
    yield first, second
    second.close()
    first.close()


def test_attribute_semantics() -> None:
    attribute = Attribute(1.5, 7)
    assert (attribute.value, attribute.agent_id) == (1.5, 7) and attribute.timestamp > 0
    stamped = Attribute([1.0, 2.0], 123, 7)
    assert Attribute(1.0, agent_id=9, timestamp=5).agent_id == 9 and Attribute(1.0, 123, agent_id=9).timestamp == 123
    assert stamped.timestamp == 123 and isinstance(stamped.value, np.ndarray)
    attribute.value = 2.5
    assert attribute.value == 2.5
    with pytest.raises(TypeError):
        attribute.value = "fast"
    with pytest.raises(AttributeError):
        attribute.agent_id = 8  # type: ignore[misc]
    with pytest.raises(AttributeError):
        attribute.timestamp = 1  # type: ignore[misc]
    with pytest.raises(TypeError):
        Attribute({"a": 1}, 7)


def test_node_and_edge_semantics() -> None:
    node = Node(7, "person", "bob")
    assert (node.id, node.type, node.name, node.agent_id) == (0, "person", "bob", 7)
    node.agent_id = 8
    for read_only in ("id", "name", "type"):
        with pytest.raises(AttributeError):
            setattr(node, read_only, 1)
    with pytest.raises(RuntimeError):
        Node(7, "dragon")
    with pytest.raises(wm.WMError):
        Node(7, "dragon")
    node.attrs["person_age"] = Attribute(30, 7)
    with pytest.raises(TypeError):
        node.attrs["person_age"] = Attribute("thirty", 7)
    with pytest.raises(TypeError):
        node.attrs["person_age"] = 30  # type: ignore[assignment]
    node.attrs["dragon_scales"] = Attribute(1, 7)  # any name may be assigned, as in pydsr ...
    assert node.attrs["dragon_scales"].value == 1
    del node.attrs["dragon_scales"]
    del node.attrs["person_age"]
    with pytest.raises(KeyError):
        node.attrs["person_age"]
    edge = Edge(2, 1, "looking_at", 7)  # destination first
    assert (edge.origin, edge.destination, edge.type) == (1, 2, "looking_at")
    for read_only in ("origin", "destination", "type"):
        with pytest.raises(AttributeError):
            setattr(edge, read_only, 3)
    edge.agent_id = 9
    edge.attrs["distance_to_robot"] = Attribute(2.0, 7)
    del edge.attrs["distance_to_robot"]
    with pytest.raises(KeyError):
        edge.attrs["distance_to_robot"]
    with pytest.raises(RuntimeError):
        Edge(2, 1, "hates", 7)


def test_an_attribute_the_ontology_does_not_allow_is_refused_when_written(agents: tuple[DSRGraph, DSRGraph]) -> None:
    _, g = agents
    robot = g.get_node("viriato")
    robot.attrs["dragon_scales"] = Attribute(1, 2)
    robot.attrs["robot_ref_adv_speed"] = Attribute(100.0, 2)
    with pytest.raises(KeyError, match="'dragon_scales' is not allowed on node type 'omnirobot'"):
        g.update_node(robot)
    assert g.get_node("viriato").attrs["robot_ref_adv_speed"].value != 100.0  # nothing was written
    edge = Edge(200, 1, "looking_at", 2)
    edge.attrs["dragon_scales"] = Attribute(1, 2)
    with pytest.raises(wm.UnknownAttributeError):
        g.insert_or_assign_edge(edge)
    assert g.get_edge(1, 200, "looking_at") is None
    node = Node(2, "person", "ghost")
    node.attrs["dragon_scales"] = Attribute(1, 2)
    with pytest.raises(KeyError):
        g.insert_node(node)
    assert g.get_node("ghost") is None


def test_reading_nodes_and_edges(agents: tuple[DSRGraph, DSRGraph]) -> None:
    _, g = agents
    robot = g.get_node("viriato")
    assert robot is not None and (robot.id, robot.type) == (200, "omnirobot")
    assert g.get_node(200).name == "viriato"
    assert g.get_node("nobody") is None and g.get_node(999999) is None
    with pytest.raises(TypeError):
        g.get_node(1.5)  # type: ignore[arg-type]
    assert set(robot.edges) == {(50, "in"), (500, "RT"), (1000, "has")}
    assert robot.attrs["parent"].value == 1
    assert g.get_node_root().name == "root"
    assert {n.name for n in g.get_nodes_by_type("room")} == {"dinning_room", "kitchen", "entrance"}
    assert g.get_nodes_by_type("dragon") == []
    assert (g.get_name_from_id(200), g.get_id_from_name("viriato")) == ("viriato", 200)
    assert (g.get_name_from_id(999999), g.get_id_from_name("nobody")) == (None, None)
    by_name = g.get_edge("viriato", "body", "RT")
    assert by_name is not None and (by_name.origin, by_name.destination) == (200, 500)
    assert g.get_edge(200, 500, "RT").attrs["rt_translation"].value.tolist() == [0.0, 0.0, 0.0]
    assert g.get_edge(200, 500, "in") is None
    assert len(g.get_edges_by_type("interactive")) == 2
    assert {(e.origin, e.type) for e in g.get_edges_to_id(500)} == {(200, "RT")}
    assert g.get_edges_to_id(999999) == []


def test_inserting_updating_and_deleting(agents: tuple[DSRGraph, DSRGraph]) -> None:
    first, second = agents
    node = Node(2, "person", "carol")
    node.attrs["person_name"] = Attribute("Carol", 2)
    new_id = second.insert_node(node)
    assert isinstance(new_id, int) and node.id == new_id
    assert second.insert_node(Node(2, "person", "carol")) is None  # the name exists
    seen = eventually(lambda: first.get_node("carol"), "the insert reaches the other agent")
    assert seen.attrs["person_name"].value == "Carol"

    seen.attrs["person_age"] = Attribute(41, 1)
    seen.attrs["timestamp_creation"] = Attribute(2**64 - 1, 1)  # a uint64, exact
    del seen.attrs["person_name"]
    assert first.update_node(seen) is True
    eventually(
        lambda: (
            (n := second.get_node("carol"))
            and "person_name" not in n.attrs
            and n.attrs["person_age"].value == 41
            and n.attrs["timestamp_creation"].value == 2**64 - 1
        ),
        "the update and the removal reach the other agent",
    )

    edge = Edge(new_id, 200, "looking_at", 2)
    edge.attrs["distance_to_robot"] = Attribute(1.5, 2)
    assert second.insert_or_assign_edge(edge) is True
    assert second.insert_or_assign_edge(Edge(999999, 200, "looking_at", 2)) is False
    eventually(lambda: first.get_edge(200, new_id, "looking_at"), "the edge reaches the other agent")
    assert second.delete_edge(200, new_id, "looking_at") is True
    assert second.delete_edge(200, new_id, "looking_at") is False

    assert second.delete_node("carol") is True
    assert second.delete_node("carol") is False
    assert second.update_node(node) is False  # the node is gone
    assert second.update_node(Node(2, "person", "never_inserted")) is False
    with pytest.raises(TypeError):
        second.update_node("carol")  # type: ignore[arg-type]
    with pytest.raises(TypeError):
        second.insert_node({"type": "person"})  # type: ignore[arg-type]


def test_two_agents_updating_different_attributes_of_one_node_at_once_lose_nothing(
    agents: tuple[DSRGraph, DSRGraph],
) -> None:
    first, second = agents
    node = Node(1, "person", "dana")
    assert first.insert_node(node)
    eventually(lambda: second.get_node("dana"), "the node reaches the second agent")
    for round_number in range(20):
        mine, theirs = first.get_node("dana"), second.get_node("dana")  # both read, then both write
        mine.attrs["person_age"] = Attribute(round_number, 1)
        theirs.attrs["person_name"] = Attribute(f"Dana {round_number}", 2)
        results: list[bool] = []
        writers = [
            threading.Thread(target=lambda g=g, n=n, results=results: results.append(g.update_node(n)))
            for g, n in ((first, mine), (second, theirs))
        ]
        for writer in writers:
            writer.start()
        for writer in writers:
            writer.join()
        assert results == [True, True]
        expected = {"person_age": round_number, "person_name": f"Dana {round_number}"}
        for g in (first, second):
            eventually(
                lambda g=g, expected=expected: {k: a.value for k, a in g.get_node("dana").attrs.items()} == expected,
                f"both attributes of round {round_number} on agent {g.agent_id}",
            )


def test_signals_fire_for_local_and_remote_changes_on_their_own_thread(agents: tuple[DSRGraph, DSRGraph]) -> None:
    first, second = agents
    received: list[tuple[str, tuple[Any, ...], str]] = []

    def recorder(name: str) -> Callable[..., None]:
        return lambda *args: received.append((name, args, threading.current_thread().name))

    for signal in signals.SignalType:
        signals.connect(first, signal, recorder(signal.name))
    signals.connect2(
        first,
        signals.UPDATE_EDGE_ATTR,
        lambda frm, to, names: received.append(("older UPDATE_EDGE_ATTR", (frm, to, names), "")),
    )
    with pytest.raises(TypeError):
        signals.connect(first, "UPDATE_NODE", recorder("x"))  # type: ignore[arg-type]

    def seen(expected: list[tuple[str, tuple[Any, ...]]]) -> None:
        def about_erin() -> list[tuple[str, tuple[Any, ...]]]:
            found = []
            for name, args, _ in received:
                if name.endswith("_OBJ"):  # the deleted node or edge itself
                    item = args[0]
                    args = (
                        (item.id, item.type, item.name)
                        if isinstance(item, Node)
                        else (item.origin, item.destination, item.type)
                    )
                if erin in args:
                    found.append((name, args))
            return found

        eventually(lambda: about_erin() == expected, f"the signals {expected}")

    remote = Node(2, "person", "erin")  # the other agent's changes
    erin = second.insert_node(remote)
    remote.attrs["person_age"] = Attribute(30, 2)
    second.update_node(remote)
    expected = [("UPDATE_NODE", (erin, "person")), ("UPDATE_NODE_ATTR", (erin, ["person_age"]))]
    seen(expected)
    local = Edge(erin, 200, "looking_at", 1)  # this agent's own
    first.insert_or_assign_edge(local)
    local.attrs["distance_to_robot"] = Attribute(2.5, 1)
    first.insert_or_assign_edge(local)
    first.delete_edge(200, erin, "looking_at")
    expected += [
        ("UPDATE_EDGE", (200, erin, "looking_at")),
        ("UPDATE_EDGE", (200, erin, "looking_at")),
        ("UPDATE_EDGE_ATTR", (200, erin, "looking_at", ["distance_to_robot"])),
        ("older UPDATE_EDGE_ATTR", (200, erin, ["distance_to_robot"])),
        ("DELETE_EDGE", (200, erin, "looking_at")),
        ("DELETE_EDGE_OBJ", (200, erin, "looking_at")),
    ]
    seen(expected)
    second.delete_node(erin)
    seen([*expected, ("DELETE_NODE", (erin,)), ("DELETE_NODE_OBJ", (erin, "person", "erin"))])
    assert {thread for name, _, thread in received if not name.startswith("older")} == {"wm.dsr-signals"}


def test_a_callback_may_call_the_graph(agents: tuple[DSRGraph, DSRGraph]) -> None:
    first, second = agents
    names: list[str | None] = []
    signals.connect(
        first, signals.UPDATE_NODE, lambda node_id, node_type: names.append(first.get_name_from_id(node_id))
    )
    second.insert_node(Node(2, "person", "frank"))
    eventually(lambda: "frank" in names, "the callback read the new node's name")


def test_rt_api(agents: tuple[DSRGraph, DSRGraph]) -> None:
    first, second = agents
    rt = rt_api(second)
    root, body = second.get_node("root"), second.get_node("body")
    cup = Node(2, "cup", "cup")
    cup_id = second.insert_node(cup)
    assert rt.insert_or_assign_edge_RT(root, cup_id, [100.0, 200.0, 0.0], [0.0, 0.0, np.pi / 2]) is True
    edge = rt.get_edge_RT(root, cup_id)
    assert edge.attrs["rt_translation"].value.tolist() == [100.0, 200.0, 0.0]
    pose = rt.get_RT_pose_from_parent(second.get_node("cup"))
    assert pose[:3, 3].tolist() == [100.0, 200.0, 0.0] and pose[0, 1] == pytest.approx(-1.0)
    assert np.allclose(rt.get_edge_RT_as_rtmat(edge), pose)
    assert rt.get_translation(1, cup_id).tolist() == [100.0, 200.0, 0.0]
    assert rt.get_RT_pose_from_parent(root) is None
    assert rt.get_translation(1, 999999) is None
    # moving the cup onto the robot's body replaces its RT parent, as in DSR
    assert rt.insert_or_assign_edge_RT(body, cup_id, [0.0, 0.0, 500.0], [0.0, 0.0, 0.0]) is True
    eventually(
        lambda: first.get_edge("body", "cup", "RT") and first.get_edge("root", "cup", "RT") is None,
        "the cup moved to the body",
    )
    assert rt.insert_or_assign_edge_RT(root, 999999, [0.0, 0.0, 0.0], [0.0, 0.0, 0.0]) is False
    with pytest.raises(TypeError):
        rt.insert_or_assign_edge_RT(root, cup_id, [0.0, 0.0], [0.0, 0.0, 0.0])


def test_inner_api(agents: tuple[DSRGraph, DSRGraph]) -> None:
    _, g = agents
    inner = inner_api(g)
    native = wm.Graph()
    native.load_json(SCENE)
    expected = native.rt.transform("root", "laser")
    assert np.allclose(inner.transform("root", "laser"), expected)
    assert np.allclose(inner.transform("root", "laser", 0), expected)
    assert np.allclose(
        inner.transform("root", [10.0, 0.0, 0.0], "laser"), native.rt.transform("root", "laser", [10.0, 0.0, 0.0])
    )
    assert np.allclose(inner.transform_axis("root", "laser", 0), native.rt.transform("root", "laser", [0.0] * 6))
    pose6 = [1.0, 2.0, 3.0, 0.1, 0.2, 0.3]
    assert np.allclose(inner.transform_axis("root", pose6, "laser", 0), native.rt.transform("root", "laser", pose6))
    matrix = native.rt.get_transform("root", "laser")
    assert np.allclose(inner.get_transformation_matrix("root", "laser"), matrix)
    assert np.allclose(inner.get_rotation_matrix("root", "laser"), matrix[:3, :3])
    assert np.allclose(inner.get_translation_vector("root", "laser"), matrix[:3, 3])
    assert np.allclose(wm.rt.homogeneous(matrix[:3, 3], inner.get_euler_xyz_angles("root", "laser")), matrix)
    assert inner.transform("root", "nobody") is None
    assert inner.get_transformation_matrix("nobody", "laser") is None


def test_write_to_json_file_writes_what_dsr_reads(agents: tuple[DSRGraph, DSRGraph], tmp_path: Path) -> None:
    first, _ = agents
    path = tmp_path / "out.json"
    first.write_to_json_file(str(path), ["rgbd"])
    written = json.loads(path.read_text())
    symbols = written["DSRModel"]["symbols"]
    original = json.loads(SCENE.read_text())["DSRModel"]["symbols"]
    for key, symbol in original.items():  # the scene as loaded comes back in DSR's layout and type codes
        assert (
            symbols[key]["id"] == key
            and symbols[key]["type"] == symbol["type"]
            and symbols[key]["name"] == symbol["name"]
        )
        kept = {k: v for k, v in symbol["attribute"].items() if k in symbols[key]["attribute"]}
        assert kept == {k: symbols[key]["attribute"][k] for k in kept}, key
    camera = symbols["210"]["attribute"]
    assert camera["cam_rgb"] == {"type": 5, "value": []} and camera["cam_rgb_width"] == {"type": 1, "value": 640}
    reloaded = wm.Graph()
    assert reloaded.load_json(path).nodes == len(symbols)
    with pytest.raises(TypeError):
        first.write_to_json_file(str(path), [1])  # type: ignore[list-item]


def test_pydsr_keywords_and_whole_graph_reads() -> None:
    with DSRGraph(root=0, name="keywords", id=5, dsr_input_file=str(SCENE), graph="pydsr-keywords") as g:
        assert (g.get_agent_id(), g.get_agent_name()) == (5, "keywords")
        assert len(g.get_nodes()) == 41 and len(g.get_edges()) == 43
        assert Attribute("red").agent_id == 5  # pydsr stamps a bare Attribute with the last graph's agent id
        inner, rt = inner_api(g), rt_api(g)
        assert np.allclose(inner.transform(orig="root", dest="laser"), inner.transform("root", "laser"))
        assert np.allclose(
            inner.transform(orig="root", vector=[1.0, 0.0, 0.0], dest="laser", timestamp=0),
            inner.transform("root", [1.0, 0.0, 0.0], "laser"),
        )
        assert np.allclose(
            inner.get_transformation_matrix(orig="root", dest="laser"), inner.get_transformation_matrix("root", "laser")
        )
        root = g.get_node("root")
        assert rt.insert_or_assign_edge_RT(node=root, to=203, trans=[0.0, 1.2, 0.0], rot_euler=[1.1, 0.0, 2.2])
        assert g.get_node("root").edges[(203, "RT")] is not None and g.get_edge("laser_pose", "laser", "RT") is None
        assert rt.get_translation(node_id=1, to=203, timestamp=0).tolist() == pytest.approx([0.0, 1.2, 0.0])
    with pytest.raises(RuntimeError):
        g.get_node(1)  # closed
