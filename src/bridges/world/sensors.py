"""Noisy, late, occasionally missing detections of the ground-truth scene.

At ``rate_hz`` the sensor takes a frame of every non-wall object and every
person. Each detection gets Gaussian position noise (and heading noise for
people), is dropped with probability ``dropout``, and becomes available
``latency`` seconds after the instant it describes. Each object's size is
misjudged by a factor drawn once per object, uniform within +/- ``size_error``:
shape error is a bias the robot lives with, not noise that averages away. A
person who has fallen lies on the floor and is seen :data:`LYING_HEIGHT` high.
With ``occlusion: true`` the sensors ride on the robot, at its top, and detect only
what is in their line of sight (:mod:`bridges.world.line_of_sight`): a wall hides
whatever lies behind it, and furniture and people hide what is lower than the line
passing over them, so someone comes into W only as they step out from behind a
partition or a wardrobe, and a toy on the floor behind a bed only once the robot
sees over it. With ``enabled: false`` the detections are exact and immediate
(occlusion still applies).
"""

from __future__ import annotations

import math
from collections import deque
from dataclasses import dataclass, replace

import numpy as np

from agents.caregiving.model.geometry import Box, Circle, Shape
from agents.caregiving.model.scenario import SensorSpec
from agents.caregiving.model.scene import PERSON_KIND, Obstacle, Scene
from agents.caregiving.model.visibility import WALL_KIND

from .line_of_sight import in_view

#: Metres: how high a person who has fallen is seen (a body lying on the floor).
LYING_HEIGHT = 0.3


@dataclass(frozen=True)
class Detection:
    """One detected entity: ``stamp`` is the time it describes, ``shape`` its estimated footprint."""

    stamp: float
    name: str
    kind: str
    shape: Shape
    heading: float
    height: float
    target: bool


class Sensors:
    """A seeded sensor model fed with ground-truth scenes, read with :meth:`ready`."""

    def __init__(self, spec: SensorSpec, rng: np.random.Generator) -> None:
        self.spec = spec
        self._rng = rng
        self._scale: dict[str, float] = {}
        self._next_frame = 0.0
        self._queue: deque[tuple[float, Detection]] = deque()

    def observe(self, scene: Scene, fallen: frozenset[str] = frozenset()) -> None:
        """Take a frame if one is due at ``scene.time``; the people ``fallen`` names lie where they fell."""
        if scene.time + 1e-9 < self._next_frame:
            return
        self._next_frame += 1.0 / self.spec.rate_hz
        while self._next_frame <= scene.time:
            self._next_frame += 1.0 / self.spec.rate_hz
        release = scene.time + (self.spec.latency if self.spec.enabled else 0.0)
        for det in self._frame(scene, fallen):
            self._queue.append((release, det))

    def ready(self, now: float) -> list[Detection]:
        """Pop every detection available at time ``now``."""
        out = []
        while self._queue and self._queue[0][0] <= now + 1e-9:
            out.append(self._queue.popleft()[1])
        return out

    def _frame(self, scene: Scene, fallen: frozenset[str]) -> list[Detection]:
        dets = [
            Detection(scene.time, o.name, o.kind, o.shape, getattr(o.shape, "theta", 0.0), o.height, o.target)
            for o in scene.obstacles
            if o.kind != WALL_KIND
        ]
        dets += [
            Detection(
                scene.time,
                p.name,
                PERSON_KIND,
                Circle(p.x, p.y, p.radius),
                p.heading,
                LYING_HEIGHT if p.name in fallen else p.eye_height,
                False,
            )
            for p in scene.people
        ]
        if self.spec.occlusion and scene.robot is not None:
            robot = scene.robot
            seen = in_view((robot.x, robot.y, robot.height), _bodies(scene, fallen))
            dets = [d for d in dets if d.name in seen]
        if not self.spec.enabled:
            return dets
        return [self._noisy(d) for d in dets if self._rng.uniform() >= self.spec.dropout]

    def _noisy(self, d: Detection) -> Detection:
        dx, dy = self._rng.normal(0.0, self.spec.position_sigma, 2)
        s = d.shape
        if d.kind == PERSON_KIND:
            heading = d.heading + self._rng.normal(0.0, math.radians(self.spec.heading_sigma_deg))
            assert isinstance(s, Circle)  # people are always discs
            return Detection(d.stamp, d.name, d.kind, Circle(s.x + dx, s.y + dy, s.r), heading, d.height, d.target)
        scale = self._scale.setdefault(
            d.name, float(self._rng.uniform(1 - self.spec.size_error, 1 + self.spec.size_error))
        )
        shape: Shape
        if isinstance(s, Circle):
            shape = Circle(s.x + dx, s.y + dy, s.r * scale)
        else:
            shape = Box(s.x + dx, s.y + dy, s.hx * scale, s.hy * scale, s.theta)
        return Detection(d.stamp, d.name, d.kind, shape, d.heading, d.height * scale, d.target)


def _bodies(scene: Scene, fallen: frozenset[str]) -> list[Obstacle]:
    """Everything in the room but the robot, as the sensors' lines of sight meet it: the people ``fallen`` names
    lying on the floor."""
    people = [p.body() for p in scene.people]
    lying = [replace(b, height=LYING_HEIGHT) if b.name in fallen else b for b in people]
    return [*scene.obstacles, *lying]
