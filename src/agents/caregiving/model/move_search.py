"""Candidate robot moves for Algorithm 2, likeliest first, with cheap pruning.

A :class:`Danger` is a person's risky imagined walk: their path, the object (or person) they
would hit, where and when. The robot's moves are ``move_to`` a pose:

* **stand-offs** (the paper's ``move_to(object)``): poses around an object, a
  small gap from its boundary, facing it; around the obstacle itself they cover it;
* **path poses**: free poses on the person's predicted path, or beside it,
  between the person and the obstacle: in front of the obstacle on the person's
  side, and farther back along the path, where the person will see the robot sooner.

:func:`ordered_moves` yields them lazily in the order the search tries them:
the stand-offs around the obstacle, straight behind it and straight in front
of it along the person's way first (a robot there is in view, and the detour
around it also clears the obstacle; over 50 dangers of four scenarios the first
of them removed the danger in 18 of the 28 the search could remove); then the
path poses, those where the robot has the most seconds in hand first; then the
stand-offs around the other objects by distance to the collision point. Two
cheap tests prune before any imagination: the robot must fit at the pose, and a
straight drive (the travel-time lower bound, from the robot's current speed)
must come within :data:`REACH` of it before the person passes it (path poses)
or before the collision (stand-offs). The joint imagination in time
(:mod:`agents.caregiving.model.joint`) judges the rest: :func:`search` judges
the candidates one at a time, each with its robot starting later by the time
the search has spent, and stops at the first safe one. A :class:`SearchSpec`
travels to the simulator in its wire form, and the :class:`SearchResult` comes back.
"""

from __future__ import annotations

import math
from collections.abc import Callable, Iterator, Mapping, Sequence
from dataclasses import dataclass, field, replace
from itertools import islice
from typing import TYPE_CHECKING, Any

import numpy as np

from .fields import Fields
from .geometry import Polyline, bounding_radius
from .imagine_reply import Answer
from .imagine_request import MAX_DELAY, JointItem, falling_from_fields, uncertainty_from_fields, uncertainty_to_wire
from .joint import walk_from_fields, walk_to_wire
from .robot_moves import RobotMove, robot_fits, standoff_poses, travel_time
from .scene import Scene
from .uncertainty import NO_RISK, Uncertainty
from .verdict import SearchResult, Verdict
from .visibility import WALL_KIND
from .world_model import Walk

if TYPE_CHECKING:
    from .judge_ahead import JudgeAhead

#: Lateral offsets (m) of path poses from the person's path, on the path first.
LATERAL = (0.0, 0.3, -0.3)
#: Spacing (m) of path poses along the path.
SPACING = 0.25
#: A pose the robot cannot come this close to (m) before the person passes it is pruned: a robot
#: farther off when the person goes by is beside their way, not in it.
REACH = 1.0
#: Candidate moves one search may judge at most.
MAX_MOVES = 256
#: Candidates lent to the helper process at a time (see :mod:`agents.caregiving.model.judge_ahead`).
AHEAD_DEPTH = 2


@dataclass(frozen=True)
class Danger:
    """A person's risky walk: path from where they are, the obstacle, where and in how many seconds they hit it."""

    person: str
    target: str
    path: tuple[tuple[float, float], ...]
    point: tuple[float, float]
    obstacle: str
    time_to_collision: float

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


def drive_time(scene: Scene, x: float, y: float, within: float = 0.0) -> float:
    """Lower bound on the robot's time to come ``within`` metres of (x, y): a straight drive from its current speed."""
    robot = scene.robot
    assert robot is not None
    gap = max(math.hypot(x - robot.x, y - robot.y) - within, 0.0)
    return travel_time(gap, robot.max_speed, robot.max_accel, robot.speed)


def in_reach(scene: Scene, move: RobotMove, until: float) -> bool:
    """Whether a straight drive can bring the robot within :data:`REACH` of the move's pose before ``until`` s."""
    return drive_time(scene, move.x, move.y, REACH) < until


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
    nearest = person.radius + max(robot.length, robot.width) / 2 + 0.2
    distance = min(danger.time_to_collision * person.speed, route.length) - clearance
    while distance > nearest:
        x, y = route.point_at(distance)
        ax, ay = route.point_at(min(distance + 0.05, route.length))
        heading = math.atan2(ay - y, ax - x)
        for offset in LATERAL:
            px, py = x - math.sin(heading) * offset, y + math.cos(heading) * offset
            yield RobotMove(danger.obstacle, px, py, heading + math.pi / 2), distance / person.speed
        distance -= SPACING


def standoffs(scene: Scene, danger: Danger, obstacle: str) -> list[RobotMove]:
    """Stand-off poses around ``obstacle``, those straight behind and in front of it along the person's way first."""
    dx, dy = travel_direction(danger.path, danger.point)
    shape = scene.obstacle(obstacle).shape

    def key(m: RobotMove) -> tuple[float, float]:
        norm = math.hypot(m.x - shape.x, m.y - shape.y) or 1.0
        along = ((m.x - shape.x) * dx + (m.y - shape.y) * dy) / norm
        return -abs(along), -along

    return sorted(standoff_poses(scene, obstacle), key=key)


def ordered_moves(scene: Scene, danger: Danger) -> Iterator[RobotMove]:
    """Every candidate move for ``danger``, likeliest first (see the module documentation), generated lazily."""
    deadline = danger.time_to_collision
    # Stand-offs need an object that stays put: a person walking into another person gets path poses first.
    if any(o.name == danger.obstacle for o in scene.obstacles):
        yield from (
            m
            for m in standoffs(scene, danger, danger.obstacle)
            if in_reach(scene, m, deadline) and robot_fits(scene, m)
        )
    # Seconds the robot has in hand at each path pose: the more, the likelier the person sees it in time.
    slack = [
        (until - drive_time(scene, m.x, m.y), k, m)
        for k, (m, until) in enumerate(path_poses(scene, danger))
        if in_reach(scene, m, until)
    ]
    yield from (m for _, _, m in sorted(slack, key=lambda t: (-t[0], t[1])) if robot_fits(scene, m))
    point = danger.point
    others = sorted(
        (o for o in scene.obstacles if o.kind != WALL_KIND and o.name != danger.obstacle),
        key=lambda o: math.hypot(o.shape.x - point[0], o.shape.y - point[1]),
    )
    for o in others:
        yield from (
            m for m in standoffs(scene, danger, o.name) if in_reach(scene, m, deadline) and robot_fits(scene, m)
        )


@dataclass(frozen=True)
class SearchSpec:
    """What a search must protect: the dangers, every gaze class to imagine their people at, and the bystanders.

    ``gazes`` maps each endangered person to the gaze pitches (one per gaze class) their walk is imagined at;
    ``bystanders`` are the other people's likeliest walks, imagined alongside so that a move never trips them.
    ``falling`` names the bystanders who walk into something with the robot as it is (their danger is not
    searched now, say because no move saved them a moment ago), and what they walk into: a move is not
    refused for that same fall, only for one it would cause.
    ``current`` is the move the robot is driving now (if any), which it keeps for ``delay`` seconds.
    """

    dangers: tuple[Danger, ...]
    gazes: dict[str, tuple[float, ...]]
    known: dict[str, tuple[str, ...]]
    bystanders: tuple[Walk, ...] = ()
    current: RobotMove | None = None
    delay: float = 0.0
    falling: dict[str, str] = field(default_factory=dict)

    def walk_sets(self) -> list[tuple[Walk, ...]]:
        """The sets of walks to imagine each move with: every gaze class of each endangered person in turn."""
        first = {
            d.person: Walk(d.person, d.target, self.gazes[d.person][0], self.known.get(d.person, ()))
            for d in self.dangers
        }
        sets = []
        for d in self.dangers:
            for gaze in self.gazes[d.person][1 if sets else 0 :]:
                walks = dict(first)
                walks[d.person] = Walk(d.person, d.target, gaze, self.known.get(d.person, ()))
                sets.append(tuple(walks.values()) + self.bystanders)
        return sets

    def items(self, move: RobotMove | None, uncertainty: Uncertainty) -> list[JointItem]:
        """The simulator items that judge one move, one per walk set, each ending at the first fall that refuses it."""
        return [
            JointItem(walks, move, self.current, self.delay, uncertainty, True, self.falling)
            for walks in self.walk_sets()
        ]

    def to_wire(self) -> dict[str, Any]:
        """A msgpack-friendly dict."""
        return {
            "dangers": [d.to_wire() for d in self.dangers],
            "gazes": {p: list(g) for p, g in self.gazes.items()},
            "known": {p: list(k) for p, k in self.known.items()},
            "bystanders": [walk_to_wire(w) for w in self.bystanders],
            "current": self.current.to_wire() if self.current else None,
            "delay": self.delay,
            "falling": dict(self.falling),
        }

    @classmethod
    def from_fields(cls, f: Fields) -> SearchSpec:
        """Parse :meth:`to_wire` output nested in a larger message; every endangered person needs a gaze."""
        dangers = tuple(Danger.from_fields(d) for d in f.children("dangers"))
        if not dangers:
            raise f.fail("dangers", "expected at least one danger")
        gazes_f, known_f = f.child("gazes"), f.child("known", {})
        gazes: dict[str, tuple[float, ...]] = {}
        for d in dangers:
            values = gazes_f.numbers(d.person)
            if not values or not all(-math.pi / 2 <= g <= math.pi / 2 for g in values):
                raise gazes_f.fail(d.person, "expected one or more pitches in [-pi/2, pi/2] rad")
            gazes[d.person] = values
        bystanders = tuple(walk_from_fields(w) for w in f.children("bystanders", []))
        return cls(
            dangers,
            gazes,
            {p: known_f.strings(p) for p in known_f.keys()},
            bystanders,
            RobotMove.optional_from(f, "current"),
            f.number("delay", 0.0, non_negative=True, at_most=MAX_DELAY),
            falling_from_fields(f.child("falling", {}), {w.person for w in bystanders}),
        )


def judge(move: RobotMove | None, answers: list[Answer], falling: Mapping[str, str] | None = None) -> Verdict:
    """Fold a move's answers (one per walk set) into a verdict; the first walk that is not clear says why.

    A fall that ``falling`` names (``{bystander: object}``, see :class:`SearchSpec`) does not refuse the move.
    """
    falling = falling or {}
    arrival, risk, worst = None, 0.0, ""
    for a in answers:
        if a.joint is None:
            return Verdict(move, False, 1.0, None, f"not imagined: {a.error}")
        if not a.joint.robot_reachable:
            return Verdict(move, False, 1.0, None, "the robot cannot reach the pose")
        for w in a.joint.walks:
            if not w.fine_given(falling):
                what = f"into {w.collision_object}" if w.collided else "stuck"
                return Verdict(
                    move, False, 1.0, None, f"{w.walk.person} walks {what} at gaze {math.degrees(w.walk.gaze):.0f} deg"
                )
        sampled = a.risk or NO_RISK
        if sampled.probability >= risk:
            risk, worst = sampled.probability, sampled.obstacle or ""
        arrival = a.joint.robot_arrival if arrival is None else arrival
    reason = f"everyone imagined walks clear; sampled risk {risk:.2f}" + (f" ({worst})" if risk > 0 else "")
    return Verdict(move, True, risk, arrival, reason)


def candidates(scene: Scene, dangers: tuple[Danger, ...]) -> Iterator[RobotMove]:
    """The dangers' :func:`ordered_moves`, interleaved (most urgent danger first) and without repeats."""
    streams = [ordered_moves(scene, d) for d in sorted(dangers, key=lambda d: d.time_to_collision)]
    seen: set[tuple[float, float, float]] = set()
    while streams:
        for stream in list(streams):
            move = next(stream, None)
            if move is None:
                streams.remove(stream)
                continue
            key = (round(move.x, 3), round(move.y, 3), round(move.heading, 3))
            if key not in seen:
                seen.add(key)
                yield move


def choose(verdicts: list[Verdict], threshold: float, idle_risk: float) -> Verdict | None:
    """The move to send: the first safe one; else the least risky clear one, if it at least halves the idle risk.

    A move that is clear nominally but still carries some sampled risk is better than standing by when the
    person is otherwise likely to fall, and is never sent when it would not clearly lower that likelihood.
    """
    safe = next((v for v in verdicts if v.safe(threshold)), None)
    if safe is not None:
        return safe
    clear = [v for v in verdicts if v.clear and v.risk < idle_risk / 2]
    return min(clear, key=lambda v: v.risk) if clear else None


#: Answers one joint item (see :mod:`agents.caregiving.model.service`); the search's only way to imagine.
Imagine = Callable[[JointItem], Answer]


def judge_move(spec: SearchSpec, move: RobotMove, imagine: Imagine, uncertainty: Uncertainty) -> Verdict:
    """Judge one move: the first walk set alone (most candidates fail there), then the others if it is clear."""
    items = spec.items(move, uncertainty)
    first = [imagine(items[0])]
    verdict = judge(move, first, spec.falling)
    if not verdict.clear or len(items) == 1:
        return verdict
    return judge(move, first + [imagine(item) for item in items[1:]], spec.falling)


def search(
    scene: Scene,
    spec: SearchSpec,
    imagine: Imagine,
    uncertainty: Uncertainty,
    threshold: float,
    max_moves: int,
    idle_risk: float = 1.0,
    judging: float = 0.0,
    moves: Sequence[RobotMove] | None = None,
    ahead: JudgeAhead | None = None,
) -> SearchResult:
    """Algorithm 2's search: judge the candidates one at a time, likeliest first, and stop at the first safe one.

    Each candidate is imagined with the robot starting ``judging`` seconds later than the one before, since
    the move is sent only once the search has judged it: the k-th candidate (from 1) after
    ``spec.delay + judging * k``. The result holds every verdict and the move to send (see :func:`choose`).
    ``moves`` replaces the generated candidates (to judge the move under way again, for instance). With
    ``ahead``, a helper process judges candidates meanwhile (same verdicts, less wall time).
    """
    pool = islice(candidates(scene, spec.dangers) if moves is None else iter(moves), max_moves)
    verdicts = _Judging(scene, spec, imagine, uncertainty, judging, ahead).in_order(pool, threshold)
    return SearchResult(choose(verdicts, threshold, idle_risk), tuple(verdicts))


@dataclass(eq=False)  # compared by identity: it tags the moves it lends the helper
class _Judging:
    """Judges a search's candidates, the k-th (from 1) with the robot starting ``judging * k`` seconds later.

    Alone, each candidate is judged in turn. With ``ahead``, once the first candidate has failed, the
    helper is lent the next candidates not yet handed out, :data:`AHEAD_DEPTH` at a time, while this
    process judges the others; the verdicts are gathered in candidate order, so the search sees what it
    would see alone.
    """

    scene: Scene
    spec: SearchSpec
    imagine: Imagine
    uncertainty: Uncertainty
    judging: float
    ahead: JudgeAhead | None

    def spec_at(self, k: int) -> SearchSpec:
        return replace(self.spec, delay=self.spec.delay + self.judging * k)

    def in_order(self, moves: Iterator[RobotMove], threshold: float) -> list[Verdict]:
        """The verdicts in candidate order, up to the first safe one."""
        positions = enumerate(moves, start=1)
        verdicts: list[Verdict] = []
        judged: dict[int, Verdict] = {}
        lent: dict[int, RobotMove] = {}  # the candidates the helper is judging, by position

        def exchange(wait: bool = False) -> None:
            """Take the helper's verdicts, then lend it the next candidates up to :data:`AHEAD_DEPTH`.

            Nothing is lent before the first candidate has failed: most searches end with it, and a helper
            judging the next ones meanwhile would only take the second core from the rest of the stack.
            """
            ahead = self.ahead
            if ahead is None:
                return
            for (owner, k), verdict in ahead.answers(wait):
                if owner is self:
                    move = lent.pop(k)
                    judged[k] = verdict or self.judge(k, move)
            while verdicts and ahead.outstanding < AHEAD_DEPTH:
                k, move = next(positions, (0, None))
                if move is None:
                    return
                if not ahead.lend((self, k), self.scene, self.spec_at(k), move, self.uncertainty):
                    judged[k] = self.judge(k, move)
                    return
                lent[k] = move

        def gather() -> bool:
            """Move the judged prefix into ``verdicts``; True once it ends with a safe verdict."""
            while (k := len(verdicts) + 1) in judged:
                verdicts.append(judged.pop(k))
                if verdicts[-1].safe(threshold):
                    return True
            return False

        mine = next(positions, None)  # the next candidate this process judges: always the first not lent
        while mine is not None:
            judged[mine[0]] = self.judge(*mine)
            exchange()
            if gather():
                return verdicts
            mine = next(positions, None)
            exchange()
        while lent:
            exchange(wait=True)
            if gather():
                return verdicts
        gather()
        return verdicts

    def judge(self, k: int, move: RobotMove) -> Verdict:
        return judge_move(self.spec_at(k), move, self.imagine, self.uncertainty)


@dataclass(frozen=True)
class SearchItem:
    """Run the whole search for ``spec`` in the simulator (judging ``moves`` instead of the candidates, if given)."""

    spec: SearchSpec
    uncertainty: Uncertainty
    threshold: float
    max_moves: int
    idle_risk: float = 1.0
    judging: float = 0.0
    moves: tuple[RobotMove, ...] | None = None

    def to_wire(self) -> dict[str, Any]:
        """``{"kind": "search", "spec", "uncertainty", "threshold", "max_moves", "idle_risk", "judging", "moves"?}``."""
        out: dict[str, Any] = {
            "kind": "search",
            "spec": self.spec.to_wire(),
            "uncertainty": uncertainty_to_wire(self.uncertainty),
            "threshold": self.threshold,
            "max_moves": self.max_moves,
            "idle_risk": self.idle_risk,
            "judging": self.judging,
        }
        if self.moves is not None:
            out["moves"] = [m.to_wire() for m in self.moves]
        return out

    @classmethod
    def from_fields(cls, f: Fields) -> SearchItem:
        """Parse :meth:`to_wire` output: every field is checked before the first candidate is imagined."""
        uncertainty = uncertainty_from_fields(f.child("uncertainty"))
        return cls(
            SearchSpec.from_fields(f.child("spec")),
            uncertainty,
            f.number("threshold", positive=True, at_most=1.0),
            int(f.number("max_moves", positive=True, at_most=MAX_MOVES)),
            f.number("idle_risk", 1.0, non_negative=True, at_most=1.0),
            f.number("judging", 0.0, non_negative=True, at_most=MAX_DELAY),
            tuple(RobotMove.from_fields(m) for m in f.children("moves")) if f.has("moves") else None,
        )

    def run(self, scene: Scene, imagine: Imagine, ahead: JudgeAhead | None = None) -> SearchResult:
        """:func:`search` with this item's parameters."""
        return search(
            scene,
            self.spec,
            imagine,
            self.uncertainty,
            self.threshold,
            self.max_moves,
            self.idle_risk,
            self.judging,
            self.moves,
            ahead,
        )
