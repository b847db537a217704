"""pydsr's geometry: ``rt_api(g)`` for RT edges and ``inner_api(g)`` for transforms between frames.

Both work on the graph's RT tree (:mod:`wm.rt`), in whatever units the graph
holds (DSR scenes use millimetres). ``timestamp`` arguments are accepted for
compatibility; the pose used is the latest one. Frames are given by node name
or id. Methods return None where pydsr returns an empty optional: a node that
is missing or not in the RT tree.
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


class rt_api:  # noqa: N801 - pydsr's name
    """``rt_api(g)``: place nodes with RT edges and read their poses."""

    def __init__(self, g: DSRGraph) -> None:
        self._g = _graph(g)

    def insert_or_assign_edge_RT(self, node: Node, to_id: int, translation: Sequence[float], rotation_euler_xyz: Sequence[float]) -> bool:  # noqa: N802
        """Place ``to_id`` in ``node``'s frame; a previous RT parent of ``to_id`` is replaced. False if a node is missing."""
        parent, child = _node_arg(node).id, _check_id(to_id, "to_id")
        attrs = {"rt_translation": _vector(translation, 3, "translation"),
                 "rt_rotation_euler_xyz": _vector(rotation_euler_xyz, 3, "rotation_euler_xyz")}

        def place(graph: Graph) -> bool:
            old = graph.rt.parent(child)
            with graph.batch():
                if old is not None and old != parent:
                    graph.delete_edge(old, child, RT)
                graph.insert_or_assign_edge(parent, child, RT, attrs)
            return True

        return bool(_or_none(self._g, place))

    def get_edge_RT(self, node: Node, to_id: int) -> Edge | None:  # noqa: N802
        return self._g.get_edge(_node_arg(node).id, _check_id(to_id, "to_id"), RT)

    def get_RT_pose_from_parent(self, node: Node) -> np.ndarray | None:  # noqa: N802
        """The node's pose in its RT parent's frame, as a 4x4 matrix; None for a root."""
        child = _node_arg(node).id
        return _or_none(self._g, lambda graph: graph.rt.local_matrix(child) if graph.rt.parent(child) is not None else None)

    def get_edge_RT_as_rtmat(self, edge: Edge, timestamp: int = 0) -> np.ndarray:  # noqa: N802
        if not isinstance(edge, Edge) or edge.type != RT:
            raise DSRTypeError("get_edge_RT_as_rtmat takes an RT Edge")
        attrs = edge.attrs
        translation = attrs["rt_translation"].value if "rt_translation" in attrs else (0.0, 0.0, 0.0)
        rotation = attrs["rt_rotation_euler_xyz"].value if "rt_rotation_euler_xyz" in attrs else (0.0, 0.0, 0.0)
        return homogeneous(translation, rotation)

    def get_translation(self, frm: int, to: int, timestamp: int = 0) -> np.ndarray | None:
        """The translation on the RT edge ``frm -> to``."""
        src, dst = _check_id(frm, "from"), _check_id(to, "to")
        return _or_none(self._g, lambda graph: np.array(graph.get_edge(src, dst, RT).attrs.get("rt_translation", (0.0, 0.0, 0.0))))


class inner_api:  # noqa: N801 - pydsr's name
    """``inner_api(g)`` (DSR's InnerEigenAPI): ``transform(a, b)`` is ``b``'s origin in ``a``'s frame."""

    def __init__(self, g: DSRGraph) -> None:
        self._g = _graph(g)

    def transform(self, dest: Any, *args: Any) -> np.ndarray | None:
        """``transform(dest, src[, ts])`` or ``transform(dest, point3, src[, ts])``: a point of ``src``'s frame in ``dest``'s."""
        point, src = self._point_and_frame(args, 3)
        target = _frame(dest)
        return _or_none(self._g, lambda graph: graph.rt.transform(target, src, point))

    def transform_axis(self, dest: Any, *args: Any) -> np.ndarray | None:
        """Like :meth:`transform` for a pose (x, y, z, rx, ry, rz); without one, ``src``'s own pose in ``dest``'s frame."""
        pose, src = self._point_and_frame(args, 6)
        target = _frame(dest)
        return _or_none(self._g, lambda graph: graph.rt.transform(target, src, pose if pose is not None else [0.0] * 6))

    def get_transformation_matrix(self, dest: Any, src: Any, timestamp: int = 0) -> np.ndarray | None:
        target, origin = _frame(dest), _frame(src)
        return _or_none(self._g, lambda graph: graph.rt.get_transform(target, origin))

    def get_rotation_matrix(self, dest: Any, src: Any, timestamp: int = 0) -> np.ndarray | None:
        matrix = self.get_transformation_matrix(dest, src)
        return None if matrix is None else matrix[:3, :3]

    def get_translation_vector(self, dest: Any, src: Any, timestamp: int = 0) -> np.ndarray | None:
        matrix = self.get_transformation_matrix(dest, src)
        return None if matrix is None else matrix[:3, 3]

    def get_euler_xyz_angles(self, dest: Any, src: Any, timestamp: int = 0) -> np.ndarray | None:
        matrix = self.get_transformation_matrix(dest, src)
        return None if matrix is None else np.array(euler_xyz(matrix[:3, :3]))

    @staticmethod
    def _point_and_frame(args: tuple[Any, ...], length: int) -> tuple[list[float] | None, int | str]:
        if args and isinstance(args[0], (list, tuple, np.ndarray)):
            if len(args) < 2:
                raise DSRTypeError("expected (dest, vector, src[, timestamp])")
            return _vector(args[0], length, "the vector"), _frame(args[1])
        if not args:
            raise DSRTypeError("expected (dest, src[, timestamp])")
        return None, _frame(args[0])
