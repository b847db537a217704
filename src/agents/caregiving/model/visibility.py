"""What a person can see: a horizontal field-of-view cone and a vertical gaze window.

An object is seen when its footprint overlaps the horizontal cone about the
person's heading *and* its elevation span, seen from the eyes, overlaps the
vertical window ``[gaze - vfov/2, gaze + vfov/2]``. A low ball close by sits
below the window, which is why the paper's person walks into it. Walls are
always known (people know their own room). Since each object is seen for one
interval of gaze, the gaze range splits into a few classes with the same visible
set: :func:`gaze_classes` enumerates them exactly, so no sampling is needed.
"""

from __future__ import annotations

import math
from collections.abc import Iterable, Sequence
from dataclasses import dataclass

import numpy as np
from numpy.typing import NDArray

from .geometry import Circle, FloatArray, Shape, bounding_radius, corner_points, point_distance, signed_distance
from .scene import Obstacle, PersonState

WALL_KIND = "wall"
#: Metres (and radians) taken off :func:`sight`'s bounds, far above the rounding of their arithmetic.
UNSEEN_SLACK = 1e-6


def wrap_angle(angle: float) -> float:
    """The angle in [-pi, pi)."""
    return (angle + math.pi) % (2 * math.pi) - math.pi


def off_heading(person: PersonState, obstacle: Obstacle) -> float:
    """How far (radians, unsigned) the direction to the obstacle's centre lies off the person's heading."""
    return abs(wrap_angle(math.atan2(obstacle.shape.y - person.y, obstacle.shape.x - person.x) - person.heading))


def in_horizontal_fov(person: PersonState, obstacle: Obstacle) -> bool:
    """Whether any part of the footprint lies inside the person's horizontal cone."""
    return _in_cone(person, obstacle.shape, point_distance(obstacle.shape, person.x, person.y))


def _in_cone(person: PersonState, shape: Shape, inside: float) -> bool:
    """:func:`in_horizontal_fov`, given the person's signed distance to the shape."""
    return _cone_gap(person, shape, inside) <= 0.0


def _cone_gap(person: PersonState, shape: Shape, inside: float) -> float:
    """The angle (rad) between the footprint's directions and the person's horizontal cone; 0.0 or less in it."""
    if inside <= 0.0:
        return 0.0
    centre = math.atan2(shape.y - person.y, shape.x - person.x)
    offset = wrap_angle(centre - person.heading)
    half_fov = person.hfov / 2
    if -half_fov <= offset <= half_fov:
        return 0.0  # the centre itself is in view (the footprint's span holds its direction)
    dist = math.hypot(shape.x - person.x, shape.y - person.y)
    if isinstance(shape, Circle):
        half = math.asin(min(1.0, shape.r / dist))
        lo, hi = -half, half
    else:
        rel = [wrap_angle(math.atan2(y - person.y, x - person.x) - centre) for x, y in corner_points(shape)]
        lo, hi = min(rel), max(rel)
    if offset > 0.0:  # left of the cone; the way round the back is the other gap
        return min(offset + lo - half_fov, 2 * math.pi - offset - hi - half_fov)
    return min(-half_fov - offset - hi, 2 * math.pi + offset + lo - half_fov)


def elevation_span(person: PersonState, obstacle: Obstacle) -> tuple[float, float]:
    """Lowest and highest elevation (rad, up positive) of the object seen from the eyes."""
    return _elevations(person, obstacle, point_distance(obstacle.shape, person.x, person.y))


def _gaze_window(person: PersonState, obstacle: Obstacle, inside: float) -> tuple[float, float]:
    """The gaze pitches at which the object's elevation span meets the vertical field of view."""
    low, high = _elevations(person, obstacle, inside)
    return low - person.vfov / 2, high + person.vfov / 2


def _elevations(person: PersonState, obstacle: Obstacle, inside: float) -> tuple[float, float]:
    """:func:`elevation_span`, given the person's signed distance to the footprint."""
    near = max(inside, 1e-3)
    far = math.hypot(obstacle.shape.x - person.x, obstacle.shape.y - person.y) + bounding_radius(obstacle.shape)
    top = obstacle.height - person.eye_height
    low = math.atan2(-person.eye_height, near)
    high = math.atan2(top, far if top < 0.0 else near)
    return low, high


def gaze_interval(person: PersonState, obstacle: Obstacle) -> tuple[float, float] | None:
    """The gaze pitches for which the object is seen, or ``None`` if it is outside the cone."""
    if obstacle.kind == WALL_KIND:
        return (-math.pi / 2, math.pi / 2)
    inside = point_distance(obstacle.shape, person.x, person.y)
    if not _in_cone(person, obstacle.shape, inside):
        return None
    return _gaze_window(person, obstacle, inside)


def can_see(person: PersonState, obstacle: Obstacle, gaze: float) -> bool:
    """Whether the person, gazing at pitch ``gaze`` (rad), sees the obstacle."""
    return sight(person, obstacle, gaze) is None


@dataclass(frozen=True)
class Hidden:
    """Why a person cannot see an object now: how far (m) they must at least move before they can, while
    turning less than ``turn`` (rad) from the heading they have now (``inf``: however they turn)."""

    distance: float
    turn: float = math.inf


def sight(person: PersonState, obstacle: Obstacle, gaze: float) -> Hidden | None:
    """``None`` when the person, gazing at pitch ``gaze`` (rad), sees the obstacle; else a :class:`Hidden` bound.

    :func:`gaze_interval`'s two tests, the cheaper first: an object below or above the gaze window (a low
    ball close by) is rejected before its bearing is worked out. The window's edges depend only on the
    distances from the eyes' foot to the footprint's nearest point and to its far side, which moving ``d``
    changes by at most ``d``; so an object outside the window stays out of it, however the person turns, until
    they have moved the distance that closes the gap (``inf``: none does). An object in the window but outside
    the cone stays outside while the person moves less than ``r sin(gap / 2)`` (``r`` their distance to it)
    and turns less than ``gap / 2``: moving ``d`` turns the direction to any point of the footprint by at most
    ``asin(d / r)``. Both bounds are shortened by :data:`UNSEEN_SLACK`, so that rounding never hides a sighting.
    """
    if obstacle.kind == WALL_KIND:
        return None
    inside = point_distance(obstacle.shape, person.x, person.y)
    low, high = _gaze_window(person, obstacle, inside)
    if low <= gaze <= high:
        gap = _cone_gap(person, obstacle.shape, inside)
        if gap <= 0.0:
            return None
        turn = max(gap / 2 - UNSEEN_SLACK, 0.0)
        return Hidden(max(inside * math.sin(turn) - UNSEEN_SLACK, 0.0), turn)
    half = person.vfov / 2
    near = max(inside, 1e-3)
    top = obstacle.height - person.eye_height
    if gaze < low:  # the footprint's nearest floor point lies below the window: come nearer
        needed = near - person.eye_height / math.tan(-(gaze + half))
    elif top >= 0.0:  # a tall object's top lies below the window: come nearer
        needed = near - top / math.tan(gaze - half)
    elif gaze - half < 0.0:  # a low object's top lies below the window: step back until it rises into it
        far = math.hypot(obstacle.shape.x - person.x, obstacle.shape.y - person.y) + bounding_radius(obstacle.shape)
        needed = top / math.tan(gaze - half) - far
    else:
        return Hidden(math.inf)
    return Hidden(max(needed - UNSEEN_SLACK, 0.0))


def _wrap_all(angles: FloatArray) -> FloatArray:
    return np.mod(angles + math.pi, 2 * math.pi) - math.pi


def seen_along(
    person: PersonState, xs: FloatArray, ys: FloatArray, headings: FloatArray, obstacle: Obstacle, gaze: float
) -> NDArray[np.bool_]:
    """:func:`can_see` for the person standing at each of many poses (``xs``, ``ys``, ``headings``) at once."""
    if obstacle.kind == WALL_KIND:
        return np.ones(len(xs), dtype=bool)
    shape = obstacle.shape
    pts = np.stack((xs, ys), axis=1)
    inside = signed_distance(shape, pts)
    centre = np.arctan2(shape.y - ys, shape.x - xs)
    if isinstance(shape, Circle):
        dist = np.hypot(shape.x - xs, shape.y - ys)
        half = np.arcsin(np.minimum(1.0, shape.r / np.maximum(dist, 1e-12)))
        lo, hi = -half, half
    else:
        rel = np.stack([_wrap_all(np.arctan2(cy - ys, cx - xs) - centre) for cx, cy in corner_points(shape)])
        lo, hi = rel.min(axis=0), rel.max(axis=0)
    offset = _wrap_all(centre - headings)
    in_cone = (inside <= 0.0) | ((offset + hi >= -person.hfov / 2) & (offset + lo <= person.hfov / 2))
    near = np.maximum(inside, 1e-3)
    far = np.hypot(shape.x - xs, shape.y - ys) + bounding_radius(shape)
    top = obstacle.height - person.eye_height
    low = np.arctan2(-person.eye_height, near) - person.vfov / 2
    high = np.arctan2(top, far if top < 0.0 else near) + person.vfov / 2
    return in_cone & (low <= gaze) & (gaze <= high)


def visible(person: PersonState, obstacles: Iterable[Obstacle], gaze: float) -> tuple[Obstacle, ...]:
    """The obstacles seen at gaze ``gaze`` (walls always included)."""
    return tuple(o for o in obstacles if can_see(person, o, gaze))


def candidate_targets(person: PersonState, obstacles: Iterable[Obstacle]) -> tuple[Obstacle, ...]:
    """Possible destinations inside the person's horizontal cone (Algorithm 1, line 5)."""
    return tuple(o for o in obstacles if o.target and in_horizontal_fov(person, o))


@dataclass(frozen=True)
class GazeClass:
    """A sub-range of gaze pitches over which the person sees the same objects."""

    low: float
    high: float
    visible: frozenset[str]

    @property
    def gaze(self) -> float:
        """A representative gaze of the class (its midpoint)."""
        return (self.low + self.high) / 2


def first_of(gazes: Sequence[float], k: int) -> tuple[float, ...]:
    """The gazes with the ``k``-th first and the others in their order: a walk set's gaze classes, the one a
    danger is searched at first."""
    return (gazes[k], *gazes[:k], *gazes[k + 1 :])


def surely_seen(classes: Sequence[GazeClass]) -> frozenset[str]:
    """What is seen in every one of a person's gaze classes: seen whatever their gaze."""
    return frozenset.intersection(*(c.visible for c in classes)) if classes else frozenset()


def gaze_classes(person: PersonState, obstacles: Sequence[Obstacle]) -> tuple[GazeClass, ...]:
    """Split ``[gaze_min, gaze_max]`` into the classes with distinct visible sets, in order."""
    intervals = {o.name: gaze_interval(person, o) for o in obstacles}
    if person.gaze_max <= person.gaze_min:
        g = person.gaze_min
        return (GazeClass(g, g, frozenset(n for n, iv in intervals.items() if iv is not None and iv[0] <= g <= iv[1])),)
    cuts = {person.gaze_min, person.gaze_max}
    for interval in intervals.values():
        if interval is not None:
            cuts.update(c for c in interval if person.gaze_min < c < person.gaze_max)
    edges = sorted(cuts)
    classes: list[GazeClass] = []
    for low, high in zip(edges[:-1], edges[1:], strict=True):
        mid = (low + high) / 2
        seen = frozenset(n for n, iv in intervals.items() if iv is not None and iv[0] <= mid <= iv[1])
        if classes and classes[-1].visible == seen:
            classes[-1] = GazeClass(classes[-1].low, high, seen)
        else:
            classes.append(GazeClass(low, high, seen))
    return tuple(classes)
