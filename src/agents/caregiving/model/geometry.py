"""Planar shapes and the distance queries the caregiving stack is built on.

Every footprint in the room is either a :class:`Circle` or an oriented
:class:`Box` on the floor plane. Queries are vectorised over many points at
once, so a whole walk can be checked against a shape in one numpy call.
Signed distances are negative inside a shape.
"""

from __future__ import annotations

import bisect
import math
from collections.abc import Sequence
from dataclasses import dataclass, field
from functools import cached_property

import numpy as np
from numpy.typing import ArrayLike, NDArray

FloatArray = NDArray[np.float64]


@dataclass(frozen=True)
class Circle:
    """A disc of radius ``r`` centred at ``(x, y)``."""

    x: float
    y: float
    r: float

    @property
    def bound(self) -> float:
        """Radius of the smallest circle about the centre that contains it: the radius itself."""
        return self.r


@dataclass(frozen=True)
class Box:
    """A rectangle centred at ``(x, y)`` with half extents ``hx``, ``hy``, rotated by ``theta`` rad."""

    x: float
    y: float
    hx: float
    hy: float
    theta: float = 0.0
    #: ``(cos theta, sin theta)``.
    rotation: tuple[float, float] = field(init=False, repr=False, compare=False)
    #: Radius of the smallest circle about the centre that contains it.
    bound: float = field(init=False, repr=False, compare=False)

    def __post_init__(self) -> None:
        # Worked out once per box, as plain attributes: the distance queries of every step ask for them, and
        # a cached_property takes a lock the first time it is read (in every new box, such as the robot's
        # body at each step).
        object.__setattr__(self, "rotation", (math.cos(self.theta), math.sin(self.theta)))
        object.__setattr__(self, "bound", math.hypot(self.hx, self.hy))


Shape = Circle | Box


def as_points(points: ArrayLike) -> FloatArray:
    """Return ``points`` as an ``(N, 2)`` float array (a single point becomes ``(1, 2)``)."""
    arr = np.asarray(points, dtype=np.float64)
    return arr.reshape(-1, 2)


def _to_local(box: Box, pts: FloatArray) -> FloatArray:
    c, s = math.cos(box.theta), math.sin(box.theta)
    d = pts - (box.x, box.y)
    return np.stack((c * d[:, 0] + s * d[:, 1], -s * d[:, 0] + c * d[:, 1]), axis=1)


def _to_world(box: Box, local: FloatArray) -> FloatArray:
    c, s = math.cos(box.theta), math.sin(box.theta)
    return np.stack((c * local[:, 0] - s * local[:, 1] + box.x, s * local[:, 0] + c * local[:, 1] + box.y), axis=1)


def _offset_distance(shape: Shape, dx: FloatArray, dy: FloatArray) -> FloatArray:
    """Signed distance to the shape's boundary of the points offset ``(dx, dy)`` from its centre (broadcast)."""
    if isinstance(shape, Circle):
        return np.hypot(dx, dy) - shape.r
    c, s = math.cos(shape.theta), math.sin(shape.theta)
    qx = np.abs(c * dx + s * dy) - shape.hx
    qy = np.abs(-s * dx + c * dy) - shape.hy
    return np.hypot(np.maximum(qx, 0.0), np.maximum(qy, 0.0)) + np.minimum(np.maximum(qx, qy), 0.0)


def signed_distance(shape: Shape, points: ArrayLike) -> FloatArray:
    """Signed distance from each point to the shape's boundary (negative inside)."""
    pts = as_points(points)
    return _offset_distance(shape, pts[:, 0] - shape.x, pts[:, 1] - shape.y)


def grid_distance(shape: Shape, xs: FloatArray, ys: FloatArray) -> FloatArray:
    """:func:`signed_distance` at every ``(xs[i], ys[j])`` of a grid, as an ``(len(xs), len(ys))`` array."""
    return _offset_distance(shape, (xs - shape.x)[:, None], (ys - shape.y)[None, :])


def point_distance(shape: Shape, x: float, y: float) -> float:
    """:func:`signed_distance` of one point, in plain floats (for the many single-point queries)."""
    if isinstance(shape, Circle):
        return math.hypot(x - shape.x, y - shape.y) - shape.r
    c, s = shape.rotation
    dx, dy = x - shape.x, y - shape.y
    qx, qy = abs(c * dx + s * dy) - shape.hx, abs(-s * dx + c * dy) - shape.hy
    return math.hypot(max(qx, 0.0), max(qy, 0.0)) + min(max(qx, qy), 0.0)


def corner_points(box: Box) -> list[tuple[float, float]]:
    """The four corners of a box, counter-clockwise, as plain float pairs (see :func:`corners`)."""
    c, s = box.rotation
    return [
        (box.x + c * u - s * v, box.y + s * u + c * v)
        for u, v in ((box.hx, box.hy), (-box.hx, box.hy), (-box.hx, -box.hy), (box.hx, -box.hy))
    ]


def closest_boundary_point(shape: Shape, points: ArrayLike) -> FloatArray:
    """The point of the shape's boundary nearest to each query point."""
    pts = as_points(points)
    if isinstance(shape, Circle):
        d = pts - (shape.x, shape.y)
        n = np.hypot(d[:, 0], d[:, 1])
        safe = np.where(n > 0.0, n, 1.0)
        unit = np.where(n[:, None] > 0.0, d / safe[:, None], np.array([1.0, 0.0]))
        return (shape.x, shape.y) + unit * shape.r
    local = _to_local(shape, pts)
    half = np.array([shape.hx, shape.hy])
    clamped = np.clip(local, -half, half)
    inside = np.all(np.abs(local) < half, axis=1)
    if np.any(inside):
        # Push interior points out through the nearest face.
        gap = half - np.abs(local[inside])
        axis = np.argmin(gap, axis=1)
        rows = np.arange(axis.size)
        moved = clamped[inside].copy()
        moved[rows, axis] = np.copysign(half[axis], local[inside][rows, axis])
        clamped[inside] = moved
    return _to_world(shape, clamped)


def corners(box: Box) -> FloatArray:
    """The four corners of a box, counter-clockwise, as a ``(4, 2)`` array."""
    return np.array(corner_points(box))


def displacement(before: Shape, after: Shape) -> float:
    """How far a body moved between two poses: its farthest-moved corner for boxes (so turning counts), else its centre."""
    if isinstance(before, Box) and isinstance(after, Box):
        return max(math.dist(a, b) for a, b in zip(corner_points(before), corner_points(after), strict=True))
    return math.hypot(after.x - before.x, after.y - before.y)


def moved_more_than(before: Shape, after: Shape, distance: float) -> bool:
    """``displacement(before, after) > distance``, without the corners when the centre's shift settles it.

    Two opposite corners of a box move by ``t + v`` and ``t - v`` (``t`` the centre's shift), and one of
    them moves at least ``|t|``: so a centre shift beyond ``distance`` settles it. Each corner of a box of
    the same size moves at most ``|t|`` plus the chord its turn sweeps at the box's bounding radius: a sum
    short of ``distance`` settles it the other way.
    """
    shift = math.hypot(after.x - before.x, after.y - before.y)
    if shift > distance:
        return True
    if isinstance(before, Box) and isinstance(after, Box) and before.hx == after.hx and before.hy == after.hy:
        chord = 2.0 * abs(math.sin((after.theta - before.theta) / 2.0)) * before.bound
        if shift + chord < distance - 1e-9:
            return False
    return displacement(before, after) > distance


def nearest_segment(points: FloatArray, x: float, y: float) -> tuple[int, float]:
    """The segment of the polyline through ``points`` (an ``(N, 2)`` array) nearest ``(x, y)``, and its distance.

    Of two segments equally near (where they meet at a waypoint), the later one; a single point is segment 0.
    """
    pts = points.tolist()
    ax, ay = pts[0]
    if len(pts) == 1:
        return 0, math.hypot(x - ax, y - ay)
    best, nearest = math.inf, 0
    for k, (bx, by) in enumerate(pts[1:]):
        t = segment_fraction((ax, ay), (bx, by), x, y)
        gap = math.hypot(x - ax - t * (bx - ax), y - ay - t * (by - ay))
        if gap <= best:
            best, nearest = gap, k
        ax, ay = bx, by
    return nearest, best


def segment_fraction(a: Sequence[float], b: Sequence[float], x: float, y: float) -> float:
    """How far along the segment from ``a`` to ``b`` (0 to 1) its point nearest ``(x, y)`` lies."""
    dx, dy = b[0] - a[0], b[1] - a[1]
    norm = dx * dx + dy * dy
    return 0.0 if norm == 0.0 else min(max(((x - a[0]) * dx + (y - a[1]) * dy) / norm, 0.0), 1.0)


def segment_exits(shape: Shape, origin: Sequence[float], ends: ArrayLike) -> FloatArray:
    """Where each segment from ``origin`` to a row of ``ends`` (an ``(N, 2)`` array) leaves ``shape`` for good, as a
    fraction of its length from 0 to 1 (1: it ends inside); ``nan`` where it never touches it (touching its
    boundary counts)."""
    pts = as_points(ends)
    if isinstance(shape, Circle):
        d = pts - origin
        f = np.asarray(origin, dtype=np.float64) - (shape.x, shape.y)
        a = np.einsum("ij,ij->i", d, d)
        b = 2.0 * (d @ f)
        c = float(f @ f) - shape.r * shape.r
        disc = b * b - 4.0 * a * c
        with np.errstate(divide="ignore", invalid="ignore"):
            root = np.sqrt(np.maximum(disc, 0.0))
            enter, leave = (-b - root) / (2.0 * a), (-b + root) / (2.0 * a)
        still = a == 0.0  # a segment of no length is inside or not, where it stands
        enter, leave = np.where(still, 0.0, enter), np.where(still, 1.0, leave)
        hits = np.where(still, c <= 0.0, (disc >= 0.0) & (leave >= 0.0) & (enter <= 1.0))
        return np.where(hits, np.clip(leave, 0.0, 1.0), np.nan)
    start = _to_local(shape, as_points(origin))[0]
    delta = _to_local(shape, pts) - start
    half = np.array([shape.hx, shape.hy])
    still = np.abs(delta) < 1e-12  # parallel to a side: inside that slab all along, or never
    with np.errstate(divide="ignore", invalid="ignore"):
        lo, hi = (-half - start) / delta, (half - start) / delta
    in_slab = np.abs(start) <= half
    near = np.where(still, np.where(in_slab, -np.inf, np.inf), np.minimum(lo, hi))
    far = np.where(still, np.where(in_slab, np.inf, -np.inf), np.maximum(lo, hi))
    enter = np.maximum(near.max(axis=1), 0.0)
    leave = np.minimum(far.min(axis=1), 1.0)
    return np.where(enter <= leave, leave, np.nan)


def polyline_distance(points: FloatArray, x: float, y: float) -> float:
    """Distance from ``(x, y)`` to the nearest point of the polyline through ``points`` (an ``(N, 2)`` array)."""
    return nearest_segment(points, x, y)[1]


def bounding_radius(shape: Shape) -> float:
    """Radius of the smallest circle about the shape's centre that contains it."""
    return shape.bound


def aabb(shape: Shape) -> tuple[float, float, float, float]:
    """Axis-aligned bounds ``(xmin, ymin, xmax, ymax)``."""
    if isinstance(shape, Circle):
        return (shape.x - shape.r, shape.y - shape.r, shape.x + shape.r, shape.y + shape.r)
    c, s = abs(math.cos(shape.theta)), abs(math.sin(shape.theta))
    ex, ey = shape.hx * c + shape.hy * s, shape.hx * s + shape.hy * c
    return (shape.x - ex, shape.y - ey, shape.x + ex, shape.y + ey)


def shapes_overlap(a: Shape, b: Shape, margin: float = 0.0) -> bool:
    """True when the shapes come closer than ``margin`` (exact for circles, conservative-exact for boxes)."""
    ax0, ay0, ax1, ay1 = aabb(a)
    bx0, by0, bx1, by1 = aabb(b)
    if ax0 - margin > bx1 or bx0 - margin > ax1 or ay0 - margin > by1 or by0 - margin > ay1:
        return False  # bounding boxes apart: cannot overlap
    if isinstance(a, Circle):
        return bool(signed_distance(b, (a.x, a.y))[0] < a.r + margin)
    if isinstance(b, Circle):
        return shapes_overlap(b, a, margin)
    # Box-box: distance between convex polygons is reached at a vertex of one against the other.
    da = signed_distance(b, corners(a)).min()
    db = signed_distance(a, corners(b)).min()
    if min(da, db) < margin:
        return True
    return _edges_cross(corners(a), corners(b))


def _edges_cross(pa: FloatArray, pb: FloatArray) -> bool:
    for i in range(4):
        p, r = pa[i], pa[(i + 1) % 4] - pa[i]
        for j in range(4):
            q, s = pb[j], pb[(j + 1) % 4] - pb[j]
            denom = r[0] * s[1] - r[1] * s[0]
            if abs(denom) < 1e-12:
                continue
            qp = q - p
            t = (qp[0] * s[1] - qp[1] * s[0]) / denom
            u = (qp[0] * r[1] - qp[1] * r[0]) / denom
            if 0.0 <= t <= 1.0 and 0.0 <= u <= 1.0:
                return True
    return False


def polyline_length(path: ArrayLike) -> float:
    """Total length of a polyline given as ``(N, 2)`` points."""
    pts = as_points(path)
    if len(pts) < 2:
        return 0.0
    return float(np.hypot(*np.diff(pts, axis=0).T).sum())


def resample_by_distance(path: ArrayLike, distances: ArrayLike) -> FloatArray:
    """Points at the given arc-length distances along a polyline (clamped to its ends)."""
    return Polyline.of(path).resampled(distances)


@dataclass(frozen=True)
class Polyline:
    """A path with its cumulative arc lengths, for many single-point look-ups along it."""

    points: FloatArray
    cumulative: FloatArray

    @classmethod
    def of(cls, path: ArrayLike) -> Polyline:
        """The polyline through ``path``'s points."""
        pts = as_points(path)
        seg = np.hypot(*np.diff(pts, axis=0).T) if len(pts) > 1 else np.zeros(0)
        return cls(pts, np.concatenate(([0.0], np.cumsum(seg))))

    @cached_property
    def length(self) -> float:
        """Total arc length."""
        return float(self.cumulative[-1])

    @cached_property
    def _plain(self) -> tuple[list[float], list[list[float]]]:
        """The cumulative lengths and the points as plain lists, for :meth:`point_at`'s scalar arithmetic."""
        return self.cumulative.tolist(), self.points.tolist()

    def point_at(self, distance: float) -> tuple[float, float]:
        """The point ``distance`` along the path (clamped to its ends), in plain floats."""
        cum, pts = self._plain
        if distance <= 0.0 or len(pts) == 1:
            return pts[0][0], pts[0][1]
        if distance >= cum[-1]:
            return pts[-1][0], pts[-1][1]
        k = bisect.bisect_right(cum, distance) - 1
        t = (distance - cum[k]) / (cum[k + 1] - cum[k])
        (ax, ay), (bx, by) = pts[k], pts[k + 1]
        return ax + t * (bx - ax), ay + t * (by - ay)

    def resampled(self, distances: ArrayLike) -> FloatArray:
        """Points at the given arc-length distances along the path (clamped to its ends)."""
        cum, pts = self.cumulative, self.points
        s = np.asarray(distances, dtype=np.float64)
        if len(pts) == 1:
            return np.repeat(pts, s.size, axis=0)
        s = np.clip(s, 0.0, cum[-1])
        return np.stack((np.interp(s, cum, pts[:, 0]), np.interp(s, cum, pts[:, 1])), axis=1)

    def arc_length_nearest(self, point: tuple[float, float]) -> float:
        """How far along the path its point nearest ``point`` lies (:func:`nearest_segment`)."""
        cum, pts = self._plain
        if len(pts) == 1:
            return 0.0
        k, _ = nearest_segment(self.points, *point)
        return cum[k] + segment_fraction(pts[k], pts[k + 1], *point) * (cum[k + 1] - cum[k])

    def remaining(self, distance: float, step: float) -> FloatArray:
        """Points every ``step`` metres from ``distance`` to the end (both ends included)."""
        n = max(2, int(math.ceil(max(self.length - distance, 0.0) / step)) + 1)
        return self.resampled(np.linspace(min(distance, self.length), self.length, n))


def swept_clearance(shape: Shape, path: ArrayLike, radius: float, step: float) -> tuple[float, FloatArray]:
    """Minimum clearance of a disc of ``radius`` swept along ``path``, sampled every ``step`` metres.

    Returns the clearance and the disc centre where it is reached.
    """
    pts = as_points(path)
    length = polyline_length(pts)
    n = max(2, int(math.ceil(length / step)) + 1)
    samples = resample_by_distance(pts, np.linspace(0.0, length, n))
    clear = signed_distance(shape, samples) - radius
    k = int(np.argmin(clear))
    return float(clear[k]), samples[k]
