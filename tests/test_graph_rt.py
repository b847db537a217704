"""RT: transforms between any two nodes of the RT tree, SE(2) helpers, and the tree's invariants."""

from __future__ import annotations

import math

import numpy as np
import pytest
from hypothesis import given, settings
from hypothesis import strategies as st

import wm
from graph_helpers import Recorder, assert_refused
from wm.rt import euler_xyz, rotation_matrix


def rot(axis: str, angle: float) -> np.ndarray:
    c, s = math.cos(angle), math.sin(angle)
    return {
        "x": np.array([[1, 0, 0], [0, c, -s], [0, s, c]]),
        "y": np.array([[c, 0, s], [0, 1, 0], [-s, 0, c]]),
        "z": np.array([[c, -s, 0], [s, c, 0], [0, 0, 1]]),
    }[axis]


def pose(t: tuple[float, float, float], r: tuple[float, float, float]) -> np.ndarray:
    """Child-in-parent matrix, intrinsic x-y-z: R = Rx Ry Rz."""
    m = np.eye(4)
    m[:3, :3] = rot("x", r[0]) @ rot("y", r[1]) @ rot("z", r[2])
    m[:3, 3] = t
    return m


T_ROBOT = ((1.0, 2.0, 0.0), (0.0, 0.0, math.pi / 2))
T_PERSON = ((4.0, -1.0, 0.0), (0.0, 0.0, -0.3))
T_CAMERA = ((0.2, 0.0, 1.2), (0.1, -0.4, 0.25))
T_CUP = ((0.5, 0.5, 0.9), (0.3, 0.2, -1.0))


@pytest.fixture
def g() -> wm.Graph:
    graph = wm.Graph(replica_id="local")
    for node_type, name in [
        ("world", "world"),
        ("robot", "robot"),
        ("person", "ann"),
        ("rgbd", "camera"),
        ("object", "cup"),
    ]:
        graph.insert_node(node_type, name)
    graph.rt.insert_or_assign("world", "robot", *T_ROBOT)
    graph.rt.insert_or_assign("world", "ann", *T_PERSON)
    graph.rt.insert_or_assign("robot", "camera", *T_CAMERA)
    graph.rt.insert_or_assign("ann", "cup", *T_CUP)
    return graph


def in_world(name: str) -> np.ndarray:
    chain = {
        "world": [],
        "robot": [T_ROBOT],
        "ann": [T_PERSON],
        "camera": [T_ROBOT, T_CAMERA],
        "cup": [T_PERSON, T_CUP],
    }[name]
    m = np.eye(4)
    for t, r in chain:
        m = m @ pose(t, r)
    return m


NAMES = ["world", "robot", "ann", "camera", "cup"]


@pytest.mark.parametrize("dest", NAMES)
@pytest.mark.parametrize("src", NAMES)
def test_transform_between_any_two_nodes(g: wm.Graph, dest: str, src: str) -> None:
    expected = np.linalg.inv(in_world(dest)) @ in_world(src)
    np.testing.assert_allclose(g.rt.get_transform(dest, src), expected, atol=1e-12)
    point = np.array([0.3, -0.7, 1.1])
    np.testing.assert_allclose(g.rt.transform(dest, src, point), (expected @ np.append(point, 1))[:3], atol=1e-12)
    np.testing.assert_allclose(g.rt.transform(dest, src), expected[:3, 3], atol=1e-12)
    x, y, yaw = g.rt.pose2d(dest, src)
    assert (x, y) == pytest.approx((expected[0, 3], expected[1, 3]))
    assert yaw == pytest.approx(math.atan2(expected[1, 0], expected[0, 0]))


def test_transform_of_a_pose(g: wm.Graph) -> None:
    six = (0.1, 0.2, 0.3, 0.4, -0.5, 0.6)
    result = g.rt.transform("camera", "cup", six)
    expected = np.linalg.inv(in_world("camera")) @ in_world("cup") @ pose(six[:3], six[3:])
    np.testing.assert_allclose(pose(tuple(result[:3]), tuple(result[3:])), expected, atol=1e-12)
    with pytest.raises(wm.RTError):
        g.rt.transform("camera", "cup", (1.0, 2.0))


def test_planar_helpers(g: wm.Graph) -> None:
    g.insert_node("object", "ball")
    g.rt.set_pose2d("robot", "ball", 1.0, 0.0, 0.0)
    assert g.get_edge("robot", "ball", "RT").attrs == wm.se2(1.0, 0.0, 0.0)
    x, y, yaw = g.rt.pose2d("world", "ball")
    assert (x, y, yaw) == pytest.approx((1.0, 3.0, math.pi / 2))
    assert g.rt.parent("ball") == g.get_node("robot").id
    assert g.rt.parent("world") is None


@settings(max_examples=200, deadline=None)
@given(st.tuples(st.floats(-3.1, 3.1), st.floats(-1.55, 1.55), st.floats(-3.1, 3.1)))
def test_euler_round_trip(angles: tuple[float, float, float]) -> None:
    matrix = rotation_matrix(angles)
    np.testing.assert_allclose(matrix, rot("x", angles[0]) @ rot("y", angles[1]) @ rot("z", angles[2]), atol=1e-12)
    np.testing.assert_allclose(rotation_matrix(euler_xyz(matrix)), matrix, atol=1e-9)
    np.testing.assert_allclose(euler_xyz(matrix), angles, atol=1e-6)


def test_euler_at_gimbal_lock_still_gives_the_same_rotation() -> None:
    for angles in [(0.3, math.pi / 2, 0.4), (-1.0, -math.pi / 2, 2.0)]:
        matrix = rotation_matrix(angles)
        np.testing.assert_allclose(rotation_matrix(euler_xyz(matrix)), matrix, atol=1e-9)


def test_second_parent_and_cycles_are_refused(g: wm.Graph) -> None:
    rec = Recorder(g)
    assert_refused(g, rec, wm.RTError, lambda: g.rt.set_pose2d("ann", "robot", 0, 0, 0))  # robot has a parent
    assert_refused(g, rec, wm.RTError, lambda: g.rt.set_pose2d("cup", "world", 0, 0, 0))  # world is cup's ancestor
    assert_refused(g, rec, wm.RTError, lambda: g.rt.set_pose2d("cup", "cup", 0, 0, 0))
    g.rt.set_pose2d("world", "robot", 5, 5, 0)  # re-assigning the same parent is fine
    assert g.rt.pose2d("world", "robot") == pytest.approx((5, 5, 0))
    g.delete_edge("world", "robot", "RT")
    g.rt.set_pose2d("ann", "robot", 1, 0, 0)  # after deleting the old edge
    assert g.rt.parent("robot") == g.get_node("ann").id


def test_nodes_in_different_trees(g: wm.Graph) -> None:
    g.insert_node("object", "loose")
    with pytest.raises(wm.RTError):
        g.rt.get_transform("world", "loose")
    np.testing.assert_allclose(g.rt.get_transform("loose", "loose"), np.eye(4))


def test_concurrent_second_parents_resolve_to_the_lowest_id() -> None:
    a, b = wm.Graph(replica_id="a"), wm.Graph(replica_id="b")
    world, other, ball = (
        a.insert_node("world", "world"),
        a.insert_node("world", "other"),
        a.insert_node("object", "ball"),
    )
    b.apply_update(a.diff(), "a")
    a.rt.set_pose2d(world, ball, 1, 0, 0)
    b.rt.set_pose2d(other, ball, 2, 0, 0)
    a.merge_volatile(b.take_volatile_outbox(), "b")
    b.merge_volatile(a.take_volatile_outbox(), "a")
    a.apply_update(b.diff(a.state_vector()), "b")
    b.apply_update(a.diff(b.state_vector()), "a")
    assert a.rt.parent(ball) == b.rt.parent(ball) == min(world, other)
    assert a.rt.pose2d(min(world, other), ball) == b.rt.pose2d(min(world, other), ball)
