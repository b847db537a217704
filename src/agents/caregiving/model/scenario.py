"""Scenario files: the room, its objects, people, robot, sensors and trial randomisation.

A YAML file is validated into frozen dataclasses; anything wrong raises
:class:`ScenarioError` naming the key path. Poses are written ``[x, y, heading_deg]``
in metres and degrees, with the origin at the centre of the room.
:func:`sample_trial` draws one randomised trial from a seeded generator.
"""

from __future__ import annotations

import math
from dataclasses import dataclass, replace
from importlib import resources
from importlib.resources.abc import Traversable
from pathlib import Path

import numpy as np
import yaml

from .errors import ScenarioError
from .fields import Fields
from .geometry import Box, Circle, Shape, aabb, shapes_overlap
from .scene import Obstacle, PersonState, RobotState, Scene

OBJECT_KINDS = frozenset(
    {"ball", "backpack", "box", "bed", "cabinet", "chair", "couch", "door", "plant", "shoe", "table", "toy", "wall"}
)
#: The shipped scenarios, package data of :mod:`agents.caregiving`.
SHIPPED = resources.files("agents.caregiving").joinpath("scenarios")


def shipped_scenarios() -> list[str]:
    """The names of the shipped scenarios, sorted."""
    return sorted(f.name.removesuffix(".yaml") for f in SHIPPED.iterdir() if f.name.endswith(".yaml"))


#: Gap kept between sampled entities so nobody starts touching anything.
PLACEMENT_MARGIN = 0.15
_PLACE_ATTEMPTS = 200


@dataclass(frozen=True)
class WallSpec:
    """An interior wall segment of a given thickness."""

    start: tuple[float, float]
    end: tuple[float, float]
    thickness: float


@dataclass(frozen=True)
class RoomSpec:
    """A rectangular room centred at the origin, walled all round, plus interior walls."""

    width: float
    depth: float
    wall_height: float
    wall_thickness: float
    walls: tuple[WallSpec, ...]

    @property
    def bounds(self) -> tuple[float, float, float, float]:
        """The free interior ``(xmin, ymin, xmax, ymax)``."""
        return (-self.width / 2, -self.depth / 2, self.width / 2, self.depth / 2)

    def wall_obstacles(self) -> tuple[Obstacle, ...]:
        """The four boundary walls and every interior wall as box obstacles."""
        w, d, t, h = self.width / 2, self.depth / 2, self.wall_thickness, self.wall_height
        boxes = [
            Box(0.0, d + t / 2, w + t, t / 2),
            Box(0.0, -d - t / 2, w + t, t / 2),
            Box(w + t / 2, 0.0, t / 2, d + t),
            Box(-w - t / 2, 0.0, t / 2, d + t),
        ]
        for wall in self.walls:
            (x0, y0), (x1, y1) = wall.start, wall.end
            boxes.append(
                Box(
                    (x0 + x1) / 2,
                    (y0 + y1) / 2,
                    math.hypot(x1 - x0, y1 - y0) / 2,
                    wall.thickness / 2,
                    math.atan2(y1 - y0, x1 - x0),
                )
            )
        return tuple(Obstacle(f"wall{i}", "wall", b, h) for i, b in enumerate(boxes))


@dataclass(frozen=True)
class ObjectSpec:
    """A piece of furniture or clutter; ``radius`` for circles, ``length``/``width`` for boxes."""

    name: str
    kind: str
    shape: str
    radius: float
    length: float
    width: float
    height: float
    x: float
    y: float
    heading_deg: float
    target: bool

    def footprint(self) -> Shape:
        """The placed footprint."""
        if self.shape == "circle":
            return Circle(self.x, self.y, self.radius)
        return Box(self.x, self.y, self.length / 2, self.width / 2, math.radians(self.heading_deg))


@dataclass(frozen=True)
class PersonSpec:
    """A person: start pose, destination object, walk and view parameters (degrees)."""

    name: str
    x: float
    y: float
    heading_deg: float
    target: str
    speed: float
    radius: float
    eye_height: float
    hfov_deg: float
    vfov_deg: float
    gaze_range_deg: tuple[float, float]
    gaze_deg: float

    def footprint(self) -> Shape:
        """The body's footprint."""
        return Circle(self.x, self.y, self.radius)


@dataclass(frozen=True)
class RobotSpec:
    """The robot: start pose, box footprint, height and motion limits."""

    name: str
    x: float
    y: float
    heading_deg: float
    length: float
    width: float
    height: float
    max_speed: float
    max_accel: float

    def footprint(self) -> Shape:
        """The placed footprint."""
        return Box(self.x, self.y, self.length / 2, self.width / 2, math.radians(self.heading_deg))


@dataclass(frozen=True)
class SensorSpec:
    """Detection noise: rate, position sigma, size error fraction, drop-out rate, latency; and whether the sensors
    ride on the robot and see only what is in their line of sight (``occlusion``)."""

    enabled: bool
    rate_hz: float
    position_sigma: float
    heading_sigma_deg: float
    size_error: float
    dropout: float
    latency: float
    occlusion: bool = False


@dataclass(frozen=True)
class RandomisationSpec:
    """Which entities move between trials, and how far from their nominal pose."""

    entities: tuple[str, ...]
    radius: float
    heading_jitter_deg: float
    trials: int


@dataclass(frozen=True)
class Scenario:
    """A validated scenario."""

    name: str
    description: str
    room: RoomSpec
    objects: tuple[ObjectSpec, ...]
    people: tuple[PersonSpec, ...]
    robot: RobotSpec
    sensors: SensorSpec
    randomisation: RandomisationSpec

    def scene(self, time: float = 0.0) -> Scene:
        """The ground-truth scene at the scenario's poses."""
        objects = tuple(Obstacle(o.name, o.kind, o.footprint(), o.height, o.target) for o in self.objects)
        people = tuple(person_state(p) for p in self.people)
        r = self.robot
        robot = RobotState(
            r.name, r.x, r.y, math.radians(r.heading_deg), r.length, r.width, r.height, r.max_speed, r.max_accel
        )
        return Scene(self.room.bounds, self.room.wall_obstacles() + objects, people, robot, time)


def person_state(p: PersonSpec) -> PersonState:
    """A person spec as the scene's runtime state (radians)."""
    return PersonState(
        p.name,
        p.x,
        p.y,
        math.radians(p.heading_deg),
        p.speed,
        p.radius,
        p.eye_height,
        math.radians(p.hfov_deg),
        math.radians(p.vfov_deg),
        math.radians(p.gaze_range_deg[0]),
        math.radians(p.gaze_range_deg[1]),
        (p.x, p.y),
    )


def load_scenario(path: str | Path) -> Scenario:
    """Load and validate a scenario file; a bare name is looked up in the shipped ``scenarios/``."""
    p: Path | Traversable = Path(path)
    if not p.suffix and not p.exists():
        p = SHIPPED.joinpath(f"{p.name}.yaml")
    try:
        data = yaml.safe_load(p.read_text(encoding="utf-8"))
    except OSError as exc:
        raise ScenarioError(f"<file>: cannot read {p}: {exc.strerror}") from exc
    except yaml.YAMLError as exc:
        raise ScenarioError(f"<file>: {p} is not valid YAML: {exc}") from exc
    return parse_scenario(data)


def parse_scenario(data: object) -> Scenario:
    """Validate an already-parsed YAML document."""
    f = Fields(data, "", ScenarioError)
    f.reject_unknown(
        frozenset({"name", "description", "room", "objects", "people", "robot", "sensors", "randomisation"})
    )
    room = _room(f.child("room"))
    objects = tuple(_object(o) for o in f.children("objects"))
    people = tuple(_person(p) for p in f.children("people"))
    robot = _robot(f.child("robot"))
    scenario = Scenario(
        f.string("name"),
        str(f.string("description", "-")),
        room,
        objects,
        people,
        robot,
        _sensors(f.child("sensors")),
        _randomisation(f.child("randomisation")),
    )
    _cross_check(scenario, f)
    return scenario


def _pose(f: Fields) -> tuple[float, float, float]:
    x, y, heading = f.numbers("pose", 3)
    return x, y, heading


def _room(f: Fields) -> RoomSpec:
    f.reject_unknown(frozenset({"size", "wall_height", "wall_thickness", "walls"}))
    width, depth = f.numbers("size", 2)
    if width <= 0 or depth <= 0:
        raise f.fail("size", f"expected two positive numbers, got {[width, depth]}")
    walls = []
    for w in f.children("walls", []):
        w.reject_unknown(frozenset({"start", "end", "thickness"}))
        x0, y0 = w.numbers("start", 2)
        x1, y1 = w.numbers("end", 2)
        if (x0, y0) == (x1, y1):
            raise w.fail("end", "must differ from start")
        walls.append(WallSpec((x0, y0), (x1, y1), w.number("thickness", 0.1, positive=True)))
    return RoomSpec(
        width,
        depth,
        f.number("wall_height", 2.5, positive=True),
        f.number("wall_thickness", 0.1, positive=True),
        tuple(walls),
    )


def _object(f: Fields) -> ObjectSpec:
    f.reject_unknown(frozenset({"name", "kind", "shape", "height", "pose", "target"}))
    s = f.child("shape")
    shape = s.string("type", choices=frozenset({"circle", "box"}))
    if shape == "circle":
        s.reject_unknown(frozenset({"type", "radius"}))
        radius, length, width = s.number("radius", positive=True), 0.0, 0.0
    else:
        s.reject_unknown(frozenset({"type", "size"}))
        length, width = s.numbers("size", 2)
        if length <= 0 or width <= 0:
            raise s.fail("size", f"expected two positive numbers, got {[length, width]}")
        radius = 0.0
    x, y, heading = _pose(f)
    return ObjectSpec(
        f.string("name"),
        f.string("kind", choices=OBJECT_KINDS),
        shape,
        radius,
        length,
        width,
        f.number("height", positive=True),
        x,
        y,
        heading,
        f.boolean("target", False),
    )


def _person(f: Fields) -> PersonSpec:
    f.reject_unknown(
        frozenset(
            {
                "name",
                "pose",
                "target",
                "speed",
                "radius",
                "eye_height",
                "hfov_deg",
                "vfov_deg",
                "gaze_range_deg",
                "gaze_deg",
            }
        )
    )
    x, y, heading = _pose(f)
    lo, hi = f.numbers("gaze_range_deg", 2)
    if not -90.0 < lo < hi < 90.0:
        raise f.fail("gaze_range_deg", f"expected -90 < min < max < 90, got {[lo, hi]}")
    gaze = f.number("gaze_deg", (lo + hi) / 2)
    if not lo <= gaze <= hi:
        raise f.fail("gaze_deg", f"expected a value within gaze_range_deg {[lo, hi]}, got {gaze}")
    return PersonSpec(
        f.string("name"),
        x,
        y,
        heading,
        f.string("target"),
        f.number("speed", positive=True),
        f.number("radius", positive=True),
        f.number("eye_height", positive=True),
        f.number("hfov_deg", positive=True, at_most=360.0),
        f.number("vfov_deg", positive=True, at_most=180.0),
        (lo, hi),
        gaze,
    )


def _robot(f: Fields) -> RobotSpec:
    f.reject_unknown(frozenset({"name", "pose", "footprint", "height", "max_speed", "max_accel"}))
    x, y, heading = _pose(f)
    length, width = f.numbers("footprint", 2)
    if length <= 0 or width <= 0:
        raise f.fail("footprint", f"expected two positive numbers, got {[length, width]}")
    return RobotSpec(
        f.string("name", "robot"),
        x,
        y,
        heading,
        length,
        width,
        f.number("height", positive=True),
        f.number("max_speed", positive=True),
        f.number("max_accel", positive=True),
    )


def _sensors(f: Fields) -> SensorSpec:
    f.reject_unknown(
        frozenset(
            {
                "enabled",
                "rate_hz",
                "position_sigma",
                "heading_sigma_deg",
                "size_error",
                "dropout",
                "latency",
                "occlusion",
            }
        )
    )
    return SensorSpec(
        f.boolean("enabled", True),
        f.number("rate_hz", positive=True),
        f.number("position_sigma", non_negative=True),
        f.number("heading_sigma_deg", 0.0, non_negative=True),
        f.number("size_error", non_negative=True, at_most=0.9),
        f.number("dropout", non_negative=True, at_most=0.99),
        f.number("latency", non_negative=True),
        f.boolean("occlusion", False),
    )


def _randomisation(f: Fields) -> RandomisationSpec:
    f.reject_unknown(frozenset({"entities", "radius", "heading_jitter_deg", "trials"}))
    trials = f.number("trials", 1, positive=True)
    if trials != int(trials):
        raise f.fail("trials", f"expected a whole number, got {trials}")
    return RandomisationSpec(
        f.strings("entities", []),
        f.number("radius", 0.0, non_negative=True),
        f.number("heading_jitter_deg", 0.0, non_negative=True),
        int(trials),
    )


def _cross_check(s: Scenario, f: Fields) -> None:
    names: dict[str, str] = {}
    entries = [(f"objects[{i}].name", o.name) for i, o in enumerate(s.objects)]
    entries += [(f"people[{i}].name", p.name) for i, p in enumerate(s.people)]
    entries.append(("robot.name", s.robot.name))
    for path, name in entries:
        if name in names or name.startswith("wall"):
            raise ScenarioError(
                f"{path}: name {name!r} is already used"
                if name in names
                else f"{path}: names starting with 'wall' are reserved"
            )
        names[name] = path
    targets = {o.name for o in s.objects if o.target}
    for i, p in enumerate(s.people):
        if p.target not in targets:
            raise ScenarioError(f"people[{i}].target: {p.target!r} is not an object marked target: true")
    for i, e in enumerate(s.randomisation.entities):
        if e not in names:
            raise ScenarioError(f"randomisation.entities[{i}]: unknown entity {e!r}")
    for path, shape in _footprints(s):
        if not _inside(shape, s.room.bounds):
            raise ScenarioError(f"{path}.pose: footprint leaves the room {list(s.room.bounds)}")


def _footprints(s: Scenario) -> list[tuple[str, Shape]]:
    out: list[tuple[str, Shape]] = [(f"objects[{i}]", o.footprint()) for i, o in enumerate(s.objects)]
    out += [(f"people[{i}]", p.footprint()) for i, p in enumerate(s.people)]
    out.append(("robot", s.robot.footprint()))
    return out


def _inside(shape: Shape, bounds: tuple[float, float, float, float], margin: float = 0.0) -> bool:
    x0, y0, x1, y1 = aabb(shape)
    eps = 1e-9
    return (
        x0 >= bounds[0] + margin - eps
        and y0 >= bounds[1] + margin - eps
        and x1 <= bounds[2] - margin + eps
        and y1 <= bounds[3] - margin + eps
    )


def sample_trial(scenario: Scenario, rng: np.random.Generator) -> Scenario:
    """A copy of ``scenario`` with the randomised entities moved within the configured radius.

    Each entity is drawn uniformly in a disc around its nominal position (and its heading
    jittered), rejecting poses that leave the room or come within :data:`PLACEMENT_MARGIN`
    of another entity or an interior wall.
    """
    spec = scenario.randomisation
    current = scenario
    walls = scenario.room.wall_obstacles()[4:]
    for name in spec.entities:
        for _ in range(_PLACE_ATTEMPTS):
            radius = spec.radius * math.sqrt(rng.uniform())
            angle = rng.uniform(0.0, 2 * math.pi)
            jitter = rng.uniform(-spec.heading_jitter_deg, spec.heading_jitter_deg)
            candidate = _moved(current, name, radius * math.cos(angle), radius * math.sin(angle), jitter)
            if _placement_ok(candidate, name, walls):
                current = candidate
                break
        else:
            raise ScenarioError(f"randomisation.entities: could not place {name!r} after {_PLACE_ATTEMPTS} draws")
    return current


def _moved(s: Scenario, name: str, dx: float, dy: float, dheading: float) -> Scenario:
    nominal = _entity(s, name)
    x, y, h = nominal.x + dx, nominal.y + dy, nominal.heading_deg + dheading
    if isinstance(nominal, RobotSpec):
        return replace(s, robot=replace(nominal, x=x, y=y, heading_deg=h))
    if isinstance(nominal, PersonSpec):
        return replace(s, people=tuple(replace(p, x=x, y=y, heading_deg=h) if p.name == name else p for p in s.people))
    return replace(s, objects=tuple(replace(o, x=x, y=y, heading_deg=h) if o.name == name else o for o in s.objects))


def _entity(s: Scenario, name: str) -> ObjectSpec | PersonSpec | RobotSpec:
    for e in (*s.objects, *s.people, s.robot):
        if e.name == name:
            return e
    raise ScenarioError(f"randomisation.entities: unknown entity {name!r}")


def _placement_ok(s: Scenario, name: str, walls: tuple[Obstacle, ...]) -> bool:
    shapes = {e.name: e.footprint() for e in (*s.objects, *s.people, s.robot)}
    mine = shapes.pop(name)
    if not _inside(mine, s.room.bounds, PLACEMENT_MARGIN):
        return False
    others = list(shapes.values()) + [w.shape for w in walls]
    return not any(shapes_overlap(mine, other, PLACEMENT_MARGIN) for other in others)
