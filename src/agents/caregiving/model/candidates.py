"""Algorithm 2's candidate moves, likeliest first, with cheap pruning.

A :class:`Danger` is a person's risky imagined walk: their path, the object (or person) they
would hit, where and when. The robot's moves are ``move_to`` a pose:

* **stand-offs** (the paper's ``move_to(object)``): poses around an object, a
  small gap from its boundary, facing it; around the obstacle itself they cover it;
* **covers farther back**: free poses straight on the person's way past the obstacle
  (the middle of each row of :func:`beyond_poses`), a robot the person plans round
  before they reach the obstacle, so that their detour clears it too; then the same
  a little towards the obstacle's side of the way, which the person passes on the
  side away from the obstacle;
* **path poses**: free poses on the person's predicted path, or beside it,
  between the person and the obstacle: in front of the obstacle on the person's
  side, and farther back along the path, where the person will see the robot sooner;
* **guards**: the rows of covers farther back moved to the edge of the person's way on
  the obstacle's side, where the robot's near end meets the person's way: the person
  passes it on its far side, and their detour swings away from the obstacle;
* **swerves**: the first stand-off shifted sideways, when the search found that the
  person, walking round the robot there, still grazes the obstacle on one side;
* **crossings**: stand-offs of any object, within reach in time or not, and then free poses on
  and beside the person's way past the obstacle (:func:`beyond_poses`), whose drive crosses
  the rest of the person's route ahead of them: a robot that appears in someone's way,
  anywhere along it, makes them plan their walk anew, and the new route may miss the obstacle.

:func:`ordered_moves` yields them lazily in the order the search tries them:
the stand-offs around the obstacle, straight behind it and straight in front of
it along the person's way first (a robot there is in view, and the detour around
it also clears the obstacle; over 50 dangers of four scenarios the first of them
removed the danger in 18 of the 28 the search could remove); then the covers
farther back, nearest first (where a closed loop on exact beliefs lost trials to
saving moves it never judged, these stood there most often, 0.5-0.9 m past the
touch, where the stand-off straight behind stands too near the obstacle); then
the path poses, those where the robot has the most seconds in hand first; then
the guards, nearest first; then the crossings, soonest crossed first (the stand-offs, then the poses past the
obstacle); then the stand-offs around the other objects by distance to the
collision point. Two cheap tests prune before any imagination: the robot must
fit at the pose, and a straight drive (the travel-time lower bound, from the
robot's current speed), started when the robot would start on that candidate,
must come within :data:`REACH` of it before the person passes it (path poses) or
before the collision (stand-offs), or, for a crossing, a cover farther back or a guard,
must come into the person's way before the collision (:func:`crossing_time`). :func:`candidates` interleaves the dangers'
orders and puts the :func:`swerves` of the first candidate next once its verdict is in (after the second
candidate if that was asked for first).
"""

from __future__ import annotations

import math
from collections.abc import Callable, Iterable, Iterator, Sequence
from dataclasses import dataclass, replace
from typing import Any

import numpy as np

from .fields import Fields
from .geometry import FloatArray, Polyline, bounding_radius
from .imagine import Imagination
from .robot_moves import RobotMove, robot_fits, standoff_poses, time_to_cover
from .scene import Obstacle, Scene
from .verdict import Verdict
from .visibility import WALL_KIND
from .world_model import REPLAN_SHIFT

#: Lateral offsets (m) of path poses from the person's path, on the path first.
LATERAL = (0.0, 0.3, -0.3)
#: Spacing (m) of path poses along the path.
SPACING = 0.25
#: A pose the robot cannot come this close to (m) before the person passes it is pruned: a robot
#: farther off when the person goes by is beside their way, not in it.
REACH = 1.0
#: Spacing (m) of the points of a person's route that a crossing drive is tested against.
CROSSING_STEP = 0.1
#: Rows of :func:`beyond_poses`, :data:`SPACING` apart along the person's way past the obstacle.
BEYOND_ROWS = 3
#: Sideways shift (m) of a cover farther back towards the obstacle's side of the way: a few cells of the people's
#: planning grid, so that their plan goes round the robot on its far side.
COVER_SHIFT = 0.1
#: Sideways shifts (m) of a swerve, the smaller first.
SWERVE_SHIFTS = (0.15, 0.3)
#: A touch this close to straight ahead (rad) is head-on: the person passed the obstacle on neither side,
#: so there is no side to widen their detour towards.
HEAD_ON = math.radians(25.0)


@dataclass(frozen=True)
class Danger:
    """A person's risky walk: path from where they are, the obstacle, where and in how many seconds they hit it."""

    person: str
    target: str
    path: tuple[tuple[float, float], ...]
    point: tuple[float, float]
    obstacle: str
    time_to_collision: float

    @classmethod
    def of(cls, im: Imagination) -> Danger | None:
        """The danger of an imagined walk that ends in a collision; ``None`` when it does not."""
        if not im.collided or im.collision_point is None or im.collision_object is None or im.collision_time is None:
            return None
        return cls(im.person, im.target, im.path, im.collision_point, im.collision_object, im.collision_time)

    def to_wire(self) -> dict[str, Any]:
        """A msgpack-friendly dict."""
        return {
            "person": self.person,
            "target": self.target,
            "path": [list(p) for p in self.path],
            "point": list(self.point),
            "obstacle": self.obstacle,
            "time_to_collision": self.time_to_collision,
        }

    @classmethod
    def from_fields(cls, f: Fields) -> Danger:
        """Parse :meth:`to_wire` output nested in a larger message."""
        x, y = f.numbers("point", 2)
        return cls(
            f.string("person"),
            f.string("target"),
            f.pairs("path"),
            (x, y),
            f.string("obstacle"),
            f.number("time_to_collision", positive=True),
        )


def travel_direction(path: tuple[tuple[float, float], ...], point: tuple[float, float]) -> tuple[float, float]:
    """Unit direction of the person's path where it comes closest to ``point``."""
    if len(path) < 2:
        return 1.0, 0.0
    pts = np.asarray(path, dtype=float)
    seg = np.diff(pts, axis=0)
    k = int(np.argmin(np.linalg.norm(pts[:-1] + seg / 2 - np.asarray(point), axis=1)))
    norm = float(np.hypot(*seg[k])) or 1.0
    return float(seg[k][0] / norm), float(seg[k][1] / norm)


def touching_distance(scene: Scene, person: str) -> float:
    """How far the robot's centre stands from ``person``'s when its farthest-reaching end just touches them."""
    robot = scene.robot
    assert robot is not None
    return scene.person(person).radius + max(robot.length, robot.width) / 2


def drive_time(scene: Scene, x: float, y: float, within: float = 0.0) -> float:
    """Lower bound on the robot's time to come ``within`` metres of (x, y): a straight drive there from its current
    speed, ending at rest at (x, y)."""
    robot = scene.robot
    assert robot is not None
    trip = math.hypot(x - robot.x, y - robot.y)
    return time_to_cover(trip, trip - within, robot.max_speed, robot.max_accel, robot.speed)


def in_reach(scene: Scene, move: RobotMove, until: float) -> bool:
    """Whether a straight drive can bring the robot within :data:`REACH` of the move's pose before ``until`` s."""
    return drive_time(scene, move.x, move.y, REACH) < until


def route_ahead(scene: Scene, danger: Danger) -> tuple[FloatArray, FloatArray] | None:
    """Points of the person's route every :data:`CROSSING_STEP` metres, and the seconds until they pass each
    (at most until the collision); None for a route of a single point."""
    if len(danger.path) < 2:
        return None
    points = Polyline.of(danger.path).remaining(0.0, CROSSING_STEP)
    walked = np.concatenate(([0.0], np.cumsum(np.hypot(*np.diff(points, axis=0).T))))
    return points, np.minimum(walked / max(scene.person(danger.person).speed, 1e-9), danger.time_to_collision)


def crossing_time(
    scene: Scene,
    danger: Danger,
    move: RobotMove,
    start: float,
    route: tuple[FloatArray, FloatArray] | None = None,
) -> float | None:
    """When a straight drive to the move's pose, started ``start`` s from now, first stands in the way of the
    person's route where they have not passed yet, before they would hit the obstacle; None if never.

    In the way is as the world's people judge it: the robot's body within
    :data:`~agents.caregiving.model.world_model.REPLAN_SHIFT` of the person's disc on their route. Seen
    there, it makes them plan anew, so a point of their route past the obstacle counts too, as long as the
    robot is there before the collision. ``route`` is :func:`route_ahead`'s, if already worked out.
    """
    robot = scene.robot
    assert robot is not None
    ahead = route if route is not None else route_ahead(scene, danger)
    if ahead is None:
        return None
    points, passes = ahead
    trip = math.hypot(move.x - robot.x, move.y - robot.y)
    ux, uy = ((move.x - robot.x) / trip, (move.y - robot.y) / trip) if trip > 0.0 else (0.0, 0.0)
    along = np.clip((points[:, 0] - robot.x) * ux + (points[:, 1] - robot.y) * uy, 0.0, trip)
    off = np.hypot(points[:, 0] - robot.x - along * ux, points[:, 1] - robot.y - along * uy)
    blocking = touching_distance(scene, danger.person) + REPLAN_SHIFT
    best: float | None = None
    for k in np.flatnonzero(off < blocking).tolist():
        entry = max(float(along[k]) - math.sqrt(blocking**2 - float(off[k]) ** 2), 0.0)
        t = start + time_to_cover(trip, entry, robot.max_speed, robot.max_accel, robot.speed)
        if t < passes[k] and (best is None or t < best):
            best = t
    return best


def crossings(scene: Scene, danger: Danger, start: Callable[[], float] = lambda: 0.0) -> Iterator[RobotMove]:
    """The stand-offs of every object (the danger's first), then the :func:`beyond_poses`, whose drive crosses
    the person's route in time (:func:`crossing_time`), each kind soonest crossed first; the robot must fit at
    the pose."""
    route = route_ahead(scene, danger)
    if route is None:
        return
    names = [danger.obstacle] if _stays_put(scene, danger.obstacle) else []
    names += [o.name for o in other_objects(scene, danger)]
    now = start()
    for moves in ([m for name in names for m in standoffs(scene, danger, name)], beyond_poses(scene, danger)):
        timed = _crossing_in_time(scene, danger, moves, now, route)
        yield from (m for _, _, m in sorted(timed, key=lambda c: (c[0], c[1])) if robot_fits(scene, m))


def covers_farther_back(scene: Scene, danger: Danger, start: Callable[[], float] = lambda: 0.0) -> Iterator[RobotMove]:
    """The poses straight on the person's way past the obstacle (:func:`beyond_poses` with no sideways offset),
    nearest first, then the same poses :data:`COVER_SHIFT` towards the obstacle's side of the way, each whose
    drive comes into the person's way before the collision (:func:`crossing_time`); the robot must fit at the
    pose.

    A person plans round a robot straight on their way on either side, and on the obstacle's side the detour
    may still touch it; a robot a little towards that side is passed on its far side, away from the obstacle.
    """
    return _rows_crossed_in_time(scene, danger, (0.0, COVER_SHIFT * obstacle_side(scene, danger)), start)


def guards(scene: Scene, danger: Danger, start: Callable[[], float] = lambda: 0.0) -> Iterator[RobotMove]:
    """The rows of :func:`beyond_poses` beside the person's way on the obstacle's side, the robot's near end on
    the edge of the person's way, each whose drive comes into the person's way before the collision
    (:func:`crossing_time`); the robot must fit at the pose.

    A person who sees the robot standing at the edge of their way plans round it on its far side: their
    detour swings away from the obstacle's side, by more than round a cover shifted a little, and clears an
    obstacle they would have grazed on that side.
    """
    edge = touching_distance(scene, danger.person)
    return _rows_crossed_in_time(scene, danger, (edge * obstacle_side(scene, danger),), start)


def _rows_crossed_in_time(
    scene: Scene, danger: Danger, laterals: Sequence[float], start: Callable[[], float]
) -> Iterator[RobotMove]:
    """The :func:`beyond_poses` at each of ``laterals`` in turn, nearest first, whose drive, started at
    ``start()``, comes into the person's way before the collision; the robot must fit at the pose."""
    route = route_ahead(scene, danger)
    if route is None:
        return
    for lateral in laterals:
        poses = beyond_poses(scene, danger, (lateral,))
        yield from (m for _, _, m in _crossing_in_time(scene, danger, poses, start(), route) if robot_fits(scene, m))


def obstacle_side(scene: Scene, danger: Danger) -> float:
    """1.0 when the obstacle's centre lies left of the person's way where they would touch it, else -1.0."""
    dx, dy = travel_direction(danger.path, danger.point)
    route = Polyline.of(danger.path)
    x, y = route.point_at(route.arc_length_nearest(danger.point))
    shape = scene.body(danger.obstacle).shape
    return 1.0 if dx * (shape.y - y) - dy * (shape.x - x) >= 0.0 else -1.0


def _crossing_in_time(
    scene: Scene, danger: Danger, moves: Sequence[RobotMove], now: float, route: tuple[FloatArray, FloatArray]
) -> list[tuple[float, int, RobotMove]]:
    """The ``moves`` whose straight drive, started ``now`` s from the scene's time, comes into the person's way
    before the collision (:func:`crossing_time` on ``route``), in order, each with when it does and its place
    in ``moves``."""
    return [(t, k, m) for k, m in enumerate(moves) if (t := crossing_time(scene, danger, m, now, route)) is not None]


def path_poses(scene: Scene, danger: Danger) -> Iterator[tuple[RobotMove, float]]:
    """Free poses on and beside the path, from just before the obstacle back towards the person.

    Each stands broadside across the path, so the person meets the robot's longer side, and comes
    with the seconds until the person would reach it.
    """
    robot, person = scene.robot, scene.person(danger.person)
    assert robot is not None
    if len(danger.path) < 2:
        return
    route = Polyline.of(danger.path)
    obstacle = scene.body(danger.obstacle)
    clearance = bounding_radius(obstacle.shape) + max(robot.length, robot.width) / 2 + 0.05
    nearest = touching_distance(scene, danger.person) + 0.2
    distance = min(danger.time_to_collision * person.speed, route.length) - clearance
    while distance > nearest:
        for move in _broadside(route, distance, danger.obstacle):
            yield move, distance / person.speed
        distance -= SPACING


def beyond_poses(scene: Scene, danger: Danger, lateral: Sequence[float] = LATERAL) -> list[RobotMove]:
    """Free poses on and beside the person's planned way past where they would touch the obstacle, nearest first.

    The first row stands just clear of the person at the touch, the others :data:`SPACING` apart on along
    their way, broadside across it, one pose at each of ``lateral``'s sideways offsets. The robot seldom
    stands there before the person passes: these are crossings (:func:`crossings`), whose drive puts the
    robot in the person's way early enough for the detour they plan round it to clear the obstacle too.
    """
    if len(danger.path) < 2:
        return []
    route = Polyline.of(danger.path)
    touch = route.arc_length_nearest(danger.point)
    first = touching_distance(scene, danger.person)
    rows = (touch + first + k * SPACING for k in range(BEYOND_ROWS))
    return [
        move
        for distance in rows
        if distance <= route.length
        for move in _broadside(route, distance, danger.obstacle, lateral)
    ]


def _broadside(route: Polyline, distance: float, target: str, lateral: Sequence[float] = LATERAL) -> list[RobotMove]:
    """Poses on and beside ``route`` (``lateral`` metres to its side) at ``distance`` along it, broadside across it."""
    x, y = route.point_at(distance)
    ax, ay = route.point_at(min(distance + 0.05, route.length))
    heading = math.atan2(ay - y, ax - x)
    return [
        RobotMove(target, x - math.sin(heading) * offset, y + math.cos(heading) * offset, heading + math.pi / 2)
        for offset in lateral
    ]


def standoffs(scene: Scene, danger: Danger, obstacle: str) -> list[RobotMove]:
    """Stand-off poses around ``obstacle``, those straight behind and in front of it along the person's way first."""
    dx, dy = travel_direction(danger.path, danger.point)
    shape = scene.obstacle(obstacle).shape

    def key(m: RobotMove) -> tuple[float, float]:
        norm = math.hypot(m.x - shape.x, m.y - shape.y) or 1.0
        along = ((m.x - shape.x) * dx + (m.y - shape.y) * dy) / norm
        return -abs(along), -along

    return sorted(standoff_poses(scene, obstacle), key=key)


def ordered_moves(scene: Scene, danger: Danger, start: Callable[[], float] = lambda: 0.0) -> Iterator[RobotMove]:
    """Every candidate move for ``danger``, likeliest first (see the module documentation), generated lazily,
    each pose once.

    ``start()`` is when the robot would start on the next move yielded, in seconds from the scene's time:
    a move is pruned unless the robot, starting then, can come within :data:`REACH` of it in time.
    """
    return _unseen(_by_kind(scene, danger, start), set())


def _by_kind(scene: Scene, danger: Danger, start: Callable[[], float]) -> Iterator[RobotMove]:
    """:func:`ordered_moves`, kind after kind: a crossing may repeat a stand-off of another kind."""

    def reachable(move: RobotMove, until: float) -> bool:
        return in_reach(scene, move, until - start()) and robot_fits(scene, move)

    deadline = danger.time_to_collision
    # Stand-offs need an object that stays put: a person walking into another person gets path poses first.
    if _stays_put(scene, danger.obstacle):
        yield from (m for m in standoffs(scene, danger, danger.obstacle) if reachable(m, deadline))
    yield from covers_farther_back(scene, danger, start)
    # Seconds the robot has in hand at each path pose: the more, the likelier the person sees it in time.
    slack = [
        (until - drive_time(scene, m.x, m.y), k, m, until) for k, (m, until) in enumerate(path_poses(scene, danger))
    ]
    yield from (m for _, _, m, until in sorted(slack, key=lambda t: (-t[0], t[1])) if reachable(m, until))
    yield from guards(scene, danger, start)
    point = danger.point
    others = sorted(
        other_objects(scene, danger),
        key=lambda o: math.hypot(o.shape.x - point[0], o.shape.y - point[1]),
    )
    yield from crossings(scene, danger, start)  # stand-offs of any object, pruned above or not, crossing in time
    for o in others:
        yield from (m for m in standoffs(scene, danger, o.name) if reachable(m, deadline))


def swerves(scene: Scene, danger: Danger, move: RobotMove, verdict: Verdict) -> list[RobotMove]:
    """The stand-off ``move`` shifted sideways, when its verdict shows the person grazing the obstacle beside it.

    A robot standing past the obstacle makes a person who sees it walk round it; when that detour is too
    tight, they graze the obstacle on the side they pass it. The same stand-off moved towards that side
    widens the detour. The graze may be at any gaze class: at the one found risky, or, when the move
    clears that one, at another, where the person still passes the obstacle on the same side. A move that
    clears the obstacle with a sampled risk of touching it (``verdict.near``) passes too close on that side
    as well. Nothing when nobody grazed the obstacle of the danger, or the touch was head-on.
    """
    touches = [*verdict.falls, *([verdict.near] if verdict.near else [])]
    fall = next((f for f in touches if f.person == danger.person and f.obstacle == danger.obstacle), None)
    if (
        fall is None
        or fall.point is None
        or not _stays_put(scene, danger.obstacle)
        or move not in standoff_poses(scene, danger.obstacle)
    ):
        return []
    dx, dy = travel_direction(danger.path, danger.point)
    shape = scene.body(danger.obstacle).shape
    rx, ry = fall.point[0] - shape.x, fall.point[1] - shape.y
    along, lateral = rx * dx + ry * dy, ry * dx - rx * dy
    if abs(math.atan2(lateral, -along)) < HEAD_ON:
        return []
    side = math.copysign(1.0, lateral)
    shifted = (replace(move, x=move.x - dy * side * s, y=move.y + dx * side * s) for s in SWERVE_SHIFTS)
    return [m for m in shifted if robot_fits(scene, m)]


def candidates(
    scene: Scene,
    dangers: tuple[Danger, ...],
    verdicts: Sequence[Verdict] = (),
    first_start: float = 0.0,
    per_move: float = 0.0,
) -> Iterator[RobotMove]:
    """The dangers' :func:`ordered_moves`, interleaved (most urgent danger first) and without repeats.

    ``verdicts`` are the search's verdicts so far, filled in as it judges: once the first candidate's is
    in, its :func:`swerves` (for the most urgent danger) come next, right after the first candidate when it is
    in before the second is asked for. The k-th
    move yielded (from 1) has the robot starting ``first_start + per_move * k`` seconds after the scene's
    time, as the search judges it; the moves it could not reach in time by then are pruned.
    """
    urgent = sorted(dangers, key=lambda d: d.time_to_collision)
    yielded = 0

    def start() -> float:
        return first_start + per_move * (yielded + 1)

    def in_order() -> Iterator[RobotMove]:
        seen: set[tuple[float, float, float]] = set()
        stream = _unseen(_interleaved([ordered_moves(scene, d, start) for d in urgent]), seen)
        first = next(stream, None)
        if first is None:
            return
        yield first
        if not verdicts:
            second = next(stream, None)
            if second is not None:
                yield second
        if verdicts:
            yield from _unseen(swerves(scene, urgent[0], first, verdicts[0]), seen)
        yield from stream

    for move in in_order():
        yielded += 1
        yield move


def _interleaved(streams: list[Iterator[RobotMove]]) -> Iterator[RobotMove]:
    """The streams' moves taken in turn, one from each, until every stream runs out."""
    while streams:
        for stream in list(streams):
            move = next(stream, None)
            if move is None:
                streams.remove(stream)
                continue
            yield move


def _unseen(moves: Iterable[RobotMove], seen: set[tuple[float, float, float]]) -> Iterator[RobotMove]:
    """The moves whose pose (to the millimetre and milliradian) is not in ``seen`` yet, each added as it passes."""
    for move in moves:
        key = (round(move.x, 3), round(move.y, 3), round(move.heading, 3))
        if key not in seen:
            seen.add(key)
            yield move


def other_objects(scene: Scene, danger: Danger) -> list[Obstacle]:
    """The scene's objects but the walls and the danger's obstacle, in scene order."""
    return [o for o in scene.obstacles if o.kind != WALL_KIND and o.name != danger.obstacle]


def _stays_put(scene: Scene, name: str) -> bool:
    """Whether ``name`` is one of the scene's obstacles (not a person), so that it has stand-offs."""
    return any(o.name == name for o in scene.obstacles)
