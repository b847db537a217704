"""Perception's belief of a ground truth, drawn from a scenario's sensor model, for benches and tests.

What the tracker holds of the truth at a moment: each object's position off by the
sensor's sigma averaged over the frames seen so far (the tracker averages a static
object's detections) and its size, height included, off by a factor drawn within the
sensor's ``size_error`` (a bias no averaging removes, as the sensors draw it); each person's position off by half the
sensor's sigma (what a one-second line fit leaves), their heading by the sensor's
heading sigma, and where their walk began likewise. Walls are known exactly.
:class:`Noise` scales each part, so that the cost of each shows apart.
"""

from __future__ import annotations

import math
from dataclasses import dataclass, replace

import numpy as np

from agents.caregiving.model.geometry import Box, Circle
from agents.caregiving.model.scenario import SensorSpec
from agents.caregiving.model.scene import Scene
from agents.caregiving.model.uncertainty import Uncertainty
from agents.caregiving.model.visibility import WALL_KIND

SAMPLES = 64  # sampled worlds per imagined walk, as the action agent's default


@dataclass(frozen=True)
class Noise:
    """How much of the sensor model's noise to draw, and whether the search samples its uncertainty."""

    objects: float = 1.0  # times the tracker's sigma of an object's position
    size: float = 1.0  # times the size error bound
    people: float = 1.0  # times the tracker's sigmas of a person's position and heading
    sampled_risk: bool = True


def sigmas(sensors: SensorSpec, at: float) -> tuple[float, float]:
    """The tracker's position sigma at ``at`` s: of a static object (averaged frames), of a person (line fit)."""
    if not sensors.enabled:
        return 0.0, 0.0
    frames = max(sensors.rate_hz * at, 1.0)
    return sensors.position_sigma / math.sqrt(frames), sensors.position_sigma / 2


def size_error(sensors: SensorSpec) -> float:
    """The bound of the size bias the sensors draw per object."""
    return sensors.size_error if sensors.enabled else 0.0


def perception_uncertainty(scene: Scene, sensors: SensorSpec, at: float, seed: int) -> Uncertainty:
    """What the action agent samples round a belief of ``scene`` at ``at`` s: the tracker's sigmas, the size error."""
    object_sigma, person_sigma = sigmas(sensors, at)
    sigma = {o.name: object_sigma for o in scene.obstacles} | {p.name: person_sigma for p in scene.people}
    return Uncertainty(size_error(sensors), sigma, SAMPLES, seed=seed)


def belief(
    truth: Scene, sensors: SensorSpec, at: float, noise: Noise, rng: np.random.Generator, origins: np.random.Generator
) -> Scene:
    """One draw of what perception holds of ``truth`` at ``at`` s (walls are known exactly)."""
    object_sigma, person_sigma = sigmas(sensors, at)
    object_sigma, person_sigma = noise.objects * object_sigma, noise.people * person_sigma
    heading_sigma = noise.people * math.radians(sensors.heading_sigma_deg) if sensors.enabled else 0.0
    error = noise.size * size_error(sensors)
    obstacles = []
    for o in truth.obstacles:
        if o.kind == WALL_KIND:
            obstacles.append(o)
            continue
        dx, dy = rng.normal(0.0, object_sigma, 2)
        f = rng.uniform(1 - error, 1 + error)
        s = o.shape
        seen = (
            Circle(s.x + dx, s.y + dy, s.r * f)
            if isinstance(s, Circle)
            else Box(s.x + dx, s.y + dy, s.hx * f, s.hy * f, s.theta)
        )
        obstacles.append(replace(o, shape=seen, height=o.height * f))
    people = []
    for p in truth.people:
        dx, dy = rng.normal(0.0, person_sigma, 2)
        tracked = p.moved(p.x + dx, p.y + dy, p.heading + rng.normal(0.0, heading_sigma))
        if p.origin is not None:
            ox, oy = origins.normal(0.0, person_sigma, 2)
            tracked = replace(tracked, origin=(p.origin[0] + ox, p.origin[1] + oy))
        people.append(tracked)
    return replace(truth, obstacles=tuple(obstacles), people=tuple(people))


def search_uncertainty(scene: Scene, sensors: SensorSpec, at: float, seed: int, noise: Noise) -> Uncertainty:
    """What the search samples round a belief: :func:`perception_uncertainty`, or nothing when ``noise`` says the
    search samples no risk."""
    if not noise.sampled_risk:
        return Uncertainty(0.0, {}, 1)
    return perception_uncertainty(scene, sensors, at, seed)
