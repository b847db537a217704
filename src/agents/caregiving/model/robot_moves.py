"""Robot moves: a pose to drive to, the stand-off poses around an object, and travel time.

A :class:`RobotMove` is ``move_to`` a pose. The paper's ``move_to(object)`` is a
stand-off pose around the object, facing it (:func:`standoff_poses`); the move
search of Algorithm 2 adds free poses (:mod:`agents.caregiving.model.candidates`). Travel
time follows a trapezoidal speed profile (accelerate at ``max_accel`` up to
``max_speed``, cruise, brake to rest): :func:`travel_time` and :func:`time_to_cover`
are the lower bounds the search prunes with; the joint imagination steps the real drive.
"""

from __future__ import annotations

import math
from dataclasses import dataclass
from typing import Any

from .errors import RequestError
from .fields import Fields
from .geometry import Box, Circle, corners, point_distance, shapes_overlap, signed_distance
from .scene import RobotState, Scene


@dataclass(frozen=True)
class RobotMove:
    """Drive to ``(x, y)`` and stop facing ``heading`` (rad), next to object ``target``."""

    target: str
    x: float
    y: float
    heading: float

    def to_wire(self) -> dict[str, Any]:
        """A msgpack-friendly dict."""
        return {"target": self.target, "x": self.x, "y": self.y, "heading": self.heading}

    @classmethod
    def from_wire(cls, data: object) -> RobotMove:
        """Parse :meth:`to_wire` output; raises :class:`RequestError` when malformed."""
        return cls.from_fields(Fields(data, "move", RequestError))

    @classmethod
    def from_fields(cls, f: Fields) -> RobotMove:
        """Parse a move nested in a larger message."""
        return cls(f.string("target"), f.number("x"), f.number("y"), f.number("heading", 0.0))

    @classmethod
    def optional_from(cls, f: Fields, key: str) -> RobotMove | None:
        """The move nested at ``key``, or ``None`` when it is absent or null (braking, no move under way)."""
        nested = f.optional_child(key)
        return cls.from_fields(nested) if nested is not None else None


def travel_time(distance: float, max_speed: float, max_accel: float, v0: float = 0.0) -> float:
    """Time to cover ``distance`` from speed ``v0`` and stop, under speed and acceleration limits.

    From a speed too high to stop within ``distance``, the time to brake to rest (past it).
    """
    if distance <= 0.0:
        return 0.0
    v0 = min(max(v0, 0.0), max_speed)
    if v0**2 / (2 * max_accel) > distance:
        return v0 / max_accel
    return time_to_cover(distance, distance, max_speed, max_accel, v0)


def time_to_cover(trip: float, covered: float, max_speed: float, max_accel: float, v0: float = 0.0) -> float:
    """Time until a robot on a ``trip`` of that many metres, ending at rest, has covered ``covered`` of them.

    The same profile as :func:`travel_time`, read part way: on its way to a pose the robot passes a point
    short of it still accelerating or cruising, sooner than if it had to stop there.
    """
    covered = min(covered, trip)
    if covered <= 0.0:
        return 0.0
    v0 = min(max(v0, 0.0), max_speed)
    a = max_accel
    d_up, d_down = (max_speed**2 - v0**2) / (2 * a), max_speed**2 / (2 * a)
    if d_up + d_down <= trip:
        peak, braking_from = max_speed, trip - d_down
    else:
        peak = max(math.sqrt((2 * a * trip + v0**2) / 2), v0)
        braking_from = (peak**2 - v0**2) / (2 * a)
    accelerating_to = (peak**2 - v0**2) / (2 * a)
    if covered <= accelerating_to:
        return (math.sqrt(v0**2 + 2 * a * covered) - v0) / a
    cruising = (min(covered, braking_from) - accelerating_to) / max_speed  # only a trapezoid cruises, at max_speed
    if covered <= braking_from:
        return (peak - v0) / a + cruising
    # Braking: a trip that ends at rest has speed sqrt(2 a s) with s metres left; one begun too fast to
    # stop within it brakes from v0 all the way.
    stops = v0**2 <= 2 * a * trip
    speed = math.sqrt(2 * a * (trip - covered) if stops else max(v0**2 - 2 * a * covered, 0.0))
    return (peak - v0) / a + cruising + (peak - speed) / a


def standoff_moves(scene: Scene, target: str, gap: float = 0.1, count: int = 8) -> list[RobotMove]:
    """Poses around ``target`` (``gap`` metres from its boundary, facing it) where the robot fits."""
    return [m for m in standoff_poses(scene, target, gap, count) if robot_fits(scene, m)]


def standoff_poses(scene: Scene, target: str, gap: float = 0.1, count: int = 8) -> list[RobotMove]:
    """Every pose around ``target``, ``gap`` metres from its boundary and facing it, whether the robot fits or not."""
    return _poses_around(scene, target, scene.obstacle(target).shape, gap, count)


def moves_beside(scene: Scene, person: str, gap: float, count: int = 12) -> list[RobotMove]:
    """Poses beside ``person`` (``gap`` metres from their body, facing them) where the robot fits, nearest first.

    Where the robot goes to someone who needs it (see :mod:`agents.caregiving.model.go_to`): the nearest
    pose is the soonest reached.
    """
    robot = _robot(scene)
    poses = _poses_around(scene, person, scene.person(person).body().shape, gap, count)
    fitting = [m for m in poses if robot_fits(scene, m)]
    return sorted(fitting, key=lambda m: math.hypot(m.x - robot.x, m.y - robot.y))


def _poses_around(scene: Scene, target: str, shape: Circle | Box, gap: float, count: int) -> list[RobotMove]:
    """``count`` poses round ``shape`` (named ``target``), ``gap`` metres from its boundary, facing it."""
    robot = _robot(scene)
    half = max(robot.length, robot.width) / 2
    moves = []
    for k in range(count):
        angle = 2 * math.pi * k / count
        dx, dy = math.cos(angle), math.sin(angle)
        t = shape.r + gap + half if isinstance(shape, Circle) else 0.0  # a circle's offset is exact at once
        for _ in range(20):  # march out to the offset boundary (signed distance is 1-Lipschitz)
            d = point_distance(shape, shape.x + dx * t, shape.y + dy * t)
            if abs(d - (gap + half)) < 1e-4:
                break
            t += (gap + half) - d
        moves.append(RobotMove(target, shape.x + dx * t, shape.y + dy * t, math.atan2(-dy, -dx)))
    return moves


def robot_fits(scene: Scene, move: RobotMove) -> bool:
    """Whether the robot's footprint at the move's pose is inside the room and clear of every body."""
    robot = _robot(scene)
    footprint = Box(move.x, move.y, robot.length / 2, robot.width / 2, move.heading)
    blockers = [o.shape for o in scene.obstacles] + [p.body().shape for p in scene.people]
    x0, y0, x1, y1 = scene.bounds
    inside = bool(
        (
            signed_distance(Box((x0 + x1) / 2, (y0 + y1) / 2, (x1 - x0) / 2, (y1 - y0) / 2), corners(footprint)) <= 0.0
        ).all()
    )
    return inside and not any(shapes_overlap(footprint, b) for b in blockers)


def _robot(scene: Scene) -> RobotState:
    if scene.robot is None:
        raise RequestError("the scene has no robot")
    return scene.robot
