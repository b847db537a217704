"""Ground-truth world stepping: people walk to their targets, the robot follows commands.

Each person walks at constant speed along a plan that avoids only what they have
seen so far (their true gaze, the robot included); walls are always known. They
re-plan whenever a new object comes into view or a seen robot/person has moved.
The robot drives to commanded poses along a planned path with a trapezoidal
speed profile. Contacts are measured with exact planar geometry every 50 ms; a
person who touches anything but their target stops there (they trip). The
:class:`Outcome` lists collisions (time, place, object) and closest approaches.
"""

from __future__ import annotations

import math
from dataclasses import dataclass, field, replace

import numpy as np

from .geometry import FloatArray, closest_boundary_point, polyline_length, resample_by_distance, signed_distance
from .planner import GridPlanner
from .robot_moves import RobotMove
from .rollout import DT
from .scenario import Scenario
from .scene import PERSON_KIND, ROBOT_KIND, Obstacle, PersonState, RobotState, Scene
from .visibility import WALL_KIND, visible

#: A seen robot or person that moved more than this triggers a re-plan.
REPLAN_SHIFT = 0.1


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


@dataclass
class _Walker:
    state: PersonState
    target: str
    gaze: float
    known: dict[str, Obstacle]
    path: FloatArray = field(default_factory=lambda: np.zeros((0, 2)))
    walked: float = 0.0
    status: str = "walking"  # walking | arrived | collided | stuck
    min_clearance: float = math.inf
    closest: str = ""
    arrival: float | None = None


@dataclass
class _Drive:
    path: FloatArray
    length: float
    heading: float
    walked: float = 0.0


class World:
    """The simulated room, stepped at ``dt``."""

    def __init__(self, scenario: Scenario, dt: float = DT, planner: GridPlanner | None = None) -> None:
        scene = scenario.scene()
        self.dt = dt
        self.time = 0.0
        self.planner = planner or GridPlanner(scene.bounds)
        self._bounds = scene.bounds
        self._static = scene.obstacles
        walls = {o.name: o for o in scene.obstacles if o.kind == WALL_KIND}
        specs = {p.name: p for p in scenario.people}
        self._walkers = [_Walker(p, specs[p.name].target, math.radians(specs[p.name].gaze_deg), dict(walls))
                         for p in scene.people]
        assert scene.robot is not None
        self.robot: RobotState = scene.robot
        self._speed = 0.0
        self._drive: _Drive | None = None
        self._collisions: list[Collision] = []

    # -- state ---------------------------------------------------------------------------------
    def scene(self) -> Scene:
        """The ground-truth snapshot now."""
        return Scene(self._bounds, self._static, tuple(w.state for w in self._walkers), self.robot, self.time)

    @property
    def robot_speed(self) -> float:
        """The robot's current speed, m/s."""
        return self._speed

    @property
    def done(self) -> bool:
        """Whether nobody is walking any more."""
        return all(w.status != "walking" for w in self._walkers)

    def outcome(self) -> Outcome:
        """The record so far."""
        return Outcome(tuple(self._collisions), {w.state.name: w.min_clearance for w in self._walkers},
                       {w.state.name: w.closest for w in self._walkers},
                       {w.state.name: w.arrival for w in self._walkers}, self.time)

    # -- robot ---------------------------------------------------------------------------------
    def command_robot(self, move: RobotMove | None) -> bool:
        """Send the robot to a move's pose (``None`` brakes to a stop); False if it cannot get there."""
        if move is None:
            self._drive = None
            return True
        people = [w.state.body() for w in self._walkers]
        plan = self.planner.plan_to_point((self.robot.x, self.robot.y), (move.x, move.y),
                                          [*self._static, *people], self.robot.width / 2)
        if not plan.reachable:
            return False
        self._drive = _Drive(plan.path, plan.length, move.heading)
        return True

    def _step_robot(self) -> None:
        r = self.robot
        if self._drive is None:
            self._speed = max(self._speed - r.max_accel * self.dt, 0.0)
            if self._speed > 0.0:
                self.robot = replace(r, x=r.x + math.cos(r.heading) * self._speed * self.dt,
                                     y=r.y + math.sin(r.heading) * self._speed * self.dt)
            return
        d = self._drive
        remaining = max(d.length - d.walked, 0.0)
        # Fastest speed for this step that still leaves room to brake at max_accel afterwards.
        stop_speed = r.max_accel * (math.sqrt(self.dt ** 2 + 2 * remaining / r.max_accel) - self.dt)
        self._speed = min(self._speed + r.max_accel * self.dt, r.max_speed, stop_speed)
        d.walked = min(d.walked + self._speed * self.dt, d.length)
        if d.length - d.walked < 1e-3 or self._speed < 1e-6:
            end = d.path[-1]
            self.robot = replace(r, x=float(end[0]), y=float(end[1]), heading=d.heading)
            self._speed, self._drive = 0.0, None
            return
        x, y = resample_by_distance(d.path, [d.walked])[0]
        self.robot = replace(r, x=float(x), y=float(y), heading=math.atan2(y - r.y, x - r.x))

    # -- people --------------------------------------------------------------------------------
    def _others(self, me: str) -> tuple[Obstacle, ...]:
        return self.scene().bodies_around(me)

    def _look(self, w: _Walker, around: tuple[Obstacle, ...]) -> bool:
        """Update what ``w`` knows; True when that calls for a new plan."""
        changed = not w.path.size
        for o in visible(w.state, around, w.gaze):
            old = w.known.get(o.name)
            if old is None:
                changed = True
            elif o.kind in (ROBOT_KIND, PERSON_KIND) and \
                    math.hypot(o.shape.x - old.shape.x, o.shape.y - old.shape.y) > REPLAN_SHIFT:
                changed = True
            else:
                continue
            w.known[o.name] = o
        return changed

    def _replan(self, w: _Walker) -> None:
        target = next(o for o in self._static if o.name == w.target)
        plan = self.planner.plan_to_object((w.state.x, w.state.y), target, list(w.known.values()), w.state.radius)
        if plan.reachable:
            w.path, w.walked = plan.path, 0.0
        elif not w.path.size:
            w.status = "stuck"

    def _step_person(self, w: _Walker) -> None:
        around = self._others(w.state.name)
        if self._look(w, around):
            self._replan(w)
        if w.status != "walking":
            return
        length = polyline_length(w.path)
        w.walked = min(w.walked + w.state.speed * self.dt, length)
        x, y = resample_by_distance(w.path, [w.walked])[0]
        s = w.state
        heading = math.atan2(y - s.y, x - s.x) if math.hypot(x - s.x, y - s.y) > 1e-9 else s.heading
        w.state = replace(s, x=float(x), y=float(y), heading=heading)
        if w.walked >= length - 1e-9:
            w.status, w.arrival = "arrived", self.time + self.dt
        self._check_contacts(w, [o for o in around if o.name != w.target])

    def _check_contacts(self, w: _Walker, bodies: list[Obstacle]) -> None:
        p = (w.state.x, w.state.y)
        clear = np.array([signed_distance(o.shape, p)[0] for o in bodies]) - w.state.radius
        k = int(np.argmin(clear))
        if clear[k] < w.min_clearance:
            w.min_clearance, w.closest = float(clear[k]), bodies[k].name
        if clear[k] <= 0.0:
            point = closest_boundary_point(bodies[k].shape, p)[0]
            self._collisions.append(Collision(self.time + self.dt, w.state.name, bodies[k].name,
                                              (float(point[0]), float(point[1]))))
            w.status = "collided"

    # -- stepping ------------------------------------------------------------------------------
    def step(self) -> None:
        """Advance the world by one ``dt``."""
        self._step_robot()
        for w in self._walkers:
            if w.status == "walking":
                self._step_person(w)
        self.time += self.dt

    def run(self, max_time: float = 60.0) -> Outcome:
        """Step until nobody walks or ``max_time`` passes."""
        while not self.done and self.time < max_time - 1e-9:
            self.step()
        return self.outcome()


def run_idle(trial: Scenario, max_time: float = 60.0, planner: GridPlanner | None = None) -> Outcome:
    """The exact-geometry ground truth of a trial with the robot standing still."""
    return World(trial, planner=planner).run(max_time)
