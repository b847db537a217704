"""The 2D scene of a graph: what a top-down view draws, for any graph and ontology.

:func:`build` places every node of the RT tree in the frame of its root (the
``world`` node when there is one) and returns plain data, shared by the
browser view (:mod:`wm.monitoring.view`) and the Foxglove channel of a recording
(:mod:`wm.monitoring.foxglove`):

``bodies``  one per placed node: pose, type, and a footprint (box or circle)
            from ``footprint``/``size``/``shape``/``radius`` when present;
``cones``   a field-of-view wedge for every placed node with ``fov``;
``paths``   every edge with a ``path`` attribute (``risky`` ones flagged);
``points``  every edge's ``collision_point``;
``ghosts``  every node with a ``final_pose`` (an imagined pose), drawn with
            the ``footprint`` of the node that has it when that one has one.

Those attribute names are the drawing conventions of wm's views, not types:
any ontology that declares them gets them drawn (the caregiving one does), and
a graph without them still gets its placed nodes. The frame is the ``world``
node, the root frame the base ontology declares.
"""

from __future__ import annotations

import math
from typing import Any

import numpy as np

from ..errors import WMError
from ..graph import Graph
from ..model import Node
from ..rt import RT, homogeneous, matrix_to_se2

CONE_RANGE_M = 2.0
DEFAULT_RADIUS_M = 0.15
ROOT_TYPE = "world"  # the root frame of a scene, in the base ontology


def root_node(g: Graph) -> Node | None:
    """The frame the scene is drawn in: the first ``world`` node, else the root of the first RT edge."""
    worlds = g.nodes(ROOT_TYPE)
    if worlds:
        return worlds[0]
    edges = g.edges(type=RT)
    if not edges:
        return None
    node, seen = edges[0].src, set()
    while (parent := g.rt.parent(node)) is not None and parent not in seen:
        seen.add(node)
        node = parent
    return g.get_node(node)


def world_poses(g: Graph, root: int) -> dict[int, tuple[float, float, float]]:
    """(x, y, yaw) in the root's frame of every node reached from ``root`` along RT edges."""
    children: dict[int, list[tuple[int, np.ndarray]]] = {}
    for edge in g.edges(type=RT):
        local = homogeneous(
            edge.get("rt_translation", (0.0, 0.0, 0.0)), edge.get("rt_rotation_euler_xyz", (0.0, 0.0, 0.0))
        )
        children.setdefault(edge.src, []).append((edge.dst, local))
    poses: dict[int, tuple[float, float, float]] = {root: (0.0, 0.0, 0.0)}
    stack = [(root, np.eye(4))]
    while stack:
        parent, matrix = stack.pop()
        for child, local in children.get(parent, []):
            if child not in poses:
                pose = matrix @ local
                poses[child] = matrix_to_se2(pose)
                stack.append((child, pose))
    return poses


def footprint(node: Node) -> dict[str, Any]:
    """The outline of a node: ``{"shape": "box", "sx", "sy"}`` or ``{"shape": "circle", "r"}``."""
    if (fp := node.get("footprint")) is not None and len(fp) >= 2:
        return {"shape": "box", "sx": float(fp[1]), "sy": float(fp[0])}
    size = node.get("size")
    if node.get("shape") == "box" and size is not None and len(size) >= 2:
        return {"shape": "box", "sx": float(size[0]), "sy": float(size[1])}
    if size is not None and len(size) >= 1:
        return {"shape": "circle", "r": float(size[0]) / 2}
    return {"shape": "circle", "r": float(node.get("radius", DEFAULT_RADIUS_M))}


def _pairs(values: Any) -> list[list[float]]:
    flat = [float(v) for v in values or ()]
    return [[flat[i], flat[i + 1]] for i in range(0, len(flat) - 1, 2)]


def build(g: Graph) -> dict[str, Any]:
    """The scene of ``g`` as JSON-ready data (see the module docstring)."""
    root = root_node(g)
    scene: dict[str, Any] = {
        "frame": root.name if root else None,
        "bodies": [],
        "cones": [],
        "paths": [],
        "points": [],
        "ghosts": [],
    }
    if root is None:
        return scene
    try:
        poses = world_poses(g, root.id)
    except WMError:
        return scene
    owners: dict[int, Node] = {}
    for node in g.nodes():
        if node.id not in poses or node.id == root.id:
            continue
        x, y, yaw = poses[node.id]
        scene["bodies"].append(
            {"id": node.id, "name": node.name, "type": node.type, "x": x, "y": y, "yaw": yaw, **footprint(node)}
        )
        if (fov := node.get("fov")) is not None:
            scene["cones"].append({"id": node.id, "x": x, "y": y, "yaw": yaw, "fov": float(fov), "range": CONE_RANGE_M})
    if (room := root.get("room_size")) is not None:
        scene["room"] = {"sx": float(room[0]), "sy": float(room[1])}
    for edge in g.edges():
        ref = [edge.src, edge.dst, edge.type]
        if edge.get("path"):
            scene["paths"].append(
                {"edge": ref, "points": _pairs(edge.get("path")), "risky": bool(edge.get("risky", False))}
            )
        if (point := edge.get("collision_point")) is not None:
            scene["points"].append({"edge": ref, "x": float(point[0]), "y": float(point[1])})
        if edge.type != RT:
            owners.setdefault(edge.dst, g.get_node(edge.src))
    for node in g.nodes():
        if (pose := node.get("final_pose")) is not None and len(pose) >= 3:
            owner = owners.get(node.id)
            shape = footprint(owner) if owner is not None and owner.get("footprint") is not None else footprint(node)
            scene["ghosts"].append(
                {"id": node.id, "name": node.name, "x": pose[0], "y": pose[1], "yaw": pose[2], **shape}
            )
    return scene


def fov_wedge(cone: dict[str, Any], steps: int = 12) -> list[list[float]]:
    """The outline of a field-of-view cone as a closed polygon (apex first)."""
    x, y, yaw, half, reach = cone["x"], cone["y"], cone["yaw"], cone["fov"] / 2, cone["range"]
    arc = [
        [
            x + reach * math.cos(yaw - half + 2 * half * i / steps),
            y + reach * math.sin(yaw - half + 2 * half * i / steps),
        ]
        for i in range(steps + 1)
    ]
    return [[x, y], *arc, [x, y]]
