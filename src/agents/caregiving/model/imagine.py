"""Algorithm 1's imagination as a pure function of a frozen scene: one person's walk to a target.

:func:`imagine_person`: the person plans a path to the target with only what
they see at the given gaze (plus what they are known to remember), then walks it
in the full scene. A person still on the route planned where their walk began
(``PersonState.origin``) walks the rest of that route
(:meth:`GridPlanner.plan_walk`). The result is a plain dataclass with
``to_wire``/``from_wire`` (msgpack-friendly dicts); malformed input raises
:class:`RequestError`. The robot's moves are imagined in time by
:mod:`agents.caregiving.model.joint`.
"""

from __future__ import annotations

import math
from collections.abc import Iterable
from dataclasses import dataclass
from typing import Any

from .errors import RequestError
from .fields import Fields
from .planner import GridPlanner
from .rollout import NumpyRollout, Rollout
from .scene import Scene
from .visibility import can_see

_PLANNERS: dict[tuple[float, float, float, float], GridPlanner] = {}
_NUMPY = NumpyRollout()


def planner_for(bounds: tuple[float, float, float, float]) -> GridPlanner:
    """The process-wide planner (and mask cache) for a room."""
    planner = _PLANNERS.get(bounds)
    if planner is None:
        planner = _PLANNERS[bounds] = GridPlanner(bounds)
    return planner


@dataclass(frozen=True)
class Imagination:
    """What the imagined walk of ``person`` to ``target`` at gaze ``gaze`` (rad) gives."""

    person: str
    target: str
    gaze: float
    seen: tuple[str, ...]
    reachable: bool
    path: tuple[tuple[float, float], ...]
    collided: bool
    collision_time: float | None
    collision_point: tuple[float, float] | None
    collision_object: str | None
    min_clearance: float
    duration: float

    def to_wire(self) -> dict[str, Any]:
        """A msgpack-friendly dict."""
        return {
            "person": self.person,
            "target": self.target,
            "gaze": self.gaze,
            "seen": list(self.seen),
            "reachable": self.reachable,
            "path": [list(p) for p in self.path],
            "collided": self.collided,
            "collision_time": self.collision_time,
            "collision_point": list(self.collision_point) if self.collision_point is not None else None,
            "collision_object": self.collision_object,
            "min_clearance": self.min_clearance if math.isfinite(self.min_clearance) else None,
            "duration": self.duration,
        }

    @classmethod
    def from_wire(cls, data: object) -> Imagination:
        """Parse :meth:`to_wire` output."""
        return cls.from_fields(Fields(data, "imagination", RequestError))

    @classmethod
    def from_fields(cls, f: Fields) -> Imagination:
        """Parse an imagination nested in a larger message."""
        collided = f.boolean("collided")
        point = f.numbers("collision_point", 2) if collided else None
        clearance = f.optional_number("min_clearance")
        return cls(
            person=f.string("person"),
            target=f.string("target"),
            gaze=f.number("gaze"),
            seen=f.strings("seen"),
            reachable=f.boolean("reachable"),
            path=f.pairs("path"),
            collided=collided,
            collision_time=f.number("collision_time") if collided else None,
            collision_point=(point[0], point[1]) if point is not None else None,
            collision_object=f.string("collision_object") if collided else None,
            min_clearance=math.inf if clearance is None else clearance,
            duration=f.number("duration", non_negative=True),
        )


def imagine_person(
    scene: Scene,
    person: str,
    target: str,
    gaze: float,
    rollout: Rollout | None = None,
    planner: GridPlanner | None = None,
    known: Iterable[str] = (),
) -> Imagination:
    """Plan with only what ``person`` sees at ``gaze`` (and the objects ``known`` to them), then walk the plan
    (the rest of the route planned where their walk began, while they are on it).

    ``known`` names objects the person is sure to have seen before (out of view now, still remembered).
    """
    if isinstance(gaze, bool) or not isinstance(gaze, (int, float)) or not -math.pi / 2 <= gaze <= math.pi / 2:
        raise RequestError(f"gaze: expected a pitch in [-pi/2, pi/2] rad, got {gaze!r}")
    p = scene.person(person)
    goal = scene.obstacle(target)
    around = scene.bodies_around(person)
    remembered = set(known)
    seen = tuple(o for o in around if o.name in remembered or can_see(p, o, gaze))
    plan = (planner or planner_for(scene.bounds)).plan_walk((p.x, p.y), p.origin, goal, seen, p.radius)
    names = tuple(o.name for o in seen)
    if not plan.reachable:
        return Imagination(person, target, gaze, names, False, (), False, None, None, None, math.inf, 0.0)
    walk = (rollout or _NUMPY).walk(plan.path, p.radius, p.speed, [o for o in around if o.name != target])
    c = walk.contact
    return Imagination(
        person,
        target,
        float(gaze),
        names,
        True,
        tuple((float(x), float(y)) for x, y in plan.path),
        c is not None,
        c.time if c else None,
        c.point if c else None,
        c.obstacle if c else None,
        walk.min_clearance,
        walk.duration,
    )
