"""pydsr's geometry: ``rt_api(g)`` for RT edges and ``inner_api(g)`` for transforms between frames.

Both work on the graph's RT tree (:mod:`wm.rt`), in whatever units the graph
holds (DSR scenes use millimetres). ``timestamp`` arguments are accepted for
compatibility; the pose used is the latest one. Frames are given by node name
or id. Methods return None where pydsr returns an empty optional: a node that
is missing or not in the RT tree. Parameters carry pydsr's keyword names; in
``inner_api`` these are DSR's own: the first argument, which pydsr calls
``orig``, is the frame the result is expressed in (DSR's C++ calls it
``dest``), and ``transform("world", "robot")`` is the robot's origin in the
world's frame.
"""

from __future__ import annotations

from collections.abc import Callable, Sequence
from typing import Any, TypeVar

import numpy as np

from ..errors import EdgeNotFoundError, NodeNotFoundError, RTError
from ..graph import Graph
from ..rt import RT, euler_xyz, homogeneous
from .graph import DSRGraph
from .values import DSRTypeError, Edge, Node, _check_id

T = TypeVar("T")


def _graph(g: Any) -> DSRGraph:
    if not isinstance(g, DSRGraph):
        raise DSRTypeError(f"expected a DSRGraph, got {type(g).__name__}")
    return g


def _vector(values: Any, length: int, what: str) -> list[float]:
    array = np.asarray(values, dtype=float) if isinstance(values, (list, tuple, np.ndarray)) else None
    if array is None or array.shape != (length,):
        raise DSRTypeError(f"{what} must be {length} numbers, got {values!r:.60}")
    return [float(x) for x in array]


def _node_arg(node: Any) -> Node:
    if not isinstance(node, Node):
        raise DSRTypeError(f"expected a Node, got {type(node).__name__}")
    return node


def _frame(ref: Any) -> int | str:
    if isinstance(ref, str):
        return ref
    return _check_id(ref, "a frame (a node name or id)")


def _or_none(g: DSRGraph, work: Callable[[Graph], T]) -> T | None:
    def guarded(graph: Graph) -> T | None:
        try:
            return work(graph)
        except (NodeNotFoundError, EdgeNotFoundError, RTError):
            return None

    return g.with_graph(guarded)


class rt_api:
    """``rt_api(g)``: place nodes with RT edges and read their poses."""

    def __init__(self, g: DSRGraph) -> None:
        self._g = _graph(g)

    def insert_or_assign_edge_RT(self, node: Node, to: int, trans: Sequence[float], rot_euler: Sequence[float]) -> bool:
        """Place ``to`` in ``node``'s frame; a previous RT parent of ``to`` is replaced. False if a node is missing."""
        parent, child = _node_arg(node).id, _check_id(to, "to")
        attrs = {
            "rt_translation": _vector(trans, 3, "trans"),
            "rt_rotation_euler_xyz": _vector(rot_euler, 3, "rot_euler"),
        }

        def place(graph: Graph) -> bool:
            old = graph.rt.parent(child)
            with graph.batch():
                if old is not None and old != parent:
                    graph.delete_edge(old, child, RT)
                graph.insert_or_assign_edge(parent, child, RT, attrs)
            return True

        return bool(_or_none(self._g, place))

    def get_edge_RT(self, node: Node, to: int) -> Edge | None:
        return self._g.get_edge(_node_arg(node).id, _check_id(to, "to"), RT)

    def get_RT_pose_from_parent(self, node: Node) -> np.ndarray | None:
        """The node's pose in its RT parent's frame, as a 4x4 matrix; None for a root."""
        child = _node_arg(node).id
        return _or_none(
            self._g, lambda graph: graph.rt.local_matrix(child) if graph.rt.parent(child) is not None else None
        )

    def get_edge_RT_as_rtmat(self, edge: Edge, timestamp: int = 0) -> np.ndarray:
        if not isinstance(edge, Edge) or edge.type != RT:
            raise DSRTypeError("get_edge_RT_as_rtmat takes an RT Edge")
        attrs = edge.attrs
        translation = attrs["rt_translation"].value if "rt_translation" in attrs else (0.0, 0.0, 0.0)
        rotation = attrs["rt_rotation_euler_xyz"].value if "rt_rotation_euler_xyz" in attrs else (0.0, 0.0, 0.0)
        return homogeneous(translation, rotation)

    def get_translation(self, node_id: int, to: int, timestamp: int = 0) -> np.ndarray | None:
        """The translation on the RT edge ``node_id -> to``."""
        src, dst = _check_id(node_id, "node_id"), _check_id(to, "to")
        return _or_none(
            self._g, lambda graph: np.array(graph.get_edge(src, dst, RT).attrs.get("rt_translation", (0.0, 0.0, 0.0)))
        )


class inner_api:
    """``inner_api(g)`` (DSR's InnerEigenAPI): ``transform(a, b)`` is ``b``'s origin in ``a``'s frame."""

    def __init__(self, g: DSRGraph) -> None:
        self._g = _graph(g)

    def transform(
        self, orig: Any, *args: Any, vector: Any = None, dest: Any = None, timestamp: int = 0
    ) -> np.ndarray | None:
        """``transform(orig, dest)`` or ``transform(orig, vector, dest)``: a point of ``dest``'s frame (its origin by default) in ``orig``'s."""
        point, source = _vector_and_frame(args, vector, dest, 3)
        target = _frame(orig)
        return _or_none(self._g, lambda graph: graph.rt.transform(target, source, point))

    def transform_axis(
        self, orig: Any, *args: Any, vector: Any = None, dest: Any = None, timestamp: int = 0
    ) -> np.ndarray | None:
        """Like :meth:`transform` for a pose (x, y, z, rx, ry, rz); without one, ``dest``'s own pose in ``orig``'s frame."""
        pose, source = _vector_and_frame(args, vector, dest, 6)
        target = _frame(orig)
        return _or_none(
            self._g, lambda graph: graph.rt.transform(target, source, pose if pose is not None else [0.0] * 6)
        )

    def get_transformation_matrix(self, orig: Any, dest: Any, timestamp: int = 0) -> np.ndarray | None:
        """The 4x4 matrix taking coordinates in ``dest``'s frame to ``orig``'s."""
        target, source = _frame(orig), _frame(dest)
        return _or_none(self._g, lambda graph: graph.rt.get_transform(target, source))

    def get_rotation_matrix(self, orig: Any, dest: Any, timestamp: int = 0) -> np.ndarray | None:
        matrix = self.get_transformation_matrix(orig, dest)
        return None if matrix is None else matrix[:3, :3]

    def get_translation_vector(self, orig: Any, dest: Any, timestamp: int = 0) -> np.ndarray | None:
        matrix = self.get_transformation_matrix(orig, dest)
        return None if matrix is None else matrix[:3, 3]

    def get_euler_xyz_angles(self, orig: Any, dest: Any, timestamp: int = 0) -> np.ndarray | None:
        matrix = self.get_transformation_matrix(orig, dest)
        return None if matrix is None else np.array(euler_xyz(matrix[:3, :3]))


def _vector_and_frame(
    args: tuple[Any, ...], vector: Any, dest: Any, length: int
) -> tuple[list[float] | None, int | str]:
    """The optional vector and the frame it is given in, from ``(dest[, ts])``, ``(vector, dest[, ts])`` or keywords."""
    if args and isinstance(args[0], (list, tuple, np.ndarray)):
        vector, args = args[0], args[1:]
    if args and dest is None:
        dest = args[0]
    if dest is None:
        raise DSRTypeError("expected (orig, dest[, timestamp]) or (orig, vector, dest[, timestamp])")
    return (None if vector is None else _vector(vector, length, "the vector")), _frame(dest)
