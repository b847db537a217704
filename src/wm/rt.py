"""Geometry: RT edges place a child node in its parent's frame, forming a tree.

An RT edge ``parent -> child`` carries ``rt_translation`` (x, y, z, metres)
and ``rt_rotation_euler_xyz`` (intrinsic x-y-z Euler angles, radians, i.e.
R = Rx(a) Ry(b) Rz(c)), as in DSR. :class:`RTApi` computes transforms between
any two nodes of the tree and offers SE(2) helpers for planar robots.

Each node has at most one RT parent and the tree has no cycle; writes that
would break this raise :class:`wm.errors.RTError`. If two replicas give a node
two parents concurrently, the parent with the lowest id is the one used.
"""

from __future__ import annotations

import math
from collections.abc import Sequence
from typing import TYPE_CHECKING

import numpy as np

from .errors import RTError

if TYPE_CHECKING:
    from .graph import Graph, NodeRef

RT = "RT"


def rotation_matrix(euler_xyz: Sequence[float]) -> np.ndarray:
    a, b, c = euler_xyz
    ca, sa, cb, sb, cc, sc = math.cos(a), math.sin(a), math.cos(b), math.sin(b), math.cos(c), math.sin(c)
    rx = np.array([[1, 0, 0], [0, ca, -sa], [0, sa, ca]])
    ry = np.array([[cb, 0, sb], [0, 1, 0], [-sb, 0, cb]])
    rz = np.array([[cc, -sc, 0], [sc, cc, 0], [0, 0, 1]])
    rotation: np.ndarray = rx @ ry @ rz
    return rotation


def euler_xyz(rotation: np.ndarray) -> tuple[float, float, float]:
    """The intrinsic x-y-z Euler angles of a rotation matrix."""
    b = math.asin(max(-1.0, min(1.0, rotation[0, 2])))
    if abs(rotation[0, 2]) < 1 - 1e-9:
        a = math.atan2(-rotation[1, 2], rotation[2, 2])
        c = math.atan2(-rotation[0, 1], rotation[0, 0])
    else:  # gimbal lock: put all the remaining rotation in a
        a = math.atan2(rotation[2, 1], rotation[1, 1])
        c = 0.0
    return a, b, c


def homogeneous(translation: Sequence[float], rotation_xyz: Sequence[float]) -> np.ndarray:
    matrix = np.eye(4)
    matrix[:3, :3] = rotation_matrix(rotation_xyz)
    matrix[:3, 3] = translation
    return matrix


def se2(x: float, y: float, yaw: float) -> dict[str, tuple[float, float, float]]:
    """RT edge attributes for a planar pose."""
    return {"rt_translation": (float(x), float(y), 0.0), "rt_rotation_euler_xyz": (0.0, 0.0, float(yaw))}


def matrix_to_se2(matrix: np.ndarray) -> tuple[float, float, float]:
    return float(matrix[0, 3]), float(matrix[1, 3]), math.atan2(matrix[1, 0], matrix[0, 0])


class RTApi:
    """Transforms over the RT tree of one graph (``graph.rt``)."""

    def __init__(self, graph: Graph) -> None:
        self._graph = graph

    def parent(self, node: NodeRef) -> int | None:
        """The RT parent of a node (the lowest id if replicas disagreed), or None for a root."""
        graph = self._graph
        parents = [e.src for e in graph.edges(type=RT, dst=node)]
        return min(parents) if parents else None

    def check_new_edge(self, parent: int, child: int) -> None:
        """Refuse an RT edge that would give ``child`` a second parent or close a cycle."""
        if parent == child:
            raise RTError(f"an RT edge from node {parent} to itself would be a cycle")
        current = self.parent(child)
        if current is not None and current != parent:
            raise RTError(f"node {child} already has RT parent {current}; delete that edge first")
        if child in self._ancestors(parent):
            raise RTError(f"an RT edge {parent} -> {child} would close a cycle")

    def insert_or_assign(
        self,
        parent: NodeRef,
        child: NodeRef,
        translation: Sequence[float] = (0.0, 0.0, 0.0),
        rotation_xyz: Sequence[float] = (0.0, 0.0, 0.0),
    ) -> None:
        self._graph.insert_or_assign_edge(
            parent, child, RT, {"rt_translation": translation, "rt_rotation_euler_xyz": rotation_xyz}
        )

    def set_pose2d(self, parent: NodeRef, child: NodeRef, x: float, y: float, yaw: float) -> None:
        self._graph.insert_or_assign_edge(parent, child, RT, se2(x, y, yaw))

    def local_matrix(self, child: int) -> np.ndarray:
        """The child's pose in its parent's frame, as a 4x4 matrix."""
        parent = self.parent(child)
        if parent is None:
            return np.eye(4)
        edge = self._graph.get_edge(parent, child, RT)
        return homogeneous(
            edge.get("rt_translation", (0.0, 0.0, 0.0)), edge.get("rt_rotation_euler_xyz", (0.0, 0.0, 0.0))
        )

    def _ancestors(self, node: int) -> list[int]:
        """``node`` and its RT ancestors up to the root."""
        chain = [node]
        parent = self.parent(node)
        while parent is not None:
            if parent in chain:
                raise RTError(f"the RT tree has a cycle through node {parent}")
            chain.append(parent)
            parent = self.parent(parent)
        return chain

    def get_transform(self, dest: NodeRef, src: NodeRef) -> np.ndarray:
        """The 4x4 matrix mapping coordinates in ``src``'s frame to ``dest``'s frame."""
        graph = self._graph
        dest_chain, src_chain = self._ancestors(graph.resolve(dest)), self._ancestors(graph.resolve(src))
        common = next((n for n in src_chain if n in dest_chain), None)
        if common is None:
            raise RTError(f"nodes {dest!r} and {src!r} are not in the same RT tree")
        up = np.eye(4)
        for node in src_chain[: src_chain.index(common)]:
            up = self.local_matrix(node) @ up
        down = np.eye(4)
        for node in dest_chain[: dest_chain.index(common)]:
            down = self.local_matrix(node) @ down
        return np.linalg.solve(down, up)

    def transform(self, dest: NodeRef, src: NodeRef, point_or_pose: Sequence[float] | None = None) -> np.ndarray:
        """Express a point (x, y, z) or pose (x, y, z, rx, ry, rz) given in ``src``'s frame in ``dest``'s frame.

        With no point, returns the origin of ``src`` in ``dest``'s frame.
        """
        matrix = self.get_transform(dest, src)
        if point_or_pose is None:
            return matrix[:3, 3].copy()
        values = np.asarray(point_or_pose, dtype=float)
        if values.shape == (3,):
            point: np.ndarray = matrix[:3, :3] @ values + matrix[:3, 3]
            return point
        if values.shape == (6,):
            pose = matrix @ homogeneous(values[:3].tolist(), values[3:].tolist())
            return np.concatenate([pose[:3, 3], euler_xyz(pose[:3, :3])])
        raise RTError(f"expected a point of 3 or a pose of 6 numbers, got shape {values.shape}")

    def pose2d(self, dest: NodeRef, src: NodeRef) -> tuple[float, float, float]:
        """(x, y, yaw) of ``src`` in ``dest``'s frame."""
        return matrix_to_se2(self.get_transform(dest, src))
