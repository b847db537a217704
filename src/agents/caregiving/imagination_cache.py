"""Incremental Algorithm 1: reuse an imagination until its inputs move beyond a tolerance.

An imagined walk of a person to a target under one gaze class depends on the
person's position, speed and tracked sigma, on what they see (the class's
visible set and the objects they remember, which is the cache key together
with person, target and where they remember the robot), and on the bodies
near the walk. A cached answer is reused while

* the person is still on the imagined walk: within ``move_tol`` of its path,
  with the same speed, radius and sigma (to ``size_tol``). The answer then
  carries ``advance``, the seconds of the walk already behind them (arc length
  to their nearest point on the path over their speed), which its times are
  brought forward by, and its path starts where they are now; a person
  standing at the start has advanced by nothing;
* every body within ``reach`` of the imagined path, before or now (and the
  target wherever it is), moved less than ``move_tol`` and kept its size,
  orientation and sigma to ``size_tol``, and none appeared or vanished there;
* it is younger than ``max_age`` simulated seconds;
* the person has not walked as far as where it (or any sampled world of it) first touched something: they did
  not fall there, so it no longer tells what lies ahead of them.

A clear walk that passes something closer than ``move_tol`` is decided by less than that: for it, the
person and the bodies near the walk may move only as far as its closest approach before it is imagined
again. Reused at the full tolerance, a walk imagined clear by a few millimetres on an early belief stays
clear while the belief of the person, now nearer, has them touching (a walk that collides is risky
already, and keeps the full tolerance).

An answer stored as *aside* (a walk the person is plainly not taking: its path
sets off far from where they head) is kept instead while the person stays
within ``aside_tol`` of where it was imagined and turns less than ``turn_tol``.

A body that stays farther than ``reach`` from the path neither touches the walk
nor shapes its plan. Entries not looked up in an evaluation are dropped, so a
changed visible set (a new key) also forgets the old answer.
"""

from __future__ import annotations

import math
from collections.abc import Sequence
from dataclasses import dataclass, replace

import numpy as np

from agents.caregiving.model.geometry import (
    Circle,
    Shape,
    bounding_radius,
    polyline_length,
    resample_by_distance,
)
from agents.caregiving.model.imagine_reply import Answer
from agents.caregiving.model.scene import Pose, Scene
from agents.caregiving.model.visibility import WALL_KIND, wrap_angle

Key = tuple[str, str, frozenset[str], Pose | None]
STEP = 0.05  # metres between the path points bodies and the person are measured against


@dataclass(frozen=True)
class Body:
    """A body's position, its other shape parameters (sizes, yaw), extent and tracked sigma."""

    x: float
    y: float
    params: tuple[float, ...]
    extent: float
    sigma: float


@dataclass(frozen=True)
class Footing:
    """The inputs of one person's imaginations at one moment (``person.params`` is speed and radius)."""

    time: float
    heading: float
    person: Body
    bodies: dict[str, Body]


@dataclass
class _Entry:
    footing: Footing
    path: np.ndarray  # dense points, STEP apart
    answer: Answer
    aside: bool


def body_of(shape: Shape, sigma: float) -> Body:
    """The :class:`Body` of a footprint."""
    params = (shape.r,) if isinstance(shape, Circle) else (shape.hx, shape.hy, shape.theta)
    return Body(shape.x, shape.y, params, bounding_radius(shape), sigma)


def footing(scene: Scene, person: str, sigma: dict[str, float]) -> Footing:
    """What ``person``'s imaginations in ``scene`` depend on."""
    p = scene.person(person)
    me = Body(p.x, p.y, (p.speed, p.radius), p.radius, sigma.get(person, 0.0))
    bodies = {
        o.name: body_of(o.shape, sigma.get(o.name, 0.0)) for o in scene.bodies_around(person) if o.kind != WALL_KIND
    }
    return Footing(scene.time, p.heading, me, bodies)


def remaining(path: Sequence[Sequence[float]], walked: float) -> list[list[float]]:
    """The polyline ``path`` from arc length ``walked`` on."""
    pts = np.asarray(path, dtype=float)
    cum = np.concatenate(([0.0], np.cumsum(np.hypot(*np.diff(pts, axis=0).T))))
    start = resample_by_distance(pts, [walked])[0]
    return [start.tolist(), *pts[cum > walked].tolist()] if cum[-1] > walked else [pts[-1].tolist()] * 2


def _walked_past_contact(answer: Answer, advance: float) -> bool:
    """Whether the person has walked as far as where the imagined walk (nominal or a sampled world) first touched
    something: they did not fall there, so the answer no longer tells what lies ahead of them (reused, its times
    brought forward by the advance, its contact would be reported as happening now)."""
    im, risk = answer.imagination, answer.risk
    times = (im.collision_time if im is not None else None, risk.time if risk is not None else None)
    return any(t is not None and t <= advance for t in times) and advance > 0.0


class ImaginationCache:
    """Answers of the simulator, reused while their inputs stay within tolerance (see the module docs)."""

    def __init__(
        self,
        move_tol: float = 0.1,
        size_tol: float = 0.02,
        reach: float = 0.6,
        max_age: float = 3.0,
        aside_tol: float = 0.5,
        turn_tol: float = math.radians(15),
    ) -> None:
        self.move_tol, self.size_tol, self.reach, self.max_age = move_tol, size_tol, reach, max_age
        self.aside_tol, self.turn_tol = aside_tol, turn_tol
        self._entries: dict[Key, _Entry] = {}
        self._used: set[Key] = set()
        self.hits = 0
        self.misses = 0

    def lookup(self, key: Key, now: Footing) -> tuple[Answer, float] | None:
        """The cached answer for ``key`` and its ``advance`` (s), or None when it must be imagined."""
        self._used.add(key)
        e = self._entries.get(key)
        tol = self.move_tol if e is None else self._tolerance(e.answer)
        advance = None if e is None else self._advance(e, now, tol)
        if (
            e is None
            or advance is None
            or not 0.0 <= now.time - e.footing.time <= self.max_age
            or self._differs(e.footing.person, now.person, math.inf)
            or self._bodies_changed(e, now, key[1], tol)
            or _walked_past_contact(e.answer, advance)
        ):
            self.misses += 1
            return None
        self.hits += 1
        im = e.answer.imagination
        if not advance or im is None:
            return e.answer, advance
        rest = remaining(im.path, advance * now.person.params[0])
        return replace(e.answer, imagination=replace(im, path=tuple((x, y) for x, y in rest))), advance

    def store(self, key: Key, at: Footing, answer: Answer, aside: bool = False) -> None:
        """Remember the simulator's ``answer`` for ``key`` imagined on ``at``; see the module docs for ``aside``."""
        path = answer.imagination.path if answer.imagination is not None else ()
        pts = np.asarray(path if path else [(at.person.x, at.person.y)], dtype=float).reshape(-1, 2)
        dense = resample_by_distance(pts, np.append(np.arange(0.0, polyline_length(pts), STEP), np.inf))
        self._entries[key] = _Entry(at, dense, answer, aside)

    def sweep(self) -> None:
        """Forget the entries not looked up since the last sweep."""
        self._entries = {k: v for k, v in self._entries.items() if k in self._used}
        self._used = set()

    def clear(self) -> None:
        """Forget everything (a new trial)."""
        self._entries.clear()
        self._used.clear()

    def _tolerance(self, answer: Answer) -> float:
        """How far the person and the bodies near the walk may move: ``move_tol``, or a clear walk's closest approach."""
        im = answer.imagination
        if im is None or im.collided:
            return self.move_tol
        return min(self.move_tol, max(im.min_clearance, 0.0))

    def _advance(self, e: _Entry, now: Footing, tol: float) -> float | None:
        """Seconds of the imagined walk behind the person, or None when they left it (by more than ``tol``)."""
        was, me = e.footing, now.person
        if e.aside:
            turned = abs(wrap_angle(now.heading - was.heading))
            moved = math.hypot(me.x - was.person.x, me.y - was.person.y)
            return 0.0 if moved <= self.aside_tol and turned <= self.turn_tol else None
        gaps = np.hypot(e.path[:, 0] - me.x, e.path[:, 1] - me.y)
        k = int(np.argmin(gaps))
        return k * STEP / max(me.params[0], 1e-3) if gaps[k] <= tol else None

    def _differs(self, a: Body, b: Body, move_tol: float) -> bool:
        return (
            math.hypot(a.x - b.x, a.y - b.y) > move_tol
            or len(a.params) != len(b.params)
            or any(abs(u - v) > self.size_tol for u, v in zip(a.params, b.params, strict=True))
            or abs(a.sigma - b.sigma) > self.size_tol
        )

    def _near(self, path: np.ndarray, body: Body | None) -> bool:
        if body is None:
            return False
        gap = float(np.min(np.hypot(path[:, 0] - body.x, path[:, 1] - body.y))) - body.extent
        return gap <= self.reach

    def _bodies_changed(self, e: _Entry, now: Footing, target: str, tol: float) -> bool:
        for name in e.footing.bodies.keys() | now.bodies.keys():
            old, new = e.footing.bodies.get(name), now.bodies.get(name)
            if old == new or not (name == target or self._near(e.path, old) or self._near(e.path, new)):
                continue
            if old is None or new is None or self._differs(old, new, tol):
                return True
        return False
