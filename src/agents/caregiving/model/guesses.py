"""Algorithm 1's guesses: each person's imagined walks folded into one intention per target.

A person item's answer is one imagined walk to one target at one gaze class, with its sampled collision
risk. :func:`guesses` keeps, for a walking person, the walks whose start matches their heading (the
heading gate), and folds each target's gaze classes into a :class:`Guess` (:func:`summarise`): risky
when the nominal walk of any class collides or its sampled probability reaches the threshold, reported
at its earliest danger.
"""

from __future__ import annotations

import math
from collections.abc import Mapping, Sequence
from dataclasses import dataclass

import numpy as np

from .geometry import aabb, resample_by_distance, signed_distance
from .imagine import Imagination
from .imagine_reply import Answer
from .scene import Obstacle, PersonState
from .uncertainty import NO_RISK
from .visibility import candidate_targets, off_heading, wrap_angle
from .world_model import Walk

#: Metres along an imagined path where the direction it sets off in is measured.
HEADING_PROBE = 0.4
#: Speed (m/s) above which a person walks: their walks are held to the heading gate.
WALKING_SPEED = 0.2
#: How far (degrees) a walking person's heading may be from where a walk sets off for it to be theirs.
HEADING_GATE_DEG = 20.0
#: How many sigmas of a tracked speed's error must stay under the walking speed for the track to tell
#: standing from walking: a young track's few detections cannot, and its person is taken to walk.
SPEED_SIGMAS = 2.0
#: Metres kept clear of anything by a walk straight ahead where it ends (the walking planner's margin and a
#: grid cell's reach beyond it, so that its end is a free cell).
AHEAD_CLEARANCE = 0.15
#: Metres between the points along a heading checked for a walk straight ahead.
AHEAD_STEP = 0.05


def aside_of(gate_deg: float) -> float:
    """The bearing (rad) past which a walk is plainly not the one a walking person is on: twice the gate."""
    return 2 * math.radians(gate_deg)


#: The bearing aside for the default gate.
ASIDE = aside_of(HEADING_GATE_DEG)


@dataclass(frozen=True)
class Walking:
    """When a person counts as walking (over ``speed`` m/s), and the bearing (rad) past which a target lies
    plainly aside of their heading (``aside``: twice Algorithm 1's heading gate)."""

    speed: float = WALKING_SPEED
    aside: float = ASIDE

    def walks(self, speed: float, speed_sigma: float = 0.0) -> bool:
        """Whether someone tracked at ``speed`` m/s, with an error of ``speed_sigma`` m/s, may be walking: over
        :attr:`speed`, or tracked too briefly to tell (:data:`SPEED_SIGMAS` of the error reach :attr:`speed`).
        Over its first few detections the fitted speed of someone walking may read near nought, and of someone
        standing, a walker's pace."""
        return speed > self.speed or SPEED_SIGMAS * speed_sigma >= self.speed


#: The intention and action agents' default :class:`Walking`.
DEFAULT_WALKING = Walking()


@dataclass(frozen=True)
class Guess:
    """The summary of one (person, target) intention over its gaze classes.

    ``nominal`` tells whether the risk comes from a nominal walk that collides (else only from the sampled
    worlds, or there is none).
    """

    person: str
    target: str
    risky: bool
    probability: float
    path: tuple[tuple[float, float], ...]
    gaze: float
    ttc: float | None
    point: tuple[float, float] | None
    obstacle: str | None
    nominal: bool = False


def walk_of(answer: Answer) -> Imagination:
    """The imagined walk of a person item's answer."""
    if answer.imagination is None:
        raise ValueError(f"not a person's imagined walk: {answer.error or answer}")
    return answer.imagination


def heading_error(path: Sequence[tuple[float, float]], heading: float) -> float:
    """Angle between a heading and the direction the path sets off in (radians)."""
    if len(path) < 2:
        return 0.0
    x, y = resample_by_distance(path, [HEADING_PROBE])[0]
    direction = math.atan2(y - path[0][1], x - path[0][0])
    return abs(wrap_angle(direction - heading))


def summarise(person: str, target: str, answers: Sequence[tuple[Answer, float]], threshold: float) -> Guess:
    """Fold the gaze classes of one intention (reachable walks): risky if any class is; report the earliest danger.

    Each answer comes with its ``advance`` (seconds of the walk behind the person, for one reused from the
    cache), which its times are brought forward by.
    """
    worst: Guess | None = None
    first: Guess | None = None
    for a, advance in answers:
        r, risk = walk_of(a), a.risk or NO_RISK
        nominal = r.collided
        risky = nominal or risk.probability >= threshold
        times = [max(t - advance, 0.0) for t in (r.collision_time, risk.time) if t is not None]
        ttc = min(times) if risky and times else None
        point = (r.collision_point if nominal else risk.point) if risky else None
        obstacle = (r.collision_object if nominal else risk.obstacle) if risky else None
        probability = max(risk.probability, float(nominal))
        g = Guess(person, target, risky, probability, r.path, r.gaze, ttc, point, obstacle, nominal)
        first = first or g
        if risky and (worst is None or (ttc or math.inf) < (worst.ttc or math.inf)):
            worst = g
    if first is None:
        raise ValueError(f"no imagined walk of {person} to {target} to summarise")
    return worst or first


def guesses(
    walks: Sequence[Walk],
    answers: Sequence[tuple[Answer, float]],
    headings: Mapping[str, float],
    gate: float,
    threshold: float,
) -> list[Guess]:
    """One guess per (person, target) with a reachable walk, from each walk's answer and its ``advance``.

    ``headings`` holds the heading of each person walking (radians); their walks that set off more than
    ``gate`` radians from it are not their intention. A target left with no walk gets no guess.
    """
    grouped: dict[tuple[str, str], list[tuple[Answer, float]]] = {}
    for walk, (answer, advance) in zip(walks, answers, strict=True):
        if answer.imagination is not None and answer.imagination.reachable:
            grouped.setdefault((walk.person, walk.target), []).append((answer, advance))
    out = []
    for (person, target), kept in grouped.items():
        if person in headings:
            kept = [x for x in kept if heading_error(walk_of(x[0]).path, headings[person]) <= gate]
        if kept:
            out.append(summarise(person, target, kept, threshold))
    return out


def unguessed_walks(person: PersonState, obstacles: Sequence[Obstacle], aside: float = ASIDE) -> tuple[Walk, ...]:
    """The walks a walking person may be on before any is guessed, at the middle of their gaze range: to every
    target in their view not plainly aside (its centre's bearing from their heading within ``aside`` rad), the
    one most nearly ahead first; with none, to the one most nearly ahead; with no target in view at all,
    straight ahead (:func:`straight_ahead`)."""
    gaze = (person.gaze_min + person.gaze_max) / 2
    ahead = sorted(((off_heading(person, o), o) for o in candidate_targets(person, obstacles)), key=lambda x: x[0])
    if not ahead:
        return (Walk(person.name, "", gaze, toward=straight_ahead(person, obstacles)),)
    kept = [o for off, o in ahead if off <= aside] or [o for _, o in ahead[:1]]
    return tuple(Walk(person.name, o.name, gaze) for o in kept)


def straight_ahead(person: PersonState, obstacles: Sequence[Obstacle]) -> tuple[float, float]:
    """Where someone walking with no target known is imagined to go: along their heading to the last point
    before anything (a wall included) comes within :data:`AHEAD_CLEARANCE` of their body; where they stand
    when something is that close already."""
    if not obstacles:
        return person.x, person.y
    reach = max(
        math.hypot(max(abs(x0 - person.x), abs(x1 - person.x)), max(abs(y0 - person.y), abs(y1 - person.y)))
        for x0, y0, x1, y1 in (aabb(o.shape) for o in obstacles)
    )
    steps = np.arange(AHEAD_STEP, reach + AHEAD_STEP, AHEAD_STEP)
    points = np.column_stack((person.x + steps * math.cos(person.heading), person.y + steps * math.sin(person.heading)))
    room = np.min([signed_distance(o.shape, points) for o in obstacles], axis=0)
    blocked = np.flatnonzero(room < person.radius + AHEAD_CLEARANCE)
    last = (int(blocked[0]) if blocked.size else len(steps)) - 1
    return (person.x, person.y) if last < 0 else (float(points[last, 0]), float(points[last, 1]))
