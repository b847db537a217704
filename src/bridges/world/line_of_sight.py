"""What sensors riding on the robot can see: straight lines of sight over the room's bodies, by their heights.

The sensors sit at the top of the robot. A body is in view when the line from them to any of its sample
points (its footprint's centre and corners; for a disc, its centre and its two sides square to the line of
sight) clears everything else on the way:

* a wall always stands in the way;
* any other body (a piece of furniture, a person, someone lying where they fell) does where the line, over its
  footprint, comes down to its height or below.

Each line is aimed at its point at the body's top, or at the sensors' own height for a body taller than the
robot. So a standing person's head shows over a bed, while a toy on the floor shows behind the bed only if it
lies far enough back for the line to clear the bed's top.
"""

from __future__ import annotations

import math
from collections.abc import Sequence

import numpy as np

from agents.caregiving.model.geometry import Box, FloatArray, Shape, corner_points, segment_exits
from agents.caregiving.model.scene import Obstacle
from agents.caregiving.model.visibility import WALL_KIND


def sample_points(shape: Shape, eye: tuple[float, float]) -> list[tuple[float, float]]:
    """The points of a footprint a line of sight from ``eye`` is aimed at: its centre and its corners, or a
    disc's centre and its two sides square to the line from ``eye``."""
    if isinstance(shape, Box):
        return [(shape.x, shape.y), *corner_points(shape)]
    dx, dy = shape.x - eye[0], shape.y - eye[1]
    norm = math.hypot(dx, dy)
    if norm == 0.0:
        return [(shape.x, shape.y)]
    sx, sy = -dy / norm * shape.r, dx / norm * shape.r
    return [(shape.x, shape.y), (shape.x + sx, shape.y + sy), (shape.x - sx, shape.y - sy)]


def in_view(sensor: tuple[float, float, float], bodies: Sequence[Obstacle]) -> frozenset[str]:
    """The names of the bodies other than walls that a sensor at ``(x, y, height)`` sees, each of ``bodies``
    (walls included) standing in the way of the others as the module says."""
    eye, height = (sensor[0], sensor[1]), sensor[2]
    targets = [b for b in bodies if b.kind != WALL_KIND]
    index = {b.name: k for k, b in enumerate(targets)}
    points: list[tuple[float, float]] = []
    owner: list[int] = []
    aim: list[float] = []
    for k, body in enumerate(targets):
        for p in sample_points(body.shape, eye):
            points.append(p)
            owner.append(k)
            aim.append(min(body.height, height))
    if not points:
        return frozenset()
    ends: FloatArray = np.asarray(points, dtype=np.float64)
    owners = np.asarray(owner)
    aimed = np.asarray(aim, dtype=np.float64)
    clear = np.ones(len(points), dtype=bool)
    for body in bodies:
        exits = segment_exits(body.shape, eye, ends)
        crossed = ~np.isnan(exits)
        if body.kind != WALL_KIND:
            # The line is lowest where it leaves the body (it comes down from the sensors towards its point).
            crossed &= body.height >= height + (aimed - height) * np.nan_to_num(exits)
            crossed &= owners != index[body.name]
        clear &= ~crossed
    return frozenset(targets[k].name for k in set(owners[clear].tolist()))
