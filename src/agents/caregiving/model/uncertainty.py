"""How likely an imagined walk is to end in a collision, given what perception is unsure of.

Perception knows each position to within a Gaussian ``sigma`` and each object's
size only to within a bias of ``+/- size_error`` (the true size is the estimate
divided by a factor drawn uniformly in ``[1 - size_error, 1 + size_error]``).
:func:`collision_risk` draws ``samples`` worlds from that uncertainty and walks
the imagined path in each, vectorised with numpy:

* the person's start is displaced, the displacement fading linearly to nothing
  at the goal (the re-planned path still ends at the target);
* every obstacle the person does not see is displaced and resized; the ones
  they see are left alone, because the person plans around whatever size they
  really are. Walls and the robot (which knows where it is) are exact.

A sampled world may have the person touch something where they stand now (an
object sampled larger or closer than it is, beside them in a tight room). If
they walk away from it, that is no fall: their contact with it counts only from
when they come back to it after being clear. Walking into it, it counts at once.

The sampled worlds are shared between imagined walks: world ``k`` displaces each
person and resizes and displaces each obstacle by draws of its own, keyed by the
uncertainty's seed and the entity's name, so two walks of the same person (with
the robot idle and with a move, say) meet the same worlds and can be compared
world by world.

It returns the fraction of sampled worlds with a contact, which of them (a
bitmask), and the earliest contact among them (time, point, obstacle). Obstacles that no sampled world
(within five sigmas and the largest size) brings within reach of the walk are
skipped, which keeps the cost flat in cluttered rooms.
"""

from __future__ import annotations

import math
import zlib
from collections.abc import Callable, Mapping
from dataclasses import dataclass, field
from functools import lru_cache

import numpy as np

from .geometry import Box, Circle, bounding_radius, closest_boundary_point, polyline_length
from .imagine import Imagination
from .rollout import DT, contacts, trajectory
from .scene import ROBOT_KIND, Scene
from .visibility import WALL_KIND


@dataclass(frozen=True)
class Uncertainty:
    """Perception's uncertainty: a size bias bound, per-entity position sigmas, how many samples."""

    size_error: float = 0.0
    sigma: Mapping[str, float] = field(default_factory=dict)
    samples: int = 64
    seed: int = 0


@dataclass(frozen=True)
class Risk:
    """Collision probability over the sampled worlds and the earliest sampled contact; ``person``, whose
    imagined walk it is, where several people's walks were sampled (a joint imagination's risk); ``worlds``,
    which sampled worlds collide (bit ``k`` for world ``k``), kept where it was sampled and not on the wire."""

    probability: float
    time: float | None
    point: tuple[float, float] | None
    obstacle: str | None
    person: str | None = None
    worlds: int = field(default=0, compare=False)


NO_RISK = Risk(0.0, None, None, None)
#: Position errors beyond this many sigmas are not sampled in practice; obstacles farther off are skipped.
TAIL = 5.0


def collision_risk(scene: Scene, im: Imagination, u: Uncertainty, dt: float = DT) -> Risk:
    """Sample the uncertainty around the imagined walk ``im`` of a person in ``scene``."""
    if not im.reachable or len(im.path) < 2:
        return NO_RISK
    person = scene.person(im.person)
    seen = set(im.seen)
    unseen = [
        o for o in scene.bodies_around(im.person) if o.name != im.target and o.name not in seen and o.kind != WALL_KIND
    ]
    if not unseen:
        return NO_RISK
    n = max(int(u.samples), 1)
    times, points = trajectory(np.asarray(im.path), person.speed, dt)
    length = polyline_length(np.asarray(im.path))
    walked = times * person.speed
    fade = 1.0 - np.clip(walked / max(length, 1e-9), 0.0, 1.0)
    shift = _shift(u.seed, im.person, n, u.sigma.get(im.person, 0.0))
    walkers = points[None, :, :] + shift[:, None, :] * fade[None, :, None]  # (n, steps, 2)
    first = np.full(n, len(times))
    hit = np.full(n, -1)
    reach = _reach(points, person.radius + TAIL * u.sigma.get(im.person, 0.0))
    for j, o in enumerate(unseen):
        if reach(o.shape, TAIL * u.sigma.get(o.name, 0.0) + bounding_radius(o.shape) / (1 - u.size_error)):
            continue  # no sampled world brings this obstacle within reach of the walk
        exact = o.kind == ROBOT_KIND
        scale, offset = (
            (np.ones(n), np.zeros((n, 2)))
            if exact
            else _resized(u.seed, o.name, n, u.sigma.get(o.name, 0.0), u.size_error)
        )
        clear = _clearances(o.shape, walkers, offset, scale) - person.radius  # (n, steps)
        touching = contacts(clear)
        idx = np.where(touching.any(axis=1), touching.argmax(axis=1), len(times))
        better = idx < first
        first[better], hit[better] = idx[better], j
    colliding = first < len(times)
    if not colliding.any():
        return NO_RISK
    k = int(np.argmin(np.where(colliding, first, len(times) + 1)))
    step = int(first[k])
    obstacle = unseen[int(hit[k])]
    point = closest_boundary_point(obstacle.shape, walkers[k, step])[0]
    worlds = int.from_bytes(np.packbits(colliding, bitorder="little").tobytes(), "little")
    return Risk(
        float(colliding.mean()), float(times[step]), (float(point[0]), float(point[1])), obstacle.name, None, worlds
    )


def _draws(seed: int, name: str) -> np.random.Generator:
    """The random draws of entity ``name`` in the sampled worlds of ``seed``: the same for every walk imagined."""
    return np.random.default_rng((seed, zlib.crc32(name.encode())))


@lru_cache(maxsize=1024)
def _shift(seed: int, name: str, n: int, sigma: float) -> np.ndarray:
    """Person ``name``'s displacement in each of ``n`` worlds (read-only: one array serves every walk of theirs)."""
    shift = _draws(seed, name).normal(0.0, sigma, (n, 2))
    shift.flags.writeable = False
    return shift


@lru_cache(maxsize=1024)
def _resized(seed: int, name: str, n: int, sigma: float, size_error: float) -> tuple[np.ndarray, np.ndarray]:
    """Object ``name``'s scale and displacement in each of ``n`` worlds (read-only, as :func:`_shift`)."""
    rng = _draws(seed, name)
    scale = 1.0 / rng.uniform(1 - size_error, 1 + size_error, n)
    offset = rng.normal(0.0, sigma, (n, 2))
    scale.flags.writeable = offset.flags.writeable = False
    return scale, offset


def _reach(points: np.ndarray, radius: float) -> Callable[[Circle | Box, float], bool]:
    """A test ``far(shape, extent)``: is the shape's centre beyond ``extent + radius`` of every walked point?"""

    def far(shape: Circle | Box, extent: float) -> bool:
        gaps = np.hypot(points[:, 0] - shape.x, points[:, 1] - shape.y)
        return bool(gaps.min() > extent + radius)

    return far


def _clearances(shape: Circle | Box, walkers: np.ndarray, offset: np.ndarray, scale: np.ndarray) -> np.ndarray:
    """Signed distance from every sampled walker position to the sampled (moved, resized) shape, vectorised."""
    centre = np.array([shape.x, shape.y])[None, None, :] + offset[:, None, :]
    rel = walkers - centre  # (n, steps, 2)
    if isinstance(shape, Circle):
        return np.hypot(rel[..., 0], rel[..., 1]) - (shape.r * scale)[:, None]
    c, s = math.cos(shape.theta), math.sin(shape.theta)
    local = np.stack((rel[..., 0] * c + rel[..., 1] * s, -rel[..., 0] * s + rel[..., 1] * c), axis=2)
    half = np.stack((shape.hx * scale, shape.hy * scale), axis=1)[:, None, :]  # (n, 1, 2)
    q = np.abs(local) - half
    outside = np.hypot(np.maximum(q[..., 0], 0.0), np.maximum(q[..., 1], 0.0))
    inside = np.minimum(np.maximum(q[..., 0], q[..., 1]), 0.0)
    return outside + inside
