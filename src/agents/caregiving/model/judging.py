"""Judging one robot move: its joint imaginations folded into a :class:`~agents.caregiving.model.verdict.Verdict`.

:func:`judge_move` imagines a move at every walk set of a :class:`SearchSpec` (the first alone
when it already refuses the move), :func:`judge_lead` judges it as a head start, with the
dangers' own falls let happen, and :func:`driven_on` reads a head start's own move off its
imaginations. :func:`judge` folds the answers: a walk that is not clear refuses the move, and so
does a pass closer to the robot than the :class:`RobotMargin` or a bystander's sampled risk. A move
clear in the first walk set is judged again with the falls it lets happen just missed
(:func:`_harmless_if_missed`).
"""

from __future__ import annotations

import math
from collections.abc import Callable, Mapping, Sequence
from dataclasses import dataclass, replace
from functools import partial

from .imagine_reply import Answer, joint_answer
from .imagine_request import JointItem
from .joint import JointImagination, WalkOutcome, raised_risks, walk_risks
from .robot_moves import RobotMove
from .scene import Scene
from .search_spec import SearchSpec
from .uncertainty import NO_RISK, Risk, Uncertainty
from .verdict import Fall, Verdict
from .world_model import Passing, Walk

#: Sigmas of perception's error in a person's position that the robot keeps clear of them when they cannot
#: keep clear of it themselves (see :class:`RobotMargin`).
MARGIN_SIGMAS = 2.0

#: Answers one joint item (see :mod:`agents.caregiving.model.service`); the search's only way to imagine.
Imagine = Callable[[JointItem], Answer]


@dataclass(frozen=True)
class RobotMargin:
    """How near the robot may come to a person while it drives, or stands where they do not know it to be.

    Perception may hold a person up to :data:`MARGIN_SIGMAS` sigmas of their position off, so an imagined
    pass closer than that may be a touch in truth. Someone who knows where the resting robot stands walks
    round it by their own plan, wherever they really are, and is not held to the margin. ``floor`` is the
    least the robot keeps from anyone, whatever perception's error: a move made for no danger (see
    :attr:`SearchSpec.keep_clear`) has no reason to pass near anyone.
    """

    robot: str
    sigma: Mapping[str, float]
    floor: float = 0.0
    size_error: float = 0.0

    @classmethod
    def of(cls, robot: str | None, uncertainty: Uncertainty, spec: SearchSpec | None = None) -> RobotMargin | None:
        """The margin of ``robot`` under perception's ``uncertainty`` (and ``spec``'s floor); None for a scene
        without a robot."""
        floor = spec.keep_clear if spec is not None else 0.0
        return cls(robot, uncertainty.sigma, floor, uncertainty.size_error) if robot is not None else None

    def error(self, person: str, obstacle: str, size: float = 0.0) -> float:
        """How far off perception may hold ``person`` from ``obstacle``: the margin's sigmas of both positions'
        errors, and, for an obstacle of bounding radius ``size``, how far inside the outline believed its true
        one may lie (held up to ``size_error`` too large)."""
        shrink = size * self.size_error / (1.0 + self.size_error)
        return MARGIN_SIGMAS * math.hypot(self.sigma.get(person, 0.0), self.sigma.get(obstacle, 0.0)) + shrink

    def too_close(self, walk: WalkOutcome) -> bool:
        """Whether the walk passes the robot closer than the margin for that person."""
        return walk.robot_clearance < max(MARGIN_SIGMAS * self.sigma.get(walk.walk.person, 0.0), self.floor)


def judge(
    move: RobotMove | None,
    answers: list[Answer],
    falling: Mapping[str, str] | SearchSpec | None = None,
    margin: RobotMargin | None = None,
) -> Verdict:
    """Fold a move's answers (one per walk set) into a verdict; the first walk that is not clear says why.

    A fall that ``falling`` names (``{bystander: object}``, or a spec's :meth:`SearchSpec.falling_in` the
    answer's walks) does not refuse the move. With ``margin``, a walk that passes the robot closer than it
    allows refuses the move as a fall into the robot. Given a spec, a bystander's sampled risk (someone none of
    its dangers is about) above their risk with the robot as it is refuses the move as a fall of theirs (see
    :func:`_bystanders_risk`): the risk a move may keep is the endangered person's, and a bystander's is one
    it may bring.
    """
    arrival, risk, worst, refused = None, 0.0, "", ""
    falls: list[Fall] = []
    near: Fall | None = None
    by_person: list[Mapping[str, Risk] | None] = []
    for k, a in enumerate(answers):
        if a.joint is None:
            return Verdict(move, False, 1.0, None, f"not imagined: {a.error}")
        by_person.append(a.risks)
        if not a.joint.robot_reachable:
            return Verdict(move, False, 1.0, None, "the robot cannot reach the pose")
        arrival = a.joint.robot_arrival if arrival is None else arrival
        excused = _excused(falling, a.joint)
        w = next((w for w in a.joint.walks if not w.fine_given(excused)), None)
        if w is not None:
            falls.append(Fall(k, w.walk.person, w.collision_object if w.collided else None, w.collision_point))
            what = f"into {w.collision_object}" if w.collided else "stuck"
            refused = refused or f"{w.walk.person} walks {what} at gaze {math.degrees(w.walk.gaze):.0f} deg"
            continue
        if margin is not None and (close := next((w for w in a.joint.walks if margin.too_close(w)), None)):
            falls.append(Fall(k, close.walk.person, margin.robot, None, close_pass=True))
            gap = f"{close.robot_clearance * 100:.0f} cm"
            refused = (
                refused
                or f"{close.walk.person} passes {gap} from the robot at gaze {math.degrees(close.walk.gaze):.0f} deg"
            )
            continue
        brought = _bystanders_risk(a, falling) if isinstance(falling, SearchSpec) else None
        if brought is not None:
            falls.append(Fall(k, str(brought.person), brought.obstacle, brought.point))
            refused = refused or (
                f"{brought.person}, a bystander, may walk into {brought.obstacle} (sampled risk {brought.probability:.2f})"
            )
            continue
        sampled = a.risk or NO_RISK
        if sampled.probability >= risk:
            risk, worst = sampled.probability, sampled.obstacle or ""
            touching = sampled.probability > 0.0 and sampled.person is not None
            near = Fall(k, str(sampled.person), sampled.obstacle, sampled.point) if touching else None
    if falls:
        # A move refused in the first walk set (the gaze class found risky) was not imagined in the others.
        return Verdict(
            move,
            False,
            1.0 if falls[0].walk_set == 0 else risk,
            arrival,
            refused,
            tuple(falls),
            sampled=tuple(by_person),
        )
    reason = f"everyone imagined walks clear; sampled risk {risk:.2f}" + (f" ({worst})" if risk > 0 else "")
    return Verdict(move, True, risk, arrival, reason, near=near, sampled=tuple(by_person))


def _bystanders_risk(answer: Answer, spec: SearchSpec) -> Risk | None:
    """The likeliest sampled risk in ``answer`` that the move brings a bystander (someone none of ``spec``'s dangers
    is about), above their risk with the robot as it is; None if it brings none.

    Every walk's risk is looked at, not only the answer's worst: a bystander's risk below the endangered
    person's is brought all the same. An answer read off the wire holds its worst alone (its ``risks`` are not
    sent), and that one is looked at.
    """
    assert answer.joint is not None
    endangered = {d.person for d in spec.dangers}
    anyway = spec.anyway_in(w.walk for w in answer.joint.walks)
    worst = {answer.risk.person: answer.risk} if answer.risk is not None and answer.risk.person is not None else {}
    risks = answer.risks if answer.risks is not None else worst
    brought = [r for r in raised_risks(risks, anyway) if r.probability > 0.0 and r.person not in (None, *endangered)]
    return max(brought, key=lambda r: r.probability, default=None)


def _excused(falling: Mapping[str, str] | SearchSpec | None, joint: JointImagination) -> Mapping[str, str]:
    """The falls that do not refuse a move in ``joint``'s walk set."""
    if isinstance(falling, SearchSpec):
        return falling.falling_in(w.walk for w in joint.walks)
    return falling or {}


def as_it_is(spec: SearchSpec, imagine: Imagine, scene: Scene, uncertainty: Uncertainty) -> SearchSpec:
    """``spec`` told what befalls the bystanders with the robot as it is, the dangers' and ``falling``'s own falls
    let happen: on each walk a bystander may be on, what they walk into (``falls_anyway``), or else their
    sampled risk under ``uncertainty`` (``risks_anyway``, those over zero).

    Such a fall happens whatever the robot does, so it must not refuse every move that saves someone else,
    and such a risk refuses only a move that raises it. Walking into the robot is not among the falls: that
    one the robot can undo by moving. The first walk set tells each bystander's likeliest walk; each walk set
    that brings a bystander's other walk is imagined for that walk.
    """
    if not spec.bystanders:
        return spec
    let_fall = spec.letting_dangers_fall()
    bystanders = {w.person for w in spec.bystanders} - set(let_fall.falling)
    told: set[Walk] = set()
    falls: list[tuple[Walk, str]] = []
    risks: list[tuple[Walk, float]] = []
    for item in let_fall.items(spec.current, None):
        new = {w for w in item.walks if w.person in bystanders} - told
        joint = imagine(replace(item, until_first_fall=False)).joint if new else None
        if joint is None:
            continue
        told |= new
        outcomes = [w for w in joint.walks if w.walk in new]
        falls += [
            (w.walk, w.collision_object)
            for w in outcomes
            if w.collision_object is not None and w.collision_object != scene.robot_name
        ]
        walking = {w.walk.person: w.walk for w in outcomes if not w.collided}
        sampled = walk_risks(scene, joint, uncertainty, {w.walk.person for w in joint.walks} - set(walking))
        risks += [(walking[p], r.probability) for p, r in sampled.items() if r.probability > 0.0]
    return replace(spec, falls_anyway=tuple(falls), risks_anyway=tuple(risks))


def judge_move(
    spec: SearchSpec, move: RobotMove | None, imagine: Imagine, uncertainty: Uncertainty, robot: str | None
) -> Verdict:
    """Judge one move (``None``: braking): the first walk set alone (most fail there), then the others if clear.

    Everyone imagined is held to the :class:`RobotMargin` of ``robot`` (the scene's robot) under ``uncertainty``.
    """
    items = spec.items(move, uncertainty)
    answers = [partial(imagine, item) for item in items]
    return _judged_in_turn(spec, move, answers, Misses(items[0], imagine), uncertainty, robot)


#: Metres by which a person imagined just missing what they were let fall into misses it with the robot as it is.
MISS_BY = 0.01


@dataclass(frozen=True)
class Misses:
    """A move's first walk set (``item``) imagined again to the end, no risk sampled, with some of the people it
    lets fall passing what they fall into (see :class:`Passing`): with the move, or with the robot as it is."""

    item: JointItem
    imagine: Imagine

    def with_move(self, passing: Mapping[str, Passing]) -> JointImagination | None:
        """The move imagined with ``passing``."""
        return self._to_the_end(self.item, passing)

    def robot_as_it_is(self, passing: Mapping[str, Passing]) -> JointImagination | None:
        """The robot going on with the move under way (or resting), imagined with ``passing``.

        The robot going on as it is drives the same whatever the delay, so the item is asked at none: every
        candidate of a search that lets the same people fall asks the same one (see :func:`sharing_as_it_is`).
        """
        as_it_is = replace(self.item, move=self.item.current, lead=None, lead_for=0.0, delay=0.0)
        return self._to_the_end(as_it_is, passing)

    def _to_the_end(self, item: JointItem, passing: Mapping[str, Passing]) -> JointImagination | None:
        return self.imagine(replace(item, until_first_fall=False, uncertainty=None, passing=passing)).joint


def sharing_as_it_is(imagine: Imagine) -> Imagine:
    """``imagine``, answering from memory an imagination of the robot as it is run to the end with no risk
    sampled (:meth:`Misses.robot_as_it_is`) that it has answered before: an answer is a function of its item,
    and a search's candidates each ask the same one when they let the same people fall."""
    answered: dict[tuple[object, ...], Answer] = {}

    def answer(item: JointItem) -> Answer:
        if item.uncertainty is not None or item.until_first_fall or item.move != item.current or item.lead is not None:
            return imagine(item)
        key = (
            item.walks,
            item.move,
            item.delay,
            *(tuple(sorted(m.items())) for m in (item.falling, item.anyway, item.passing)),
        )
        if key not in answered:
            answered[key] = imagine(item)
        return answered[key]

    return answer


def _judged_in_turn(
    spec: SearchSpec,
    move: RobotMove | None,
    answers: Sequence[Callable[[], Answer]],
    misses: Misses,
    uncertainty: Uncertainty,
    robot: str | None,
) -> Verdict:
    """:func:`judge_move`, with each walk set's answer got by calling ``answers[k]``, only when it is needed.

    A move clear in the first walk set is then held to :func:`_harmless_if_missed` (a search may settle for
    one that is clear there and fails only at other gaze classes).
    """
    margin = RobotMargin.of(robot, uncertainty, spec)
    first = [answers[0]()]
    verdict = judge(move, first, spec, margin)
    if not verdict.clear:
        return verdict
    if len(answers) > 1:
        verdict = judge(move, first + [answer() for answer in answers[1:]], spec, margin)
    return verdict if margin is None else _harmless_if_missed(verdict, first[0], spec, misses, margin)


def _harmless_if_missed(
    verdict: Verdict, first: Answer, spec: SearchSpec, misses: Misses, margin: RobotMargin
) -> Verdict:
    """``verdict`` of a move clear in the first walk set, refused if someone it lets fall there would fall with it
    had they just missed that fall instead, or anyone would then walk into the robot.

    A fall let happen (a bystander's that happens anyway, another danger's, or a danger's own where braking
    is judged) is a belief, and perception
    may hold the person and the object a few centimetres off. Someone who, walking on through it with the
    robot as it is, goes no deeper into it than the ``margin`` allows may really pass it: they are imagined
    with the move as in the nearest world where they do, missing it by :data:`MISS_BY` with the robot as it
    is. There, the move must not walk them into it or anything else, nor anyone into the robot.
    """
    assert first.joint is not None
    excused = _excused(spec, first.joint)
    let_fall = {
        w.walk.person: w.collision_object
        for w in first.joint.walks
        if w.collision_object is not None and excused.get(w.walk.person) == w.collision_object
    }
    could_miss = margin.size_error > 0.0 or any(margin.error(person, obstacle) for person, obstacle in let_fall.items())
    if not let_fall or not could_miss:
        return verdict  # nobody it lets fall can be held off by enough to miss
    unimagined = replace(verdict, clear=False, risk=1.0, reason="not imagined missing the falls it lets happen")
    through = misses.robot_as_it_is({person: Passing(obstacle) for person, obstacle in let_fall.items()})
    if through is None:
        return unimagined
    grazing = {
        w.walk.person: Passing(let_fall[w.walk.person], max(-depth, 0.0) + MISS_BY)
        for w in through.walks
        if w.walk.person in let_fall
        and (depth := w.passed_clearance) is not None
        and -depth <= margin.error(w.walk.person, let_fall[w.walk.person], w.passed_size or 0.0)
    }
    if not grazing:
        return verdict
    missed = misses.with_move(grazing)
    if missed is None:
        return unimagined
    hit = next(
        (w for w in missed.walks if w.collision_object == margin.robot or w.collided and w.walk.person in grazing),
        None,
    )
    if hit is None:
        return verdict
    missing = " and ".join(f"{person} just misses {p.obstacle}" for person, p in grazing.items())
    return replace(
        verdict,
        clear=False,
        risk=1.0,
        reason=f"{hit.walk.person} walks into {hit.collision_object} where {missing}",
        falls=(Fall(0, hit.walk.person, hit.collision_object, hit.collision_point, made_worse=True),),
        near=None,
    )


def judge_lead(
    spec: SearchSpec,
    move: RobotMove | None,
    imagine: Imagine,
    uncertainty: Uncertainty,
    robot: str | None,
    before: Sequence[Answer] = (),
) -> tuple[Verdict, list[Answer]]:
    """Judge ``move`` as a head start (or, ``None``, braking at its end): at every walk set, the dangers' own
    falls let happen. Returns the verdict and the answers, one per walk set.

    The falls the dangers foresee happen with the robot idle too; what matters of a head start is
    whether anyone else falls, or anyone walks into the robot, before a better move replaces it. A clear
    one is held to :func:`_harmless_if_missed`: someone whose fall was a false alarm walks on past it,
    towards wherever the head start (or braking) has put the robot.
    No risk is sampled: a head start is driven only while the search looks for a safe move.
    ``before`` are answers of the same move judged with fewer falls excused: each one where no fall is
    excused now is the imagination it would be again (it stops at the same fall), and is kept.
    """
    excused = spec.letting_dangers_fall()
    items = excused.items(move, None)
    answers = [
        before[k] if k < len(before) and not _excuses_more(before[k], item.falling) else imagine(item)
        for k, item in enumerate(items)
    ]
    margin = RobotMargin.of(robot, uncertainty, spec)
    verdict = judge(move, answers, excused, margin)
    if verdict.clear and margin is not None:
        verdict = _harmless_if_missed(verdict, answers[0], excused, Misses(items[0], imagine), margin)
    return verdict, answers


def _excuses_more(answer: Answer, falling: Mapping[str, str]) -> bool:
    """Whether ``falling`` excuses a fall of ``answer``'s imagination (or it has none to tell)."""
    if answer.joint is None:
        return True
    return any(w.collided and falling.get(w.walk.person) == w.collision_object for w in answer.joint.walks)


def driven_on(
    scene: Scene, spec: SearchSpec, move: RobotMove, lead: Sequence[Answer], imagine: Imagine, uncertainty: Uncertainty
) -> Verdict | None:
    """The verdict :func:`judge_move` gives the head start's own move driven on, read off the head start's answers.

    Driven on, the robot does just what it does in the head start's imagination, and so does everyone:
    the two imaginations part only where the head start lets a danger's own fall happen and goes on, and
    the move's judgement stops (:meth:`JointImagination.stopped_at_first_fall`). The risk is sampled round
    the same walks. None when that cannot be read off (see there). ``spec`` has the robot set off on
    ``move`` when the head start was sent; ``imagine`` imagines the falls let happen just missed, when
    the move is clear (see :func:`_harmless_if_missed`).
    """
    answers: list[Callable[[], Answer]] = []
    for a in lead:
        if a.joint is None:
            return None
        excused = _excused(spec, a.joint)
        stopped = a.joint.stopped_at_first_fall(excused)
        if stopped is None:
            return None
        anyway = spec.anyway_in(w.walk for w in a.joint.walks)
        answers.append(partial(joint_answer, scene, stopped, uncertainty, excused, anyway))
    misses = Misses(spec.items(move, None)[0], imagine)
    return _judged_in_turn(spec, move, answers, misses, uncertainty, scene.robot_name)
