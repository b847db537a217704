"""Ground-truth world stepping: people walk to their targets, the robot follows commands.

The same model serves the world bridge (built from a scenario: the truth) and the
robot's joint imagination (built from a believed scene and guessed intents; see
:mod:`agents.caregiving.model.joint`), as the paper's "like me" simulation implies.

Each person walks at constant speed along a plan that avoids only what they have
seen so far (their true gaze, the robot included); walls are always known. They
re-plan whenever a new object comes into view, or a seen robot or person has
moved into the rest of their way. The robot drives to commanded poses along a
planned path with a trapezoidal speed profile, from the speed it has. Contacts are measured with exact planar geometry every 50 ms; a
person who touches anything but their target stops there (they trip). As in the
rollouts (:func:`~agents.caregiving.model.rollout.contacts`), a person who starts
touching something and walks away from it does not touch it until they have come
clear of it and come back: someone imagined standing against what they just reached
does not fall over it by setting off. The
:class:`Outcome` lists collisions (time, place, object) and closest approaches.

:meth:`World.advance` steps the same way, but once the robot rests and one person
is left walking, it takes their steps up to the next thing that changes their
plan (a new sighting), a contact or their arrival in one vectorised pass, with
the same arithmetic as :meth:`World.step`: imagining a walk to its end then costs
a few array operations instead of a Python step per 50 ms.
"""

from __future__ import annotations

import copy
import math
from collections.abc import Mapping, Sequence
from dataclasses import dataclass, field, replace

import numpy as np

from .errors import CaregivingError
from .geometry import (
    Box,
    Circle,
    Polyline,
    bounding_radius,
    closest_boundary_point,
    moved_more_than,
    point_distance,
    polyline_distance,
    signed_distance,
)
from .planner import GridPlanner
from .robot_moves import RobotMove, robot_fits
from .rollout import DT
from .scenario import Scenario
from .scene import PERSON_KIND, ROBOT_KIND, Obstacle, PersonState, Pose, RobotState, Scene
from .visibility import WALL_KIND, Hidden, can_see, seen_along, sight, wrap_angle

#: A seen robot or person that moved more than this triggers a re-plan.
REPLAN_SHIFT = 0.1
#: A reported route is the one of a move if it ends this close (m) to the move's pose.
ROUTE_END_TOLERANCE = 0.05


@dataclass(frozen=True)
class Collision:
    """A person touching an object."""

    time: float
    person: str
    obstacle: str
    point: tuple[float, float]


@dataclass(frozen=True)
class Outcome:
    """What happened in a run."""

    collisions: tuple[Collision, ...]
    min_clearance: dict[str, float]
    closest: dict[str, str]
    arrival: dict[str, float | None]
    duration: float

    @property
    def collided(self) -> bool:
        """Whether anybody touched anything."""
        return bool(self.collisions)


@dataclass(frozen=True)
class Walk:
    """A person's intent: the object they head for, their gaze pitch (rad) and what they already know of.

    ``robot_at`` is the pose ``(x, y, heading)`` where they remember the robot, if they know it: a robot that has
    moved since they last saw it is planned around where it stood then. ``None``: where it stands now.
    ``toward``: for someone walking with no target known, the point they walk to instead (``target`` empty).
    """

    person: str
    target: str
    gaze: float
    known: tuple[str, ...] = ()
    robot_at: Pose | None = None
    toward: tuple[float, float] | None = None


def _remembered(body: Obstacle, robot: RobotState, robot_at: Pose | None) -> Obstacle:
    """``body`` as a walker knows it: the robot where they remember it (``robot_at``), anything else as it is."""
    return robot.moved(*robot_at).body() if robot_at is not None and body.name == robot.name else body


def fell(status: str, person: str, hit: str | None, excused: Mapping[str, str]) -> bool:
    """Whether a walk with this status is a fall (stuck, or into ``hit``) other than one ``excused`` names."""
    return status == "stuck" or status == "collided" and excused.get(person) != hit


@dataclass(frozen=True)
class Passing:
    """A person imagined passing ``obstacle``, which the belief has them walk into: it is not there for them at
    all (``allowance`` infinite), or they touch it only by going more than ``allowance`` metres into it."""

    obstacle: str
    allowance: float = math.inf

    def allowance_for(self, name: str) -> float:
        """How far the person may go into the body ``name`` before it is a touch."""
        return self.allowance if name == self.obstacle else 0.0


@dataclass
class _Walker:
    state: PersonState
    target: str
    gaze: float
    known: dict[str, Obstacle]
    toward: tuple[float, float] | None = None
    route: Polyline | None = None
    walked: float = 0.0
    status: str = "walking"  # walking | arrived | collided | stuck
    min_clearance: float = math.inf
    closest: str = ""
    arrival: float | None = None
    track: list[tuple[float, float]] = field(default_factory=list)
    # Closest approach to the robot while it drives or stands where the walker does not know it to be.
    robot_clearance: float = math.inf
    # The length of the polygonal line through every place the walker has stood, and, for the things but the
    # robot they have not seen, why not: their own and the thing's reading of it and their heading when that
    # was worked out, with the bound (see World._sees).
    travelled: float = 0.0
    unseen: dict[str, tuple[float, float, float, Hidden]] = field(default_factory=dict)
    # For the things that never move, the walker's travel and their clearance when it was last measured: they
    # stay at least that clearance, less what the walker has travelled since, away (see World._check_contacts).
    measured: dict[str, tuple[float, float]] = field(default_factory=dict)
    # The bodies the walker starts touching, with their clearance then: left out of contacts while the walker
    # leaves them, until they come clear (see World._check_contacts).
    leaving: dict[str, float] = field(default_factory=dict)


@dataclass
class _Drive:
    route: Polyline
    heading: float
    walked: float = 0.0


class World:
    """The simulated room, stepped at ``dt``."""

    def __init__(
        self,
        scene: Scene,
        walks: Sequence[Walk],
        dt: float = DT,
        planner: GridPlanner | None = None,
        passing: Mapping[str, Passing] | None = None,
    ) -> None:
        """People named in ``walks`` walk; anyone else stands still. The robot starts at its scene speed.

        ``passing`` names people imagined passing what the belief has them walk into (see :class:`Passing`).
        """
        self.dt = dt
        self._passing = dict(passing or {})
        self.started = self.time = scene.time
        self.planner = planner or GridPlanner(scene.bounds)
        self._bounds = scene.bounds
        self._static = scene.obstacles
        if scene.robot is None:
            raise CaregivingError("the world needs a robot")
        intents = {w.person: w for w in walks}
        self._standing = tuple(p for p in scene.people if p.name not in intents)
        self._standing_bodies = tuple(p.body() for p in self._standing)
        # What a walker knows of: the walls, and whatever their intent names, the robot where they remember it and
        # other people where they are now.
        bodies = [*scene.obstacles, scene.robot.body(), *(p.body() for p in scene.people)]
        self._walkers = [
            _Walker(
                p,
                intents[p.name].target,
                intents[p.name].gaze,
                {
                    o.name: _remembered(o, scene.robot, intents[p.name].robot_at)
                    for o in bodies
                    if o.kind == WALL_KIND or o.name in intents[p.name].known and o.name != p.name
                },
                intents[p.name].toward,
                track=[(p.x, p.y)],
            )
            for p in scene.people
            if p.name in intents
        ]
        self._walker_named = {w.state.name: w for w in self._walkers}
        for w in self._walkers:
            w.leaving = {
                o.name: c
                for o in bodies
                if o.name not in (w.state.name, w.target)
                and (c := point_distance(o.shape, w.state.x, w.state.y) - w.state.radius + self._allowance(w, o)) <= 0.0
            }
        self.robot: RobotState = scene.robot
        self._speed = scene.robot.speed
        self._drive: _Drive | None = None
        self._collisions: list[Collision] = []
        self._fixed: tuple[Obstacle, ...] = ()
        self.robot_arrival: float | None = None
        self.robot_seen: dict[str, float] = {}
        # The length of the polygonal line through every place the robot has stood (see World._sees).
        self._robot_travelled = 0.0

    @classmethod
    def from_scenario(cls, scenario: Scenario, dt: float = DT, planner: GridPlanner | None = None) -> World:
        """The ground truth of a scenario: everyone walks to their target at their true gaze."""
        walks = [Walk(p.name, p.target, math.radians(p.gaze_deg)) for p in scenario.people]
        return cls(scenario.scene(), walks, dt, planner)

    def fork(self) -> World:
        """An independent copy of the world now (sharing the planner and its caches)."""
        twin = copy.copy(self)
        twin._walkers = [
            replace(
                w,
                known=dict(w.known),
                track=list(w.track),
                unseen=dict(w.unseen),
                leaving=dict(w.leaving),
                measured=dict(w.measured),
            )
            for w in self._walkers
        ]
        twin._walker_named = {w.state.name: w for w in twin._walkers}
        twin._drive = replace(self._drive) if self._drive is not None else None
        twin._collisions = list(self._collisions)
        twin.robot_seen = dict(self.robot_seen)
        return twin

    # -- state ---------------------------------------------------------------------------------
    def scene(self) -> Scene:
        """The ground-truth snapshot now."""
        people = tuple(w.state for w in self._walkers) + self._standing
        robot = replace(self.robot, speed=self._speed, route=self.robot_route)
        return Scene(self._bounds, self._static, people, robot, self.time)

    @property
    def robot_speed(self) -> float:
        """The robot's current speed, m/s."""
        return self._speed

    @property
    def robot_route(self) -> tuple[tuple[float, float], ...]:
        """The waypoints of the robot's drive still ahead of it (empty when it is not driving)."""
        d = self._drive
        if d is None:
            return ()
        ahead = d.route.points[d.route.cumulative > d.walked]
        return tuple((float(x), float(y)) for x, y in ahead)

    @property
    def done(self) -> bool:
        """Whether nobody is walking any more."""
        return all(w.status != "walking" for w in self._walkers)

    def people(self) -> list[str]:
        """Everyone who walks in this world, walking still or not."""
        return [w.state.name for w in self._walkers]

    def walking(self) -> list[str]:
        """The people still walking."""
        return [w.state.name for w in self._walkers if w.status == "walking"]

    def fallen(self) -> frozenset[str]:
        """The people who have tripped: they lie where they fell."""
        return frozenset(w.state.name for w in self._walkers if w.status == "collided")

    def someone_fell(self, excused: Mapping[str, str]) -> bool:
        """Whether someone has touched something or got stuck, but for the falls ``excused`` names ({person: object})."""
        for w in self._walkers:
            if w.status != "walking" and w.status != "arrived":
                name = w.state.name
                if fell(w.status, name, self._hit(name), excused):
                    return True
        return False

    def _hit(self, person: str) -> str | None:
        """What ``person`` collided with, if they did."""
        return next((c.obstacle for c in self._collisions if c.person == person), None)

    def passed_clearance(self, person: str) -> float | None:
        """How close ``person``, passing what they are believed to walk into, came to it (negative: how deep they
        went through it); None when they pass nothing, or something that moves (an object or a person standing,
        fallen ones too, does not)."""
        body = self._passed_body(person)
        if body is None:
            return None
        w = self.walker(person)
        return float(signed_distance(body.shape, np.array(w.track)).min()) - w.state.radius

    def passed_size(self, person: str) -> float | None:
        """The bounding radius of the object ``person`` is imagined passing, whose size perception may hold off;
        None when they pass nothing, a wall or a person (whose sizes it knows)."""
        body = self._passed_body(person)
        if body is None or body.kind == WALL_KIND or body in self._standing_bodies:
            return None
        return bounding_radius(body.shape)

    def _passed_body(self, person: str) -> Obstacle | None:
        passed = self._passing.get(person)
        if passed is None:
            return None
        return next((o for o in (*self._static, *self._standing_bodies) if o.name == passed.obstacle), None)

    def walker(self, person: str) -> _Walker:
        """The state of one walking person (their track, plan, status and what they know)."""
        return next(w for w in self._walkers if w.state.name == person)

    def robot_memory(self, person: str) -> Pose | None:
        """Where ``person`` remembers the robot, as :attr:`Walk.robot_at` says it (``None``: not seen yet)."""
        seen = self.walker(person).known.get(self.robot.name)
        if seen is None or not isinstance(seen.shape, Box):
            return None
        return (seen.shape.x, seen.shape.y, seen.shape.theta)

    def outcome(self) -> Outcome:
        """The record so far."""
        return Outcome(
            tuple(self._collisions),
            {w.state.name: w.min_clearance for w in self._walkers},
            {w.state.name: w.closest for w in self._walkers},
            {w.state.name: w.arrival for w in self._walkers},
            self.time,
        )

    # -- robot ---------------------------------------------------------------------------------
    def command_robot(self, move: RobotMove | None) -> bool:
        """Send the robot to a move's pose (``None`` brakes to a stop); False if it does not fit or cannot get there."""
        if move is None:
            self._drive = None
            return True
        scene = self.scene()
        if not robot_fits(scene, move):
            return False
        self.robot_arrival = None
        plan = self.planner.plan_to_point(
            (self.robot.x, self.robot.y),
            (move.x, move.y),
            [*self._static, *(p.body() for p in scene.people)],
            self.robot.width / 2,
        )
        if not plan.reachable:
            return False
        self._drive = _Drive(Polyline.of(plan.path), move.heading)
        return True

    def resume_robot(self, move: RobotMove) -> bool:
        """Go on with ``move`` along the route the robot reported, as a robot already driving it does.

        Without a reported route that ends at the move's pose, the move is planned afresh (:meth:`command_robot`).
        """
        route = self.robot.route
        if not route or math.dist(route[-1], (move.x, move.y)) > ROUTE_END_TOLERANCE:
            return self.command_robot(move)
        self.robot_arrival = None
        self._drive = _Drive(Polyline.of([(self.robot.x, self.robot.y), *route]), move.heading)
        return True

    def _step_robot(self) -> None:
        r = self.robot
        if self._drive is None:
            self._speed = max(self._speed - r.max_accel * self.dt, 0.0)
            if self._speed > 0.0:
                self.robot = r.moved(
                    r.x + math.cos(r.heading) * self._speed * self.dt,
                    r.y + math.sin(r.heading) * self._speed * self.dt,
                    r.heading,
                )
            return
        d = self._drive
        remaining = max(d.route.length - d.walked, 0.0)
        # Fastest speed for this step that still leaves room to brake at max_accel afterwards.
        stop_speed = r.max_accel * (math.sqrt(self.dt**2 + 2 * remaining / r.max_accel) - self.dt)
        self._speed = min(self._speed + r.max_accel * self.dt, r.max_speed, stop_speed)
        d.walked = min(d.walked + self._speed * self.dt, d.route.length)
        if d.route.length - d.walked < 1e-3 or self._speed < 1e-6:
            end = d.route.points[-1]
            self.robot = r.moved(float(end[0]), float(end[1]), d.heading)
            self._speed, self._drive = 0.0, None
            self.robot_arrival = self.time + self.dt
            return
        x, y = d.route.point_at(d.walked)
        self.robot = r.moved(x, y, math.atan2(y - r.y, x - r.x))

    # -- people --------------------------------------------------------------------------------
    def _others(self, me: str) -> tuple[Obstacle, ...]:
        """Everything ``me`` can bump into, as :meth:`Scene.bodies_around` orders it (but what they pass)."""
        people = tuple(w.state.body() for w in self._walkers if w.state.name != me)
        around = self._fixed + people + self._standing_bodies
        passed = self._passing.get(me)
        if passed is None or passed.allowance < math.inf:
            return around
        return tuple(o for o in around if o.name != passed.obstacle)

    def _allowance(self, w: _Walker, o: Obstacle) -> float:
        """How far ``w`` may go into ``o`` before it is a touch: 0, but for what they are imagined passing."""
        passed = self._passing.get(w.state.name)
        return passed.allowance_for(o.name) if passed is not None else 0.0

    def _look(self, w: _Walker, around: tuple[Obstacle, ...]) -> bool:
        """Update what ``w`` knows; True when that calls for a new plan.

        A newly seen object always does. A seen robot or person that has moved (or turned) more than
        :data:`REPLAN_SHIFT` at any point is remembered where it is now, and calls for a new plan only when
        it now stands in the way of the rest of the walk: people keep their route otherwise.
        """
        changed = w.route is None
        for o in around:
            old = w.known.get(o.name)
            if old is None:
                if not self._sees(w, o):
                    continue
                if o.kind == ROBOT_KIND:
                    self.robot_seen.setdefault(w.state.name, self.time)
                changed = True
            else:
                # A known body is looked at again only once it has moved: until then, seen or not, it stays as is.
                moving = o.kind in (ROBOT_KIND, PERSON_KIND)
                if (
                    not moving
                    or not moved_more_than(old.shape, o.shape, REPLAN_SHIFT)
                    or not can_see(w.state, o, w.gaze)
                ):
                    continue
                changed = changed or self._in_the_way(w, o)
            w.known[o.name] = o
        return changed

    def _sees(self, w: _Walker, o: Obstacle) -> bool:
        """Whether ``w`` sees ``o`` now, not working it out again while it stays hidden.

        :func:`visibility.sight` bounds how far ``w`` must move before ``o`` can show; a person or the robot
        ``o`` moving ``d`` changes the distances and directions it reads by at most as much as ``w`` moving
        ``d`` does, so what both have travelled since counts against the bound. The robot also turns as it
        drives, which the bound does not cover, so its bound is worked out for the disc that holds its
        footprint at any heading: while that disc is hidden, so is the robot.
        """
        robot = o.kind == ROBOT_KIND
        other = self._walker_named.get(o.name)
        moved = self._robot_travelled if robot else other.travelled if other is not None else 0.0
        known = w.unseen.get(o.name)
        if known is not None:
            mine, theirs, heading, bound = known
            if w.travelled - mine + moved - theirs < bound.distance and (
                bound.turn == math.inf or abs(wrap_angle(w.state.heading - heading)) < bound.turn
            ):
                return False
        hidden = sight(w.state, _any_heading(o) if robot else o, w.gaze)
        if hidden is None:
            return not robot or can_see(w.state, o, w.gaze)
        w.unseen[o.name] = (w.travelled, moved, w.state.heading, hidden)
        return False

    def _in_the_way(self, w: _Walker, body: Obstacle) -> bool:
        """Whether ``body`` comes within :data:`REPLAN_SHIFT` of the walker's disc along the rest of their plan."""
        if w.route is None:
            return True
        reach = w.state.radius + REPLAN_SHIFT
        shape = body.shape
        # Every point of the route is at least this far from the body: far enough settles it without sampling.
        if polyline_distance(w.route.points, shape.x, shape.y) - bounding_radius(shape) >= reach + 1e-9:
            return False
        ahead = w.route.remaining(w.walked, REPLAN_SHIFT)
        return bool((signed_distance(shape, ahead) < reach).any())

    def _replan(self, w: _Walker) -> None:
        known = list(w.known.values())
        start = (w.state.x, w.state.y)
        if w.toward is not None:
            plan = self.planner.plan_to_point(start, w.toward, known, w.state.radius)
        else:
            target = next(o for o in self._static if o.name == w.target)
            plan = (  # the walk they were on when the world began: the rest of the route planned at its origin
                self.planner.plan_walk(start, w.state.origin, target, known, w.state.radius)
                if w.route is None
                else self.planner.plan_to_object(start, target, known, w.state.radius)
            )
        if plan.reachable:
            w.route, w.walked = Polyline.of(plan.path), 0.0
        elif w.route is None and w.toward is not None:  # nowhere known to go, the way ahead blocked: they stop
            w.status, w.arrival = "arrived", self.time
        elif w.route is None:
            w.status = "stuck"

    def _step_person(self, w: _Walker) -> None:
        around = self._others(w.state.name)
        if self._look(w, around):
            self._replan(w)
        if w.status != "walking" or w.route is None:
            return
        length = w.route.length
        w.walked = min(w.walked + w.state.speed * self.dt, length)
        x, y = w.route.point_at(w.walked)
        s = w.state
        heading = math.atan2(y - s.y, x - s.x) if math.hypot(x - s.x, y - s.y) > 1e-9 else s.heading
        w.state = s.moved(x, y, heading)
        w.travelled += math.hypot(x - s.x, y - s.y)
        w.track.append((w.state.x, w.state.y))
        if w.walked >= length - 1e-9:
            w.status, w.arrival = "arrived", self.time + self.dt
        if self._drive is not None or self._speed > 0.0 or not self._knows_robot(w):
            robot = self._fixed[-1]
            w.robot_clearance = min(w.robot_clearance, point_distance(robot.shape, x, y) - w.state.radius)
        self._check_contacts(w, around)

    def _knows_robot(self, w: _Walker) -> bool:
        """Whether ``w`` knows where the resting robot stands, so that their plan already keeps clear of it.

        The robot's body this step is the last of :attr:`_fixed`, set before anyone walks.
        """
        known = w.known.get(self.robot.name)
        return known is not None and not moved_more_than(known.shape, self._fixed[-1].shape, REPLAN_SHIFT)

    def _check_contacts(self, w: _Walker, around: tuple[Obstacle, ...]) -> None:
        """Record ``w``'s closest approach to anything ``around`` but their target, and a contact as a collision."""
        x, y, radius, target = w.state.x, w.state.y, w.state.radius, w.target
        nearest, clear = None, w.min_clearance
        leaving, measured, travelled = w.leaving, w.measured, w.travelled
        passed = self._passing.get(w.state.name)
        for o in around:
            if o.name == target:
                continue
            shape = o.shape
            # What they are imagined passing is touched only deeper than its allowance: less radius to reach it.
            reach = radius if passed is None else radius - passed.allowance_for(o.name)
            if leaving and (start := leaving.get(o.name)) is not None:
                c = point_distance(shape, x, y) - reach
                # Still touching what they started against: walking on into it at the first step counts,
                # leaving it does not until they come clear of it.
                if c <= 0.0 and not (len(w.track) == 2 and c < start):
                    continue
                del leaving[o.name]
            # A body kept at least the closest approach so far away, by its bounding circle or, if it never
            # moves, by its clearance when last measured less what the walker has travelled since, can
            # neither be the new closest nor touch (the closest approach stays positive while they walk).
            fixed = o.kind != ROBOT_KIND and o.kind != PERSON_KIND
            if fixed and (last := measured.get(o.name)) is not None and last[1] - (travelled - last[0]) - 1e-9 >= clear:
                continue
            if math.hypot(x - shape.x, y - shape.y) - bounding_radius(shape) - radius - 1e-9 >= clear:
                continue
            c = point_distance(shape, x, y) - reach
            if fixed:
                measured[o.name] = (travelled, c)
            if c < clear:
                nearest, clear = o, c
        if nearest is None:
            return
        w.min_clearance, w.closest = clear, nearest.name
        if clear <= 0.0:
            point = closest_boundary_point(nearest.shape, (x, y))[0]
            self._collisions.append(
                Collision(self.time + self.dt, w.state.name, nearest.name, (float(point[0]), float(point[1])))
            )
            w.status = "collided"

    # -- stepping ------------------------------------------------------------------------------
    def step(self) -> None:
        """Advance the world by one ``dt``."""
        before = self.robot
        self._step_robot()
        self._robot_travelled += math.hypot(self.robot.x - before.x, self.robot.y - before.y)
        self._fixed = self._static + (self.robot.body(),)
        for w in self._walkers:
            if w.status == "walking":
                self._step_person(w)
        self.time += self.dt

    def advance(self, until: float, until_first_fall: bool = False, excused: Mapping[str, str] | None = None) -> None:
        """Step until nobody walks or ``until`` passes, a lone walker past a resting robot in bulk (same result).

        With ``until_first_fall``, stop as soon as someone touches something or gets stuck, but for the falls
        ``excused`` names (``{person: object}``).
        """
        excused = excused or {}
        while not self.done and self.time < until - 1e-9 and not (until_first_fall and self.someone_fell(excused)):
            walker = self._lone_walker()
            if walker is None or not self._glide(walker, until):
                self.step()

    def run(self, max_time: float = 60.0) -> Outcome:
        """Step until nobody walks or ``max_time`` passes."""
        self.advance(max_time)
        return self.outcome()

    # -- the lone walker's steps in bulk ---------------------------------------------------------
    def _lone_walker(self) -> _Walker | None:
        """The one person still walking, when the robot rests and so nothing else in the room moves, and they
        are not leaving something they started against (whose contacts :meth:`_check_contacts` rules on)."""
        if self._drive is not None or self._speed != 0.0:
            return None
        walking = [w for w in self._walkers if w.status == "walking"]
        if len(walking) != 1 or walking[0].route is None or walking[0].leaving:
            return None
        return walking[0]

    def _glide(self, w: _Walker, until: float) -> bool:
        """Take ``w``'s steps up to ``until`` at once, stopping before a step whose look changes their plan.

        Each step is what :meth:`step` would do: look from where they stand, move along the route, check
        contacts. Returns False when the very next step needs :meth:`step` (its look changes something).
        """
        assert w.route is not None
        steps, t = 0, self.time
        while t < until - 1e-9:
            t += self.dt
            steps += 1
        s, route = w.state, w.route
        advance = s.speed * self.dt
        steps = min(steps, int(math.ceil(max(route.length - w.walked, 0.0) / max(advance, 1e-12))) + 1)
        if steps <= 0:
            return False
        walked = np.minimum(np.cumsum(np.concatenate(([w.walked], np.full(steps, advance))))[1:], route.length)
        xs, ys = self._points_at(route, walked)
        headings, lengths = [], []
        hx, hy, heading = s.x, s.y, s.heading
        for x, y in zip(xs.tolist(), ys.tolist(), strict=True):
            length = math.hypot(x - hx, y - hy)
            heading = math.atan2(y - hy, x - hx) if length > 1e-9 else heading
            headings.append(heading)
            lengths.append(length)
            hx, hy = x, y
        # The poses the person looks from: where they stand before each step.
        look_x = np.concatenate(([s.x], xs[:-1]))
        look_y = np.concatenate(([s.y], ys[:-1]))
        look_h = np.array([s.heading, *headings[:-1]])
        self._fixed = self._static + (self.robot.body(),)
        around = self._others(s.name)
        stop = steps + 1  # the first step whose look changes what the person knows
        saw_robot: int | None = None
        for o in around:
            old = w.known.get(o.name)
            moving = o.kind in (ROBOT_KIND, PERSON_KIND)
            if old is not None and not moving:
                continue
            news = old is None or moved_more_than(old.shape, o.shape, REPLAN_SHIFT)
            first_robot = o.kind == ROBOT_KIND and s.name not in self.robot_seen
            if not news and not first_robot:
                continue
            seen = np.flatnonzero(seen_along(s, look_x, look_y, look_h, o, w.gaze))
            if seen.size == 0:
                continue
            if news:
                stop = min(stop, int(seen[0]) + 1)
            if first_robot:
                saw_robot = int(seen[0]) + 1
        bodies = [o for o in around if o.name != w.target]
        pts = np.stack((xs, ys), axis=1)
        reach = np.array([s.radius - self._allowance(w, o) for o in bodies])
        clear = np.stack([signed_distance(o.shape, pts) for o in bodies], axis=1) - reach
        # The resting robot: what the walker knows of it does not change before ``stop``.
        unaware = not self._knows_robot(w)
        nearest = clear.min(axis=1)
        touching = np.flatnonzero(nearest <= 0.0)
        arrived = np.flatnonzero(walked >= route.length - 1e-9)
        last = min(stop - 1, steps, *(int(k[0]) + 1 for k in (touching, arrived) if k.size))
        if last <= 0:
            return False
        starts = []
        for _ in range(last):
            starts.append(self.time)
            self.time += self.dt
        if saw_robot is not None and saw_robot <= last:
            self.robot_seen.setdefault(s.name, starts[saw_robot - 1])
        best = int(np.argmin(nearest[:last]))
        if nearest[best] < w.min_clearance:
            w.min_clearance, w.closest = float(nearest[best]), bodies[int(np.argmin(clear[best]))].name
        if unaware:
            robot_column = next(k for k, o in enumerate(bodies) if o.kind == ROBOT_KIND)
            w.robot_clearance = min(w.robot_clearance, float(clear[:last, robot_column].min()))
        w.walked = float(walked[last - 1])
        w.state = s.moved(float(xs[last - 1]), float(ys[last - 1]), headings[last - 1])
        for step_length in lengths[:last]:  # step by step, as the polygonal line through where they stood
            w.travelled += step_length
        w.track.extend(zip(xs[:last].tolist(), ys[:last].tolist(), strict=True))
        end = starts[last - 1] + self.dt
        if w.walked >= route.length - 1e-9:
            w.status, w.arrival = "arrived", end
        if nearest[last - 1] <= 0.0:
            hit = bodies[int(np.argmin(clear[last - 1]))]
            point = closest_boundary_point(hit.shape, (w.state.x, w.state.y))[0]
            self._collisions.append(Collision(end, s.name, hit.name, (float(point[0]), float(point[1]))))
            w.status = "collided"
        return True

    @staticmethod
    def _points_at(route: Polyline, distances: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
        """:meth:`Polyline.point_at` of many distances, with the same arithmetic."""
        cum, pts = route.cumulative, route.points
        if len(pts) == 1:
            return np.full(len(distances), pts[0, 0]), np.full(len(distances), pts[0, 1])
        k = np.clip(np.searchsorted(cum, distances, side="right") - 1, 0, len(pts) - 2)
        t = (distances - cum[k]) / (cum[k + 1] - cum[k])
        xs = pts[k, 0] + t * (pts[k + 1, 0] - pts[k, 0])
        ys = pts[k, 1] + t * (pts[k + 1, 1] - pts[k, 1])
        start, end = distances <= 0.0, distances >= cum[-1]
        xs[start], ys[start] = pts[0, 0], pts[0, 1]
        xs[end], ys[end] = pts[-1, 0], pts[-1, 1]
        return xs, ys


def _any_heading(body: Obstacle) -> Obstacle:
    """``body`` as the disc its footprint sweeps turning in place, which holds it at any heading."""
    shape = body.shape
    return replace(body, shape=Circle(shape.x, shape.y, bounding_radius(shape)))


def run_idle(trial: Scenario, max_time: float = 60.0, planner: GridPlanner | None = None) -> Outcome:
    """The exact-geometry ground truth of a trial with the robot standing still."""
    return World.from_scenario(trial, planner=planner).run(max_time)
