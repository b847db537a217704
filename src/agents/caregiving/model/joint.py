"""The joint imagination in time (Algorithm 2): the robot drives its move while the people walk.

It steps :class:`agents.caregiving.model.world_model.World`, the same model the world bridge
uses for the truth, from a believed scene and guessed intents:

* the robot goes on with its ``current`` move (if any), along the route it
  reports, for ``delay`` seconds, the time the pipeline needs to send a command;
  then, given a ``lead`` (the head start a search sends while it judges on), it
  drives that for ``lead_for`` seconds; then it drives to the new move's pose
  along a fresh plan (or, when the new move is the one it drives, on along the
  same route), under its speed and acceleration limits and from the speed it has;
* each person walks to their guessed target at their gaze class, sees the robot
  when it enters their field of view, and re-plans around it as it is then.

So a move that arrives late, that intercepts the person on their way, or that
puts the robot in their way is judged by what would happen, not by where the
robot stands at the end. ``move=None`` imagines the robot braking to a stop.
"""

from __future__ import annotations

import math
from collections.abc import Collection, Mapping, Sequence
from dataclasses import dataclass, replace
from typing import Any

from .errors import RequestError
from .fields import Fields
from .imagine import Imagination, planner_for
from .planner import GridPlanner
from .robot_moves import RobotMove
from .rollout import DT
from .scene import Pose, Scene
from .uncertainty import NO_RISK, Risk, Uncertainty, collision_risk
from .world_model import Passing, Walk, World, fell

#: Seconds imagined at most: long enough for a walk across any room these scenarios hold.
HORIZON = 30.0


@dataclass(frozen=True)
class WalkOutcome:
    """How one person's imagined walk ends. Times are seconds from the imagined scene's time."""

    walk: Walk
    status: str  # arrived | collided | stuck | walking (the horizon ran out)
    track: tuple[tuple[float, float], ...]
    seen: tuple[str, ...]
    collision_time: float | None
    collision_point: tuple[float, float] | None
    collision_object: str | None
    min_clearance: float
    saw_robot_at: float | None
    # Closest approach to the robot while it drives, or stands where the person does not know it to be.
    robot_clearance: float = math.inf
    # Imagined passing what they were believed to walk into: how close they came to it (negative: through it),
    # and its bounding radius.
    passed_clearance: float | None = None
    passed_size: float | None = None

    @property
    def collided(self) -> bool:
        """Whether the person touched anything but their target."""
        return self.status == "collided"

    def fine_given(self, falling: Mapping[str, str]) -> bool:
        """Whether the walk ends well, or in the very fall ``falling`` says this person was heading for anyway."""
        return not fell(self.status, self.walk.person, self.collision_object, falling)

    def as_imagination(self) -> Imagination:
        """The walk as walked (one point per step), for sampling perception's uncertainty around it."""
        w = self.walk
        return Imagination(
            w.person,
            w.target,
            w.gaze,
            self.seen,
            self.status != "stuck",
            self.track,
            self.collided,
            self.collision_time,
            self.collision_point,
            self.collision_object,
            self.min_clearance,
            max(len(self.track) - 1, 0) * DT,
        )

    def to_wire(self) -> dict[str, Any]:
        """A msgpack-friendly dict."""
        return {
            **walk_to_wire(self.walk),
            "status": self.status,
            "track": [list(p) for p in self.track],
            "seen": list(self.seen),
            "collision_time": self.collision_time,
            "collision_point": list(self.collision_point) if self.collision_point else None,
            "collision_object": self.collision_object,
            "min_clearance": self.min_clearance if math.isfinite(self.min_clearance) else None,
            "saw_robot_at": self.saw_robot_at,
            "robot_clearance": self.robot_clearance if math.isfinite(self.robot_clearance) else None,
            "passed_clearance": self.passed_clearance,
            "passed_size": self.passed_size,
        }

    @classmethod
    def from_fields(cls, f: Fields) -> WalkOutcome:
        """Parse :meth:`to_wire` output nested in a larger message."""
        status = f.string("status", choices=frozenset({"arrived", "collided", "stuck", "walking"}))
        collided = status == "collided"
        point = f.numbers("collision_point", 2) if collided else None
        clearance = f.optional_number("min_clearance")
        robot_clearance = f.optional_number("robot_clearance")
        return cls(
            walk_from_fields(f),
            status,
            f.pairs("track"),
            f.strings("seen"),
            f.number("collision_time") if collided else None,
            (point[0], point[1]) if point else None,
            f.string("collision_object") if collided else None,
            math.inf if clearance is None else clearance,
            f.optional_number("saw_robot_at"),
            math.inf if robot_clearance is None else robot_clearance,
            f.optional_number("passed_clearance"),
            f.optional_number("passed_size"),
        )


@dataclass(frozen=True)
class JointImagination:
    """A robot move imagined in time together with the walks of the people it concerns."""

    move: RobotMove | None
    robot_reachable: bool
    robot_arrival: float | None  # seconds from now until it rests at the pose, None if not within the horizon
    walks: tuple[WalkOutcome, ...]

    @property
    def safe(self) -> bool:
        """Whether the robot can drive the move and nobody imagined touches anything or gets stuck."""
        return self.safe_given({})

    def safe_given(self, falling: Mapping[str, str]) -> bool:
        """:attr:`safe`, but for the falls ``falling`` names (``{person: object}``), which happen anyway."""
        return self.robot_reachable and all(w.fine_given(falling) for w in self.walks)

    def stopped_at_first_fall(self, falling: Mapping[str, str]) -> JointImagination | None:
        """What this imagination says had it stopped at the first fall ``falling`` does not name, as one imagined
        ``until_first_fall`` with ``falling`` does, when it went on past such falls (that it let happen).

        The falls of that step stand; a later one is taken back (that person is still walking), and so is a
        robot arrival after that step. The walks that end well are left as they ended (arrived, say, where the
        stopped imagination has them still walking), and tracks and clearances as walked: what a verdict reads
        of a walk is whether it ends well and, if not, who fell, into what and where. None when it cannot be
        told: someone got stuck, and a walk does not keep when.
        """
        falls = [w for w in self.walks if not w.fine_given(falling)]
        if not falls:
            return self
        times = [w.collision_time for w in falls]
        if any(t is None for t in times):
            return None
        first = min(t for t in times if t is not None) + 1e-9
        walks = tuple(
            replace(w, status="walking", collision_time=None, collision_point=None, collision_object=None)
            if w in falls and w.collision_time is not None and w.collision_time > first
            else w
            for w in self.walks
        )
        arrival = self.robot_arrival if self.robot_arrival is not None and self.robot_arrival <= first else None
        return replace(self, robot_arrival=arrival, walks=walks)

    def to_wire(self) -> dict[str, Any]:
        """A msgpack-friendly dict."""
        return {
            "move": self.move.to_wire() if self.move else None,
            "robot_reachable": self.robot_reachable,
            "robot_arrival": self.robot_arrival,
            "walks": [w.to_wire() for w in self.walks],
        }

    @classmethod
    def from_wire(cls, data: object) -> JointImagination:
        """Parse :meth:`to_wire` output; raises :class:`RequestError` when malformed."""
        return cls.from_fields(Fields(data, "joint", RequestError))

    @classmethod
    def from_fields(cls, f: Fields) -> JointImagination:
        """Parse a joint imagination nested in a larger message."""
        return cls(
            RobotMove.optional_from(f, "move"),
            f.boolean("robot_reachable"),
            f.optional_number("robot_arrival"),
            tuple(WalkOutcome.from_fields(w) for w in f.children("walks")),
        )


def walk_risks(scene: Scene, joint: JointImagination, u: Uncertainty, falling: Collection[str] = ()) -> dict[str, Risk]:
    """Each person's sampled risk round their walk as walked, leaving out the people ``falling`` anyway.

    The robot is left out of the sampled worlds, since it knows where it is and the nominal imagination
    already checks every step against it.
    """
    without_robot = scene.with_robot(None)
    return {
        w.walk.person: replace(collision_risk(without_robot, w.as_imagination(), u), person=w.walk.person)
        for w in joint.walks
        if w.walk.person not in falling
    }


def raised_risks(risks: Mapping[str, Risk], anyway: Mapping[str, float] | None = None) -> list[Risk]:
    """The walks' ``risks`` (``{person: risk}``, as :func:`walk_risks` gives them) that the robot brings: all but
    those no higher than ``anyway``, the bystanders' sampled risks with the robot as it is
    (``{person: probability}``)."""
    anyway = anyway or {}
    return [r for person, r in risks.items() if person not in anyway or r.probability > anyway[person]]


def worst_risk(risks: Mapping[str, Risk], anyway: Mapping[str, float] | None = None) -> Risk:
    """The likeliest collision over the sampled worlds among the :func:`raised_risks`; it names whose walk it is."""
    return max(raised_risks(risks, anyway), key=lambda r: r.probability, default=NO_RISK)


def walk_from_fields(f: Fields) -> Walk:
    """A guessed intent from a wire dict ``{person, target | toward: [x, y], gaze, known?, robot_at?: [x, y,
    heading]}``."""
    gaze = f.number("gaze")
    if not -math.pi / 2 <= gaze <= math.pi / 2:
        raise f.fail("gaze", f"expected a pitch in [-pi/2, pi/2] rad, got {gaze!r}")
    toward = f.numbers("toward", 2) if f.has("toward") else None
    return Walk(
        f.string("person"),
        "" if toward is not None else f.string("target"),
        gaze,
        f.strings("known", ()),
        optional_pose(f, "robot_at"),
        (toward[0], toward[1]) if toward is not None else None,
    )


def optional_pose(f: Fields, key: str) -> Pose | None:
    """An ``[x, y, heading]``, or ``None`` when absent or null."""
    if not f.has(key):
        return None
    x, y, heading = f.numbers(key, 3)
    return (x, y, heading)


def walk_to_wire(w: Walk) -> dict[str, Any]:
    """The wire form :func:`walk_from_fields` reads."""
    out: dict[str, Any] = {"person": w.person, "gaze": w.gaze, "known": list(w.known)}
    if w.toward is not None:
        out["toward"] = list(w.toward)
    else:
        out["target"] = w.target
    if w.robot_at is not None:
        out["robot_at"] = list(w.robot_at)
    return out


def imagine_joint(
    scene: Scene,
    walks: Sequence[Walk],
    move: RobotMove | None,
    *,
    delay: float = 0.0,
    current: RobotMove | None = None,
    lead: RobotMove | None = None,
    lead_for: float = 0.0,
    horizon: float = HORIZON,
    planner: GridPlanner | None = None,
    until_first_fall: bool = False,
    falling: Mapping[str, str] | None = None,
    passing: Mapping[str, Passing] | None = None,
) -> JointImagination:
    """Step the robot's move and the people's walks together, as the world would, and report how they end.

    With ``until_first_fall``, stop at the first person who falls, unless ``falling`` names that very fall
    (``{person: object}``, a fall that happens anyway); whoever still walks then is ``walking``.
    ``passing`` names people imagined passing what they are believed to walk into (see :class:`Passing`).
    """
    if scene.robot is None:
        raise RequestError("the scene has no robot")
    for w in walks:
        scene.person(w.person)
        if w.toward is None:
            scene.obstacle(w.target)
    world = World(scene, walks, planner=planner or planner_for(scene.bounds), passing=passing)
    start = scene.time
    if current is not None:
        world.resume_robot(current)
    world.advance(start + delay, until_first_fall, falling)
    driving = current
    if lead is not None and lead != current and world.command_robot(lead):
        driving = lead
        world.advance(start + delay + lead_for, until_first_fall, falling)
    reachable = True if driving is not None and move == driving else world.command_robot(move)
    if reachable or move is None:
        world.advance(start + horizon, until_first_fall, falling)
    arrival = world.robot_arrival - start if move is not None and world.robot_arrival is not None else None
    return JointImagination(move, reachable, arrival, tuple(_outcome(world, w, start) for w in walks))


def _outcome(world: World, walk: Walk, start: float) -> WalkOutcome:
    w = world.walker(walk.person)
    hit = next((c for c in world.outcome().collisions if c.person == walk.person), None)
    saw = world.robot_seen.get(walk.person)
    return WalkOutcome(
        walk,
        w.status,
        tuple(w.track),
        tuple(w.known),
        hit.time - start if hit else None,
        hit.point if hit else None,
        hit.obstacle if hit else None,
        w.min_clearance,
        saw - start if saw is not None else None,
        w.robot_clearance,
        world.passed_clearance(walk.person),
        world.passed_size(walk.person),
    )
