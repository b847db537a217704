"""Walk a disc along a path in the full scene and report its first collision.

The walker advances at constant speed with a 50 ms step. Two interchangeable
implementations of the :class:`Rollout` interface walk the same
:func:`trajectory` and expose the same ``(steps x obstacles)`` clearance matrix:

* :class:`BulletRollout` asks PyBullet (DIRECT, one persistent client per
  process) with ``getClosestPoints``; bodies are created once, pooled by shape and
  moved with ``resetBasePositionAndOrientation``; :meth:`BulletRollout.frozen`
  uses ``saveState``/``restoreState`` so imaginations never disturb the context.
* :class:`NumpyRollout` evaluates exact planar signed distances in one vectorised
  call per obstacle.

A contact is a step where the clearance (distance minus walker radius) is <= 0, but for a touch at the start
that the walker walks away from (:func:`contacts`): someone standing against the target they just reached
does not fall over it by setting off for another.
Past contact the two differ on purpose: PyBullet reports the 3D penetration depth
(a low box may be left over its top), numpy the planar one; walks stop at the
first contact, so their results agree.
"""

from __future__ import annotations

import math
from collections.abc import Iterator, Sequence
from contextlib import contextmanager
from dataclasses import dataclass
from typing import Protocol

import numpy as np
import pybullet as pb
from numpy.typing import ArrayLike

from .geometry import (
    Circle,
    FloatArray,
    aabb,
    as_points,
    closest_boundary_point,
    polyline_length,
    resample_by_distance,
    signed_distance,
)
from .scene import Obstacle

DT = 0.05
#: Height of the walker's cylinder in PyBullet (tall enough to meet anything on the floor).
WALKER_HEIGHT = 2.0
_FAR = 100.0


@dataclass(frozen=True)
class Contact:
    """Where and when the walker first touched an obstacle."""

    time: float
    point: tuple[float, float]
    obstacle: str


@dataclass(frozen=True)
class RolloutResult:
    """Outcome of one walk: first contact (if any), closest approach, time walked."""

    contact: Contact | None
    min_clearance: float
    closest: str
    duration: float
    steps: int

    @property
    def collided(self) -> bool:
        """Whether the walker touched anything."""
        return self.contact is not None


def trajectory(path: ArrayLike, speed: float, dt: float = DT) -> tuple[FloatArray, FloatArray]:
    """Times and positions of a walker moving along ``path`` at ``speed``, one per step, ending at the goal."""
    pts = as_points(path)
    length = polyline_length(pts)
    steps = int(math.ceil(length / (speed * dt) - 1e-9)) if length > 0 else 0
    times = np.arange(steps + 1) * dt
    times[-1] = length / speed if steps else 0.0
    return times, resample_by_distance(pts, times * speed)


def contacts(clear: np.ndarray) -> np.ndarray:
    """Where each walk (a row of clearances, one per step) touches, leaving out a touch at the start that it walks
    away from until the walk has come clear of it."""
    touching = clear <= 0.0
    if clear.shape[1] < 2:
        return touching
    leaving = touching[:, 0] & (clear[:, 1] >= clear[:, 0])
    if not leaving.any():
        return touching
    # From the first step clear of it on, a walk that started by leaving it touches it again.
    came_clear = np.cumsum(~touching[leaving], axis=1) > 0
    touching[leaving] &= came_clear
    return touching


class Rollout(Protocol):
    """Anything that can walk a disc along a path among obstacles."""

    def walk(
        self, path: ArrayLike, radius: float, speed: float, obstacles: Sequence[Obstacle], dt: float = DT
    ) -> RolloutResult:
        """Walk ``path`` and report the first contact with any of ``obstacles``."""
        ...


class NumpyRollout:
    """Exact planar geometry, vectorised over all steps."""

    def clearances(self, points: FloatArray, radius: float, obstacles: Sequence[Obstacle]) -> FloatArray:
        """``(steps, obstacles)`` clearances of a disc at each point."""
        return np.stack([signed_distance(o.shape, points) for o in obstacles], axis=1) - radius

    def walk(
        self, path: ArrayLike, radius: float, speed: float, obstacles: Sequence[Obstacle], dt: float = DT
    ) -> RolloutResult:
        """Walk ``path`` and report the first contact with any of ``obstacles``."""
        times, points = trajectory(path, speed, dt)
        if not obstacles:
            return RolloutResult(None, math.inf, "", float(times[-1]), len(times))
        clear = self.clearances(points, radius, obstacles)
        clear[(clear <= 0.0) & ~contacts(clear.T).T] = math.inf  # a touch walked away from is no contact, nor near
        touching = np.flatnonzero((clear <= 0.0).any(axis=1))
        last = int(touching[0]) if touching.size else len(times) - 1
        seen = clear[: last + 1]
        k, j = np.unravel_index(int(np.argmin(seen)), seen.shape)
        contact = None
        if touching.size:
            hit = obstacles[int(np.argmin(clear[last]))]
            p = closest_boundary_point(hit.shape, points[last])[0]
            contact = Contact(float(times[last]), (float(p[0]), float(p[1])), hit.name)
        return RolloutResult(contact, float(seen[k, j]), obstacles[j].name, float(times[last]), last + 1)


_Signature = tuple[str, float, float, float]


class BulletRollout:
    """PyBullet DIRECT rollout with one persistent client and pooled, moved bodies."""

    _shared: BulletRollout | None = None

    def __init__(self) -> None:
        self._client = pb.connect(pb.DIRECT)
        self._pool: dict[_Signature, list[int]] = {}
        self._placed: dict[str, tuple[_Signature, int, tuple[float, float, float]]] = {}
        self._walkers: dict[float, int] = {}
        self._frozen: tuple[int, dict[str, tuple[_Signature, int, tuple[float, float, float]]]] | None = None

    @classmethod
    def shared(cls) -> BulletRollout:
        """The process-wide instance (creating a client costs 15-25 ms, so there is one)."""
        if cls._shared is None:
            cls._shared = cls()
        return cls._shared

    # -- bodies --------------------------------------------------------------------------------
    def _create(self, sig: _Signature) -> int:
        kind, a, b, height = sig
        if kind == "cyl":
            shape = pb.createCollisionShape(pb.GEOM_CYLINDER, radius=a, height=height, physicsClientId=self._client)
        else:
            shape = pb.createCollisionShape(pb.GEOM_BOX, halfExtents=[a, b, height / 2], physicsClientId=self._client)
        self._frozen = None  # a saved state no longer matches the body set
        body = pb.createMultiBody(0, shape, basePosition=[0.0, 0.0, -_FAR], physicsClientId=self._client)
        # Bullet rounds box corners by the collision margin (4 cm by default); we want sharp geometry.
        pb.changeDynamics(body, -1, collisionMargin=0.0, physicsClientId=self._client)
        return body

    def _move(self, body: int, x: float, y: float, z: float, yaw: float) -> None:
        quat = (0.0, 0.0, math.sin(yaw / 2), math.cos(yaw / 2))
        pb.resetBasePositionAndOrientation(body, (x, y, z), quat, physicsClientId=self._client)

    def place(self, obstacles: Sequence[Obstacle]) -> list[int]:
        """Make the scene hold exactly ``obstacles``; returns their body ids in order."""
        wanted = {o.name for o in obstacles}
        for name in [n for n in self._placed if n not in wanted]:
            sig, body, _ = self._placed.pop(name)
            self._move(body, 0.0, 0.0, -_FAR, 0.0)
            self._pool.setdefault(sig, []).append(body)
        ids = []
        for o in obstacles:
            s = o.shape
            sig: _Signature = (
                ("cyl", round(s.r, 6), 0.0, round(o.height, 6))
                if isinstance(s, Circle)
                else ("box", round(s.hx, 6), round(s.hy, 6), round(o.height, 6))
            )
            pose = (s.x, s.y, 0.0 if isinstance(s, Circle) else s.theta)
            current = self._placed.get(o.name)
            if current is not None and current[0] != sig:
                self._pool.setdefault(current[0], []).append(current[1])
                current = None
            if current is not None:
                body = current[1]
            elif self._pool.get(sig):
                body = self._pool[sig].pop()
            else:
                body = self._create(sig)
            if current is None or current[2] != pose:
                self._move(body, pose[0], pose[1], o.height / 2, pose[2])
            self._placed[o.name] = (sig, body, pose)
            ids.append(body)
        return ids

    def _walker(self, radius: float) -> int:
        key = round(radius, 6)
        if key not in self._walkers:
            self._walkers[key] = self._create(("cyl", key, 0.0, WALKER_HEIGHT))
        return self._walkers[key]

    @contextmanager
    def frozen(self, obstacles: Sequence[Obstacle]) -> Iterator[None]:
        """Load a context and restore it (``restoreState``) however the body is used inside."""
        self.place(obstacles)
        if self._frozen is None or self._frozen[1] != self._placed:
            self._frozen = (pb.saveState(physicsClientId=self._client), dict(self._placed))
        state = self._frozen
        try:
            yield
        finally:
            if self._frozen is state:
                pb.restoreState(stateId=state[0], physicsClientId=self._client)
                self._placed = dict(state[1])
            else:  # bodies were created inside: the saved state no longer applies
                self.place(obstacles)

    # -- queries -------------------------------------------------------------------------------
    def clearances(self, points: FloatArray, radius: float, obstacles: Sequence[Obstacle]) -> FloatArray:
        """``(steps, obstacles)`` clearances from ``getClosestPoints`` with the walker at each point."""
        bodies = self.place(obstacles)
        walker = self._walker(radius)
        out = np.empty((len(points), len(bodies)))
        for k, (x, y) in enumerate(points):
            self._move(walker, float(x), float(y), WALKER_HEIGHT / 2, 0.0)
            for j, body in enumerate(bodies):
                hits = pb.getClosestPoints(walker, body, _FAR, physicsClientId=self._client)
                out[k, j] = min(h[8] for h in hits) if hits else math.inf
        self._move(walker, 0.0, 0.0, -_FAR, 0.0)
        return out

    def walk(
        self, path: ArrayLike, radius: float, speed: float, obstacles: Sequence[Obstacle], dt: float = DT
    ) -> RolloutResult:
        """Walk step by step and stop at the first contact.

        A broad phase on axis-aligned bounds skips pairs that cannot beat the best clearance so far;
        every remaining pair is measured by PyBullet.
        """
        times, points = trajectory(path, speed, dt)
        if not obstacles:
            return RolloutResult(None, math.inf, "", float(times[-1]), len(times))
        bodies = self.place(obstacles)
        walker = self._walker(radius)
        bound = _aabb_lower_bounds(points, obstacles) - radius
        leaving: set[int] = set()
        if (bound[0] <= 0.0).any():  # only a walk that may start touching something can walk away from it
            start = self.clearances(points[:2], radius, obstacles)
            leaving = set(np.flatnonzero((start[0] <= 0.0) & ~contacts(start.T)[:, 0]).tolist())
        best, closest, contact, k = math.inf, "", None, 0
        for k, (x, y) in enumerate(points):
            reach = best if math.isfinite(best) else _FAR
            near = np.flatnonzero(bound[k] < reach)
            if near.size == 0:
                continue
            self._move(walker, float(x), float(y), WALKER_HEIGHT / 2, 0.0)
            for j in near.tolist():
                body = bodies[j]
                hits = pb.getClosestPoints(walker, body, reach, physicsClientId=self._client)
                if not hits:
                    continue
                hit = min(hits, key=lambda h: h[8])
                if j in leaving:
                    if hit[8] <= 0.0:
                        continue
                    leaving.discard(j)
                if hit[8] < best:
                    best, closest = hit[8], obstacles[j].name
                    if best <= 0.0:
                        contact = Contact(float(times[k]), (float(hit[6][0]), float(hit[6][1])), closest)
            if contact is not None:
                break
        self._move(walker, 0.0, 0.0, -_FAR, 0.0)
        return RolloutResult(contact, best, closest, float(times[k]), k + 1)


def _aabb_lower_bounds(points: FloatArray, obstacles: Sequence[Obstacle]) -> FloatArray:
    """``(steps, obstacles)`` distances from each point to each obstacle's bounding box (never above the truth)."""
    boxes = np.array([aabb(o.shape) for o in obstacles])
    dx = np.maximum(np.maximum(boxes[None, :, 0] - points[:, None, 0], points[:, None, 0] - boxes[None, :, 2]), 0.0)
    dy = np.maximum(np.maximum(boxes[None, :, 1] - points[:, None, 1], points[:, None, 1] - boxes[None, :, 3]), 0.0)
    return np.hypot(dx, dy)
