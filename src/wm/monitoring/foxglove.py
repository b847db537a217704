"""A graph as Foxglove channels, built with the ``foxglove-sdk`` package.

:class:`GraphChannels` opens, on one ``foxglove.Context``, the channels that
both a live view (``wm foxglove``, a WebSocket server) and a recording
(``wm record``, an MCAP file) carry, so the two look alike in Foxglove:

``/wm/tf``       ``foxglove.FrameTransforms``: every RT edge, parent frame -> child frame
                 (frames are node names), for the 3D panel.
``/wm/scene``    ``foxglove.SceneUpdate``: the 2D scene of :mod:`wm.monitoring.scene2d`:
                 bodies as boxes or cylinders with their names, field-of-view cones as
                 triangle fans, ``has_intention`` paths as lines (risky ones red),
                 collision points as red spheres, imagined final poses as translucent
                 boxes. Every update replaces the previous one (it starts with a delete-all).
``/wm/changes``  JSON (schema ``wm.GraphChange``): one graph event, with the values of
                 the attributes it changed.
``/wm/log``      ``foxglove.Log``: the agents' log lines, when given their log directory
                 (:mod:`wm.monitoring.log_tail`).
"""

from __future__ import annotations

import math
from collections.abc import Mapping, Sequence
from pathlib import Path
from typing import Any

import foxglove
from foxglove.channels import FrameTransformsChannel, LogChannel, SceneUpdateChannel
from foxglove.messages import (
    Color,
    CubePrimitive,
    CylinderPrimitive,
    FrameTransform,
    FrameTransforms,
    LinePrimitive,
    LinePrimitiveLineType,
    Point3,
    Pose,
    Quaternion,
    SceneEntity,
    SceneEntityDeletion,
    SceneEntityDeletionType,
    SceneUpdate,
    SpherePrimitive,
    TextPrimitive,
    Timestamp,
    TriangleListPrimitive,
    Vector3,
)

from ..events import Event
from ..graph import Graph
from ..model import Edge, Node
from ..rt import RT
from ..scene_json import encode_value
from . import scene2d
from .log_tail import LogTail, log_message
from .scene2d import fov_wedge

TF, SCENE, CHANGES, LOG = "/wm/tf", "/wm/scene", "/wm/changes", "/wm/log"
CHANGE_SCHEMA: dict[str, Any] = {
    "title": "wm.GraphChange",
    "type": "object",
    "properties": {
        "kind": {"type": "string"},
        "type": {"type": "string"},
        "writer": {"type": "string"},
        "id": {"type": ["integer", "null"]},
        "name": {"type": ["string", "null"]},
        "src": {"type": ["integer", "null"]},
        "dst": {"type": ["integer", "null"]},
        "src_name": {"type": ["string", "null"]},
        "dst_name": {"type": ["string", "null"]},
        "attrs": {"type": "object"},
    },
}

TYPE_COLORS = {
    "robot": (0.16, 0.44, 0.85, 1.0),
    "person": (0.95, 0.6, 0.1, 1.0),
    "object": (0.5, 0.5, 0.5, 1.0),
}
OTHER_COLOR = (0.45, 0.7, 0.45, 1.0)
RISKY = (0.9, 0.1, 0.1, 1.0)
SAFE = (0.3, 0.6, 0.3, 1.0)


def quaternion_xyz(euler: Sequence[float]) -> tuple[float, float, float, float]:
    """(x, y, z, w) of the rotation by intrinsic x-y-z Euler angles: q = qx(a) qy(b) qz(c)."""
    (ca, sa), (cb, sb), (cc, sc) = ((math.cos(v / 2), math.sin(v / 2)) for v in euler)
    return (
        sa * cb * cc + ca * sb * sc,
        ca * sb * cc - sa * cb * sc,
        ca * cb * sc + sa * sb * cc,
        ca * cb * cc - sa * sb * sc,
    )


def _color(rgba: tuple[float, float, float, float], alpha: float | None = None) -> Color:
    r, g, b, a = rgba
    return Color(r=r, g=g, b=b, a=a if alpha is None else alpha)


def _pose(x: float, y: float, z: float = 0.0, yaw: float = 0.0) -> Pose:
    return Pose(
        position=Vector3(x=x, y=y, z=z), orientation=Quaternion(x=0.0, y=0.0, z=math.sin(yaw / 2), w=math.cos(yaw / 2))
    )


def _stamp(t_ns: int) -> Timestamp:
    return Timestamp(sec=t_ns // 1_000_000_000, nsec=t_ns % 1_000_000_000)


def _footprint(item: Mapping[str, Any], color: Color, height: float) -> dict[str, list[Any]]:
    """``cubes`` or ``cylinders``: a body or ghost footprint, as SceneEntity keyword arguments."""
    pose = _pose(item["x"], item["y"], height / 2, item["yaw"])
    if item["shape"] == "box":
        return {"cubes": [CubePrimitive(pose=pose, size=Vector3(x=item["sx"], y=item["sy"], z=height), color=color)]}
    d = 2 * item["r"]
    return {
        "cylinders": [
            CylinderPrimitive(pose=pose, size=Vector3(x=d, y=d, z=height), bottom_scale=1.0, top_scale=1.0, color=color)
        ]
    }


def scene_update(scene: Mapping[str, Any], t_ns: int) -> SceneUpdate:
    """A ``foxglove.SceneUpdate`` drawing ``scene`` (from :func:`wm.monitoring.scene2d.build`) at time ``t_ns``."""
    frame = scene.get("frame") or "world"
    stamp = _stamp(t_ns)

    def entity(ident: str, **primitives: Any) -> SceneEntity:
        return SceneEntity(timestamp=stamp, frame_id=frame, id=ident, **primitives)

    entities = []
    for body in scene["bodies"]:
        label = TextPrimitive(
            pose=_pose(body["x"], body["y"], 0.6),
            billboard=True,
            font_size=14.0,
            scale_invariant=True,
            color=_color((1, 1, 1, 1)),
            text=body["name"],
        )
        entities.append(
            entity(
                f"node/{body['id']}",
                texts=[label],
                **_footprint(body, _color(TYPE_COLORS.get(body["type"], OTHER_COLOR)), 0.3),
            )
        )
    for cone in scene["cones"]:
        wedge = fov_wedge(cone)
        points = []
        for a, b in zip(wedge[1:-2], wedge[2:-1], strict=False):
            points += [
                Point3(x=cone["x"], y=cone["y"], z=0.01),
                Point3(x=a[0], y=a[1], z=0.01),
                Point3(x=b[0], y=b[1], z=0.01),
            ]
        entities.append(
            entity(
                f"fov/{cone['id']}",
                triangles=[
                    TriangleListPrimitive(pose=_pose(0, 0), points=points, color=_color((1.0, 0.85, 0.2, 0.25)))
                ],
            )
        )
    for path in scene["paths"]:
        line = LinePrimitive(
            type=LinePrimitiveLineType.LineStrip,
            pose=_pose(0, 0),
            thickness=0.04,
            points=[Point3(x=x, y=y, z=0.02) for x, y in path["points"]],
            color=_color(RISKY if path["risky"] else SAFE),
        )
        entities.append(entity("path/{}/{}/{}".format(*path["edge"]), lines=[line]))
    for point in scene["points"]:
        sphere = SpherePrimitive(
            pose=_pose(point["x"], point["y"], 0.1), size=Vector3(x=0.2, y=0.2, z=0.2), color=_color(RISKY)
        )
        entities.append(entity("collision/{}/{}/{}".format(*point["edge"]), spheres=[sphere]))
    for ghost in scene["ghosts"]:
        entities.append(entity(f"ghost/{ghost['id']}", **_footprint(ghost, _color(TYPE_COLORS["robot"], 0.35), 0.3)))
    return SceneUpdate(
        deletions=[SceneEntityDeletion(timestamp=stamp, type=SceneEntityDeletionType.All, id="")], entities=entities
    )


def frame_transforms(graph: Graph, t_ns: int) -> FrameTransforms:
    """Every RT edge of ``graph`` as a transform from its parent's frame to its child's (frames are node names)."""
    stamp = _stamp(t_ns)
    names = {node.id: node.name for node in graph.nodes()}
    transforms = []
    for edge in graph.edges(type=RT):
        x, y, z = edge.get("rt_translation", (0.0, 0.0, 0.0))
        qx, qy, qz, qw = quaternion_xyz(edge.get("rt_rotation_euler_xyz", (0.0, 0.0, 0.0)))
        transforms.append(
            FrameTransform(
                timestamp=stamp,
                parent_frame_id=names[edge.src],
                child_frame_id=names[edge.dst],
                translation=Vector3(x=x, y=y, z=z),
                rotation=Quaternion(x=qx, y=qy, z=qz, w=qw),
            )
        )
    return FrameTransforms(transforms=transforms)


def change_of(g: Graph, event: Event) -> dict[str, Any]:
    """An event as JSON-ready data, with the current values of the attributes it names."""
    element: Node | Edge | None = None
    if event.id is not None:
        element = g.find_node(event.id)
    elif event.src is not None and event.dst is not None:
        element = g.find_edge(event.src, event.dst, event.type)
    attrs: Mapping[str, Any] = element.attrs if element is not None else {}
    return {
        "kind": event.kind.value,
        "type": event.type,
        "writer": event.writer,
        "id": event.id,
        "name": event.name,
        "src": event.src,
        "dst": event.dst,
        "src_name": event.src_name,
        "dst_name": event.dst_name,
        "attrs": {k: encode_value(attrs[k]) for k in sorted(event.attrs) if k in attrs},
    }


class GraphChannels:
    """The channels of one graph on one Foxglove context (a live server's or an MCAP writer's)."""

    def __init__(self, context: foxglove.Context, log_dir: str | Path | None = None) -> None:
        self.tf = FrameTransformsChannel(TF, context=context)
        self.scene = SceneUpdateChannel(SCENE, context=context)
        self.changes = foxglove.Channel(CHANGES, schema=CHANGE_SCHEMA, context=context)
        self.log = LogChannel(LOG, context=context)
        self._logs = LogTail(log_dir) if log_dir is not None else None

    def publish_logs(self, t_ns: int) -> int:
        """The log lines added since the last call; returns how many."""
        lines = self._logs.read() if self._logs is not None else []
        for agent, line in lines:
            self.log.log(log_message(agent, line, t_ns), log_time=t_ns)
        return len(lines)

    def publish_change(self, graph: Graph, event: Event, t_ns: int) -> None:
        self.changes.log(change_of(graph, event), log_time=t_ns)

    def publish_view(self, graph: Graph, t_ns: int) -> None:
        """The RT tree and the scene as they are now."""
        self.tf.log(frame_transforms(graph, t_ns), log_time=t_ns)
        self.scene.log(scene_update(scene2d.build(graph), t_ns), log_time=t_ns)
