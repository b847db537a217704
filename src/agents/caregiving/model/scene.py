"""The frozen scene snapshot every computation works on, and its wire form.

A :class:`Scene` is what the robot believes (or, in the world model, what is
true) at one instant: room bounds, static obstacles (walls included), people and
the robot. It is immutable, so an imagination can never disturb the context it
was asked about. ``to_wire``/``from_wire`` give msgpack-friendly dicts.
"""

from __future__ import annotations

from dataclasses import dataclass, replace
from typing import Any

from .errors import RequestError
from .fields import Fields
from .geometry import Box, Circle, Shape

ROBOT_KIND = "robot"
PERSON_KIND = "person"


@dataclass(frozen=True)
class Obstacle:
    """A named footprint with a height; ``target`` marks a possible destination for people."""

    name: str
    kind: str
    shape: Shape
    height: float
    target: bool = False


@dataclass(frozen=True)
class PersonState:
    """A person's pose and the parameters of their body, walk and view (angles in radians).

    ``origin`` is where their walk began, where they planned the route they follow (``None``: unknown).
    """

    name: str
    x: float
    y: float
    heading: float
    speed: float
    radius: float
    eye_height: float
    hfov: float
    vfov: float
    gaze_min: float
    gaze_max: float
    origin: tuple[float, float] | None = None

    def moved(self, x: float, y: float, heading: float) -> PersonState:
        """The same person at another pose (spelled out: ``dataclasses.replace`` costs thrice as much per step)."""
        return PersonState(
            self.name,
            x,
            y,
            heading,
            self.speed,
            self.radius,
            self.eye_height,
            self.hfov,
            self.vfov,
            self.gaze_min,
            self.gaze_max,
            self.origin,
        )

    def body(self) -> Obstacle:
        """The person as an obstacle for others."""
        return Obstacle(self.name, PERSON_KIND, Circle(self.x, self.y, self.radius), self.eye_height + 0.1)


#: A planar pose: x, y (m) and heading (rad).
Pose = tuple[float, float, float]


@dataclass(frozen=True)
class RobotState:
    """The robot's pose, box footprint and motion limits."""

    name: str
    x: float
    y: float
    heading: float
    length: float
    width: float
    height: float
    max_speed: float
    max_accel: float
    speed: float = 0.0  # along ``heading``, which is its direction of travel while it drives
    route: tuple[tuple[float, float], ...] = ()  # the rest of the route it is driving, as its navigation reports

    def moved(self, x: float, y: float, heading: float) -> RobotState:
        """The same robot at another pose (its speed and route are the world's to report)."""
        return RobotState(
            self.name,
            x,
            y,
            heading,
            self.length,
            self.width,
            self.height,
            self.max_speed,
            self.max_accel,
            self.speed,
            self.route,
        )

    @property
    def pose(self) -> Pose:
        """Where it stands: x, y and heading."""
        return (self.x, self.y, self.heading)

    def body(self) -> Obstacle:
        """The robot's footprint as an obstacle."""
        return Obstacle(
            self.name, ROBOT_KIND, Box(self.x, self.y, self.length / 2, self.width / 2, self.heading), self.height
        )


@dataclass(frozen=True)
class Scene:
    """An immutable snapshot: room bounds ``(xmin, ymin, xmax, ymax)``, obstacles, people, robot."""

    bounds: tuple[float, float, float, float]
    obstacles: tuple[Obstacle, ...]
    people: tuple[PersonState, ...]
    robot: RobotState | None
    time: float = 0.0

    def obstacle(self, name: str) -> Obstacle:
        """The static obstacle called ``name``."""
        for obs in self.obstacles:
            if obs.name == name:
                return obs
        raise RequestError(f"unknown object {name!r}")

    def body(self, name: str) -> Obstacle:
        """What is called ``name`` as an obstacle: a static object, a person or the robot."""
        if self.robot is not None and self.robot.name == name:
            return self.robot.body()
        for person in self.people:
            if person.name == name:
                return person.body()
        return self.obstacle(name)

    def person(self, name: str) -> PersonState:
        """The person called ``name``."""
        for person in self.people:
            if person.name == name:
                return person
        raise RequestError(f"unknown person {name!r}")

    def bodies_around(self, person: str) -> tuple[Obstacle, ...]:
        """Everything ``person`` can bump into: static obstacles, the robot and the other people."""
        others = tuple(p.body() for p in self.people if p.name != person)
        robot = (self.robot.body(),) if self.robot is not None else ()
        return self.obstacles + robot + others

    @property
    def robot_name(self) -> str | None:
        """The robot's name, as falls into it are named; ``None`` when the scene has no robot."""
        return self.robot.name if self.robot is not None else None

    def with_robot(self, robot: RobotState | None) -> Scene:
        """The same scene with the robot replaced (or removed with ``None``)."""
        return replace(self, robot=robot)

    def to_wire(self) -> dict[str, Any]:
        """A msgpack-friendly dict."""
        return {
            "bounds": list(self.bounds),
            "time": self.time,
            "obstacles": [_obstacle_to_wire(o) for o in self.obstacles],
            "people": [dict(vars(p)) for p in self.people],
            "robot": dict(vars(self.robot)) if self.robot is not None else None,
        }

    @classmethod
    def from_wire(cls, data: object) -> Scene:
        """Rebuild a scene from :meth:`to_wire` output; raises :class:`RequestError` when malformed."""
        f = Fields(data, "scene", RequestError)
        bounds = f.numbers("bounds", 4)
        if bounds[2] <= bounds[0] or bounds[3] <= bounds[1]:
            raise f.fail("bounds", f"expected xmin < xmax and ymin < ymax, got {list(bounds)}")
        obstacles = tuple(_obstacle_from_wire(o) for o in f.children("obstacles"))
        people = tuple(_person_from_wire(p) for p in f.children("people"))
        robot_fields = f.optional_child("robot")
        robot = _robot_from_wire(robot_fields) if robot_fields is not None else None
        return cls((bounds[0], bounds[1], bounds[2], bounds[3]), obstacles, people, robot, f.number("time", 0.0))


def shape_to_wire(shape: Shape) -> dict[str, Any]:
    """A shape as a plain dict."""
    if isinstance(shape, Circle):
        return {"type": "circle", "x": shape.x, "y": shape.y, "r": shape.r}
    return {"type": "box", "x": shape.x, "y": shape.y, "hx": shape.hx, "hy": shape.hy, "theta": shape.theta}


def shape_from_wire(f: Fields) -> Shape:
    """Parse a shape dict produced by :func:`shape_to_wire`."""
    kind = f.string("type", choices=frozenset({"circle", "box"}))
    x, y = f.number("x"), f.number("y")
    if kind == "circle":
        return Circle(x, y, f.number("r", positive=True))
    return Box(x, y, f.number("hx", positive=True), f.number("hy", positive=True), f.number("theta", 0.0))


def _obstacle_to_wire(o: Obstacle) -> dict[str, Any]:
    return {"name": o.name, "kind": o.kind, "shape": shape_to_wire(o.shape), "height": o.height, "target": o.target}


def _obstacle_from_wire(f: Fields) -> Obstacle:
    return Obstacle(
        f.string("name"),
        f.string("kind"),
        shape_from_wire(f.child("shape")),
        f.number("height", positive=True),
        f.boolean("target", False),
    )


def _person_from_wire(f: Fields) -> PersonState:
    return PersonState(
        name=f.string("name"),
        x=f.number("x"),
        y=f.number("y"),
        heading=f.number("heading"),
        speed=f.number("speed", positive=True),
        radius=f.number("radius", positive=True),
        eye_height=f.number("eye_height", positive=True),
        hfov=f.number("hfov", positive=True),
        vfov=f.number("vfov", positive=True),
        gaze_min=f.number("gaze_min"),
        gaze_max=f.number("gaze_max"),
        origin=_point(f.numbers("origin", 2)) if f.has("origin") else None,
    )


def _point(xy: tuple[float, ...]) -> tuple[float, float]:
    return xy[0], xy[1]


def _robot_from_wire(f: Fields) -> RobotState:
    return RobotState(
        name=f.string("name"),
        x=f.number("x"),
        y=f.number("y"),
        heading=f.number("heading"),
        length=f.number("length", positive=True),
        width=f.number("width", positive=True),
        height=f.number("height", positive=True),
        max_speed=f.number("max_speed", positive=True),
        max_accel=f.number("max_accel", positive=True),
        speed=f.number("speed", 0.0, non_negative=True),
        route=f.pairs("route") if f.has("route") else (),
    )
