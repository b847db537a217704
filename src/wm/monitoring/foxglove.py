"""The 2D scene (:mod:`wm.monitoring.scene2d`) as a Foxglove ``foxglove.SceneUpdate`` in JSON.

Foxglove's 3D panel draws a ``/wm/scene`` channel of a recording as it is:
bodies as boxes or cylinders with their names, field-of-view cones as
triangle fans, ``has_intention`` paths as lines (risky ones red), collision
points as red spheres and imagined final poses as translucent boxes. Every
update replaces the previous one (it starts with a delete-all).
"""

from __future__ import annotations

import math
from typing import Any

from .scene2d import fov_wedge

SCHEMA_NAME = "foxglove.SceneUpdate"

_VEC3 = {"type": "object", "properties": {k: {"type": "number"} for k in "xyz"}}
_QUAT = {"type": "object", "properties": {k: {"type": "number"} for k in "xyzw"}}
_COLOR = {"type": "object", "properties": {k: {"type": "number"} for k in "rgba"}}
_TIME = {"type": "object", "properties": {"sec": {"type": "integer"}, "nsec": {"type": "integer"}}}
_POSE = {"type": "object", "properties": {"position": _VEC3, "orientation": _QUAT}}
_SHAPE = {"type": "object", "properties": {"pose": _POSE, "size": _VEC3, "color": _COLOR}}


def _ARRAY_OF(item: dict[str, Any]) -> dict[str, Any]:
    return {"type": "array", "items": item}


SCHEMA: dict[str, Any] = {
    "title": SCHEMA_NAME,
    "description": "An update to the entities displayed in a 3D scene",
    "type": "object",
    "properties": {
        "deletions": _ARRAY_OF(
            {"type": "object", "properties": {"timestamp": _TIME, "type": {"type": "integer"}, "id": {"type": "string"}}}
        ),
        "entities": _ARRAY_OF(
            {
                "type": "object",
                "properties": {
                    "timestamp": _TIME,
                    "frame_id": {"type": "string"},
                    "id": {"type": "string"},
                    "lifetime": _TIME,
                    "frame_locked": {"type": "boolean"},
                    "metadata": _ARRAY_OF({"type": "object", "properties": {"key": {"type": "string"}, "value": {"type": "string"}}}),
                    "cubes": _ARRAY_OF(_SHAPE),
                    "cylinders": _ARRAY_OF(_SHAPE),
                    "spheres": _ARRAY_OF(_SHAPE),
                    "lines": _ARRAY_OF(
                        {
                            "type": "object",
                            "properties": {
                                "type": {"type": "integer"}, "pose": _POSE, "thickness": {"type": "number"},
                                "scale_invariant": {"type": "boolean"}, "points": _ARRAY_OF(_VEC3), "color": _COLOR,
                                "colors": _ARRAY_OF(_COLOR), "indices": _ARRAY_OF({"type": "integer"}),
                            },
                        }
                    ),
                    "triangles": _ARRAY_OF(
                        {
                            "type": "object",
                            "properties": {
                                "pose": _POSE, "points": _ARRAY_OF(_VEC3), "color": _COLOR,
                                "colors": _ARRAY_OF(_COLOR), "indices": _ARRAY_OF({"type": "integer"}),
                            },
                        }
                    ),
                    "texts": _ARRAY_OF(
                        {
                            "type": "object",
                            "properties": {
                                "pose": _POSE, "billboard": {"type": "boolean"}, "font_size": {"type": "number"},
                                "scale_invariant": {"type": "boolean"}, "color": _COLOR, "text": {"type": "string"},
                            },
                        }
                    ),
                },
            }
        ),
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
LINE_STRIP, DELETE_ALL = 0, 1


def _color(rgba: tuple[float, float, float, float], alpha: float | None = None) -> dict[str, float]:
    r, g, b, a = rgba
    return {"r": r, "g": g, "b": b, "a": a if alpha is None else alpha}


def _pose(x: float, y: float, z: float = 0.0, yaw: float = 0.0) -> dict[str, Any]:
    return {
        "position": {"x": x, "y": y, "z": z},
        "orientation": {"x": 0.0, "y": 0.0, "z": math.sin(yaw / 2), "w": math.cos(yaw / 2)},
    }


def _stamp(t_ns: int) -> dict[str, int]:
    return {"sec": t_ns // 1_000_000_000, "nsec": t_ns % 1_000_000_000}


def _shape(item: dict[str, Any], color: dict[str, float], height: float) -> tuple[str, dict[str, Any]]:
    """("cubes" or "cylinders", primitive) for a body or ghost footprint."""
    pose = _pose(item["x"], item["y"], height / 2, item["yaw"])
    if item["shape"] == "box":
        return "cubes", {"pose": pose, "size": {"x": item["sx"], "y": item["sy"], "z": height}, "color": color}
    d = 2 * item["r"]
    return "cylinders", {"pose": pose, "size": {"x": d, "y": d, "z": height}, "bottom_scale": 1.0, "top_scale": 1.0, "color": color}


def scene_update(scene: dict[str, Any], t_ns: int) -> dict[str, Any]:
    """A ``foxglove.SceneUpdate`` drawing ``scene`` (from :func:`wm.monitoring.scene2d.build`) at time ``t_ns``."""
    frame = scene.get("frame") or "world"
    stamp = _stamp(t_ns)

    def entity(ident: str, **primitives: list[dict[str, Any]]) -> dict[str, Any]:
        return {"timestamp": stamp, "frame_id": frame, "id": ident, "lifetime": {"sec": 0, "nsec": 0}, "frame_locked": False,
                "metadata": [], **primitives}

    entities = []
    for body in scene["bodies"]:
        kind, primitive = _shape(body, _color(TYPE_COLORS.get(body["type"], OTHER_COLOR)), 0.3)
        label = {"pose": _pose(body["x"], body["y"], 0.6), "billboard": True, "font_size": 14.0, "scale_invariant": True,
                 "color": _color((1, 1, 1, 1)), "text": body["name"]}
        entities.append(entity(f"node/{body['id']}", **{kind: [primitive]}, texts=[label]))
    for cone in scene["cones"]:
        wedge = fov_wedge(cone)
        points = []
        for a, b in zip(wedge[1:-2], wedge[2:-1]):
            points += [{"x": cone["x"], "y": cone["y"], "z": 0.01}, {"x": a[0], "y": a[1], "z": 0.01}, {"x": b[0], "y": b[1], "z": 0.01}]
        fan = {"pose": _pose(0, 0), "points": points, "color": _color((1.0, 0.85, 0.2, 0.25)), "colors": [], "indices": []}
        entities.append(entity(f"fov/{cone['id']}", triangles=[fan]))
    for path in scene["paths"]:
        line = {"type": LINE_STRIP, "pose": _pose(0, 0), "thickness": 0.04, "scale_invariant": False,
                "points": [{"x": x, "y": y, "z": 0.02} for x, y in path["points"]],
                "color": _color(RISKY if path["risky"] else SAFE), "colors": [], "indices": []}
        entities.append(entity("path/{}/{}/{}".format(*path["edge"]), lines=[line]))
    for point in scene["points"]:
        sphere = {"pose": _pose(point["x"], point["y"], 0.1), "size": {"x": 0.2, "y": 0.2, "z": 0.2}, "color": _color(RISKY)}
        entities.append(entity("collision/{}/{}/{}".format(*point["edge"]), spheres=[sphere]))
    for ghost in scene["ghosts"]:
        kind, primitive = _shape(ghost, _color(TYPE_COLORS["robot"], 0.35), 0.3)
        entities.append(entity(f"ghost/{ghost['id']}", **{kind: [primitive]}))
    return {"deletions": [{"timestamp": stamp, "type": DELETE_ALL, "id": ""}], "entities": entities}
