"""Algorithm 2's move search: judge the candidates in time, likeliest first, and choose the move to send.

The candidates come from :mod:`agents.caregiving.model.candidates`. The joint imagination in time
(:mod:`agents.caregiving.model.joint`) judges them: :func:`search` judges the candidates one at a
time, each with its robot starting later by the time the search has spent, and stops at the first
safe one, or at the first that saves everyone at the gaze found risky and makes nothing worse at
the others (:class:`NoWorse`). When none does, :func:`choose` may still pick a clear one that
lowers the risk; once one such is in hand, the search judges only :data:`SETTLE_AFTER_CLEAR`
candidates more for a safe one (:class:`Settles`). A :class:`SearchSpec` travels to the
simulator in its wire form, and the :class:`SearchResult` comes back.
"""

from __future__ import annotations

import math
from collections.abc import Callable, Iterable, Iterator, Mapping, Sequence
from dataclasses import dataclass, field, replace
from functools import partial
from itertools import chain, islice
from typing import TYPE_CHECKING, Any

from .candidates import Danger, candidates
from .fields import Fields
from .imagine_reply import Answer, joint_answer
from .imagine_request import MAX_DELAY, JointItem, falling_from_fields, uncertainty_from_fields, uncertainty_to_wire
from .joint import JointImagination, WalkOutcome, walk_from_fields, walk_to_wire
from .robot_moves import RobotMove
from .scene import Scene
from .uncertainty import NO_RISK, Uncertainty
from .verdict import Fall, SearchResult, Verdict
from .world_model import Walk

if TYPE_CHECKING:
    from .judge_ahead import JudgeAhead

#: Candidate moves one search may judge at most.
MAX_MOVES = 256
#: Candidates lent to the helper process at a time (see :mod:`agents.caregiving.model.judge_ahead`).
AHEAD_DEPTH = 2
#: Candidates judged past the first clear move that halves the idle risk before the search settles for the
#: least risky clear move: each one judged sends whichever move is chosen later (see docs/caregiving.md).
SETTLE_AFTER_CLEAR = 3
#: A head start is asked for only when every danger is at least this likely with the robot idle: it is judged
#: harmless given that the person falls anyway, a bet on the likelier world only from one half up.
HEAD_START_RISK = 0.5
#: Sigmas of perception's error in a person's position that the robot keeps clear of them when they cannot
#: keep clear of it themselves (see :class:`RobotMargin`).
MARGIN_SIGMAS = 2.0


@dataclass(frozen=True)
class SearchSpec:
    """What a search must protect: the dangers, every gaze class to imagine their people at, and the bystanders.

    ``gazes`` maps each endangered person to the gaze pitches (one per gaze class) their walk is imagined at;
    ``bystanders`` are the other people's walks, imagined alongside so that a move never trips them: each
    bystander's first walk is their likeliest, in every walk set; a later walk of the same bystander is one
    they may be on instead, imagined in a walk set of its own (see :meth:`walk_sets`).
    ``falling`` names the bystanders who walk into something with the robot as it is (their danger is not
    searched now, say because no move saved them a moment ago), and what they walk into: a move is not
    refused for that same fall, only for one it would cause.
    ``falls_anyway`` pairs a bystander's walk with what they walk into on it with the robot as it is, the
    search finds (see :func:`falls_anyway`): in a walk set where they walk it, a move is not refused for that
    fall either.
    ``current`` is the move the robot is driving now (if any), which it keeps for ``delay`` seconds.
    ``lead`` is a head start the search sent (see :func:`search`), driven for ``lead_for`` seconds after that.
    """

    dangers: tuple[Danger, ...]
    gazes: dict[str, tuple[float, ...]]
    known: dict[str, tuple[str, ...]]
    bystanders: tuple[Walk, ...] = ()
    current: RobotMove | None = None
    delay: float = 0.0
    falling: dict[str, str] = field(default_factory=dict)
    lead: RobotMove | None = None
    lead_for: float = 0.0
    falls_anyway: tuple[tuple[Walk, str], ...] = ()

    def falling_in(self, walks: Iterable[Walk]) -> dict[str, str]:
        """The falls that do not refuse a move in a walk set of ``walks``: ``falling``'s, and ``falls_anyway``'s
        where the bystander walks that walk."""
        on = set(walks)
        return {**self.falling, **{w.person: hit for w, hit in self.falls_anyway if w in on}}

    def letting_dangers_fall(self) -> SearchSpec:
        """The spec with the dangers' own falls let happen too, as they do with the robot idle."""
        return replace(self, falling={**self.falling, **{d.person: d.obstacle for d in self.dangers}})

    def walk_sets(self) -> list[tuple[Walk, ...]]:
        """The sets of walks to imagine each move with: every gaze class of each endangered person in turn, with
        every bystander on their likeliest walk; then each other walk a bystander may be on, in a set of its own
        with the endangered people at the gaze found risky."""
        first = {
            d.person: Walk(d.person, d.target, self.gazes[d.person][0], self.known.get(d.person, ()))
            for d in self.dangers
        }
        likeliest: dict[str, Walk] = {}
        others: list[Walk] = []
        for w in self.bystanders:
            if w.person in likeliest:
                others.append(w)
            else:
                likeliest[w.person] = w
        sets = []
        for d in self.dangers:
            for gaze in self.gazes[d.person][1 if sets else 0 :]:
                walks = dict(first)
                walks[d.person] = Walk(d.person, d.target, gaze, self.known.get(d.person, ()))
                sets.append(tuple(walks.values()) + tuple(likeliest.values()))
        for w in others:
            sets.append(tuple(first.values()) + tuple({**likeliest, w.person: w}.values()))
        return sets

    def items(self, move: RobotMove | None, uncertainty: Uncertainty | None) -> list[JointItem]:
        """The simulator items that judge one move, one per walk set, each ending at the first fall that refuses it
        (``uncertainty`` None: no risk sampled)."""
        return [
            JointItem(
                walks,
                move,
                self.current,
                self.delay,
                uncertainty,
                True,
                self.falling_in(walks),
                self.lead,
                self.lead_for,
            )
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
            "lead": self.lead.to_wire() if self.lead else None,
            "lead_for": self.lead_for,
            "falls_anyway": [{"walk": walk_to_wire(w), "object": hit} for w, hit in self.falls_anyway],
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
        anyway = []
        for fall in f.children("falls_anyway", []):
            walk = walk_from_fields(fall.child("walk"))
            if walk not in bystanders:
                raise fall.fail("walk", "expected one of the bystanders' walks")
            anyway.append((walk, fall.string("object")))
        return cls(
            dangers,
            gazes,
            {p: known_f.strings(p) for p in known_f.keys()},
            bystanders,
            RobotMove.optional_from(f, "current"),
            f.number("delay", 0.0, non_negative=True, at_most=MAX_DELAY),
            falling_from_fields(f.child("falling", {}), {w.person for w in bystanders}),
            RobotMove.optional_from(f, "lead"),
            f.number("lead_for", 0.0, non_negative=True, at_most=MAX_DELAY),
            tuple(anyway),
        )


@dataclass(frozen=True)
class RobotMargin:
    """How near the robot may come to a person while it drives, or stands where they do not know it to be.

    Perception may hold a person up to :data:`MARGIN_SIGMAS` sigmas of their position off, so an imagined
    pass closer than that may be a touch in truth. Someone who knows where the resting robot stands walks
    round it by their own plan, wherever they really are, and is not held to the margin.
    """

    robot: str
    sigma: Mapping[str, float]

    @classmethod
    def of(cls, robot: str | None, uncertainty: Uncertainty) -> RobotMargin | None:
        """The margin of ``robot`` under perception's ``uncertainty``; None for a scene without a robot."""
        return cls(robot, uncertainty.sigma) if robot is not None else None

    def too_close(self, walk: WalkOutcome) -> bool:
        """Whether the walk passes the robot closer than the margin for that person."""
        return walk.robot_clearance < MARGIN_SIGMAS * self.sigma.get(walk.walk.person, 0.0)


def judge(
    move: RobotMove | None,
    answers: list[Answer],
    falling: Mapping[str, str] | SearchSpec | None = None,
    margin: RobotMargin | None = None,
) -> Verdict:
    """Fold a move's answers (one per walk set) into a verdict; the first walk that is not clear says why.

    A fall that ``falling`` names (``{bystander: object}``, or a spec's :meth:`SearchSpec.falling_in` the
    answer's walks) does not refuse the move. With ``margin``, a walk that passes the robot closer than it
    allows refuses the move as a fall into the robot. Given a spec, a sampled risk that is a bystander's
    (someone none of its dangers is about) refuses the move as a fall of theirs: the risk a move may keep is
    the endangered person's, and a bystander's is one it may bring. (Whether the robot as it is brings them
    as much is not asked: the largest sampled risk of a walk set is all an answer holds.)
    """
    endangered = {d.person for d in falling.dangers} if isinstance(falling, SearchSpec) else None
    arrival, risk, worst, refused = None, 0.0, "", ""
    falls: list[Fall] = []
    near: Fall | None = None
    for k, a in enumerate(answers):
        if a.joint is None:
            return Verdict(move, False, 1.0, None, f"not imagined: {a.error}")
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
            falls.append(Fall(k, close.walk.person, margin.robot, None))
            gap = f"{close.robot_clearance * 100:.0f} cm"
            refused = (
                refused
                or f"{close.walk.person} passes {gap} from the robot at gaze {math.degrees(close.walk.gaze):.0f} deg"
            )
            continue
        sampled = a.risk or NO_RISK
        if endangered and sampled.probability > 0.0 and sampled.person not in (None, *endangered):
            falls.append(Fall(k, str(sampled.person), sampled.obstacle, sampled.point))
            refused = refused or (
                f"{sampled.person}, a bystander, may walk into {sampled.obstacle} (sampled risk {sampled.probability:.2f})"
            )
            continue
        if sampled.probability >= risk:
            risk, worst = sampled.probability, sampled.obstacle or ""
            touching = sampled.probability > 0.0 and sampled.person is not None
            near = Fall(k, str(sampled.person), sampled.obstacle, sampled.point) if touching else None
    if falls:
        # A move refused in the first walk set (the gaze class found risky) was not imagined in the others.
        return Verdict(move, False, 1.0 if falls[0].walk_set == 0 else risk, arrival, refused, tuple(falls))
    reason = f"everyone imagined walks clear; sampled risk {risk:.2f}" + (f" ({worst})" if risk > 0 else "")
    return Verdict(move, True, risk, arrival, reason, near=near)


def _excused(falling: Mapping[str, str] | SearchSpec | None, joint: JointImagination) -> Mapping[str, str]:
    """The falls that do not refuse a move in ``joint``'s walk set."""
    if isinstance(falling, SearchSpec):
        return falling.falling_in(w.walk for w in joint.walks)
    return falling or {}


def falls_anyway(spec: SearchSpec, imagine: Imagine, robot: str | None) -> tuple[tuple[Walk, str], ...]:
    """The bystanders who walk into something in the first walk set with the robot as it is, the dangers' and
    ``falling``'s own falls let happen: each one's walk and what they walk into (see :class:`SearchSpec`).

    Such a fall happens whatever the robot does, so it must not refuse every move that saves someone else.
    Walking into the robot is not among them: that one the robot can undo by moving.
    """
    if not spec.bystanders:
        return ()
    let_fall = spec.letting_dangers_fall()
    joint = imagine(replace(let_fall.items(spec.current, None)[0], until_first_fall=False)).joint
    if joint is None:
        return ()
    return tuple(
        (w.walk, w.collision_object)
        for w in joint.walks
        if w.collision_object is not None and w.walk.person not in let_fall.falling and w.collision_object != robot
    )


def lowers_risk(verdict: Verdict, idle_risk: float) -> bool:
    """Whether a move is clear and at least halves ``idle_risk``, the risk the person runs with the robot standing by."""
    return verdict.clear and verdict.risk < idle_risk / 2


def choose(verdicts: list[Verdict], threshold: float, idle_risk: float) -> Verdict | None:
    """The move to send: the first safe one; else the least risky clear one, if it at least halves the idle risk.

    A move that is clear nominally but still carries some sampled risk is better than standing by when the
    person is otherwise likely to fall, and is never sent when it would not clearly lower that likelihood.
    """
    safe = next((v for v in verdicts if v.safe(threshold)), None)
    if safe is not None:
        return safe
    clear = [v for v in verdicts if lowers_risk(v, idle_risk)]
    return min(clear, key=lambda v: v.risk) if clear else None


def standing(verdict: Verdict, robot: str | None) -> tuple[int, float]:
    """How good a move is, lower first: its class, then its sampled risk.

    The classes: clear at every gaze (a safe move is a clear one with a risk under the threshold);
    clear at the gaze found risky only, with falls at others into something other than the robot (as a
    :class:`NoWorse` move); refused at the gaze found risky; last, refused for someone walking into the
    robot (named ``robot``) or getting stuck at any gaze, a fall the robot itself causes.
    """
    if verdict.trips(robot):
        return 3, 1.0
    if verdict.clear:
        return 0, verdict.risk
    if verdict.clear_where_found:
        return 1, verdict.risk
    return 2, 1.0


def holds(under_way: Verdict, threshold: float, robot: str | None) -> bool:
    """Whether the move under way, judged again, still does what a search would settle for, so no search is needed.

    It holds when it is safe, or when it is still clear at the gaze class found risky with a risk under
    ``threshold`` and walks nobody into the robot or leaves them stuck at any gaze: at the other gaze
    classes where someone falls, they fall with the robot carrying on as it is, so it is what
    :class:`NoWorse` accepts of a new candidate. A search started anyway could find a move clear at
    every gaze on this frame's noise, and a robot that switches to it late, on one frame's word, loses
    the time it has spent and turns up somewhere new in the person's view.
    """
    return under_way.clear_where_found and under_way.risk < threshold and not under_way.trips(robot)


def gives_up(under_way: Verdict, failed_before: bool, robot: str | None) -> bool:
    """Whether to look for a move to replace the move under way, which no longer :func:`holds`.

    A move that walks someone into the robot or leaves them stuck is given up at once. Any other only
    when it also failed on the look before (``failed_before``): one frame's belief may refuse a move that
    the next frame's clears again, and a robot that switches on every such frame goes back and forth
    between two poses and reaches neither.
    """
    return failed_before or under_way.trips(robot)


def replaces(new: Verdict, under_way: Verdict, samples: int, robot: str | None) -> bool:
    """Whether ``new`` should replace the move under way, both judged now from the robot's current state.

    Only a move of a better :func:`standing`, or of the same standing with a risk lower by more than the
    sampling error of the risk under way (over ``samples`` sampled worlds), replaces it. Each new frame's
    noise ranks near-equal moves anew (a risk of 0.20 one frame, 0.19 the next), and a robot that switches
    at every ranking gets nowhere, or into the person's way.
    """
    new_class, new_risk = standing(new, robot)
    old_class, old_risk = standing(under_way, robot)
    if new_class != old_class:
        return new_class < old_class
    n = max(samples, 1)
    return new_risk < old_risk - max(math.sqrt(old_risk * (1.0 - old_risk) / n), 1.0 / n)


#: Answers one joint item (see :mod:`agents.caregiving.model.service`); the search's only way to imagine.
Imagine = Callable[[JointItem], Answer]


@dataclass
class NoWorse:
    """Whether a refused move still saves everyone at the gaze found risky, and makes nothing worse elsewhere.

    Such a move is clear in the first walk set (the gaze class the danger was found at), with sampled
    risk under ``threshold``; in every other set where someone still falls, that person falls there with
    the robot carrying on as it is too (into something other than the robot, and not stuck). It saves the
    person if their gaze is the one found risky, and leaves them no worse off if it is another. The robot
    carrying on is imagined once per walk set, when a move first needs it.
    """

    spec: SearchSpec
    imagine: Imagine
    uncertainty: Uncertainty
    threshold: float
    robot: str | None
    #: Called before the robot carrying on is first imagined: the search's spec must know who falls anyway.
    prepare: Callable[[], object] = lambda: None
    _idle: dict[int, Verdict] = field(default_factory=dict)

    def __call__(self, verdict: Verdict) -> bool:
        if verdict.clear or not holds(verdict, self.threshold, self.robot):
            return False
        return self.as_idle(verdict)

    def as_idle(self, verdict: Verdict) -> bool:
        """Whether everyone who falls with the move, in any walk set, falls there with the robot as it is too."""
        return all(any(g.person == f.person for g in self._idle_in(f.walk_set).falls) for f in verdict.falls)

    def harmless(self, verdict: Verdict) -> bool:
        """Whether a move judged at every walk set can be driven without harm: the robot reaches it, it trips
        nobody, and whoever falls with it falls with the robot as it is too (:meth:`as_idle`)."""
        imagined = verdict.clear or bool(verdict.falls)
        return imagined and not verdict.trips(self.robot) and self.as_idle(verdict)

    def _idle_in(self, walk_set: int) -> Verdict:
        if walk_set not in self._idle:
            self.prepare()
            item = self.spec.items(self.spec.current, self.uncertainty)[walk_set]
            margin = RobotMargin.of(self.robot, self.uncertainty)
            self._idle[walk_set] = judge(self.spec.current, [self.imagine(item)], self.spec, margin)
        return self._idle[walk_set]


@dataclass
class Settles:
    """Whether the search may stop at a verdict short of a safe move, told each verdict once, in order.

    It stops at a move :class:`NoWorse` accepts, and ``after_clear`` candidates past the first clear move
    whose risk is under half ``idle_risk`` (one :func:`choose` would send): a search that goes on judging
    for a safe move when none is there sends that clear move later by every candidate it judges.
    """

    no_worse: NoWorse
    idle_risk: float
    after_clear: int
    _judged: int = 0
    _first_clear: int | None = None
    by_no_worse: bool = False
    by_count: bool = False

    def __call__(self, verdict: Verdict) -> bool:
        self._judged += 1
        if self.no_worse(verdict):
            self.by_no_worse = True
            return True
        if self._first_clear is None and lowers_risk(verdict, self.idle_risk):
            self._first_clear = self._judged
        self.by_count = self._first_clear is not None and self._judged - self._first_clear >= self.after_clear
        return self.by_count


def judge_move(
    spec: SearchSpec, move: RobotMove | None, imagine: Imagine, uncertainty: Uncertainty, robot: str | None
) -> Verdict:
    """Judge one move (``None``: braking): the first walk set alone (most fail there), then the others if clear.

    Everyone imagined is held to the :class:`RobotMargin` of ``robot`` (the scene's robot) under ``uncertainty``.
    """
    items = spec.items(move, uncertainty)
    return _judged_in_turn(spec, move, [partial(imagine, item) for item in items], uncertainty, robot)


def _judged_in_turn(
    spec: SearchSpec,
    move: RobotMove | None,
    answers: Sequence[Callable[[], Answer]],
    uncertainty: Uncertainty,
    robot: str | None,
) -> Verdict:
    """:func:`judge_move`, with each walk set's answer got by calling ``answers[k]``, only when it is needed."""
    margin = RobotMargin.of(robot, uncertainty)
    first = [answers[0]()]
    verdict = judge(move, first, spec, margin)
    if not verdict.clear or len(answers) == 1:
        return verdict
    return judge(move, first + [answer() for answer in answers[1:]], spec, margin)


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
    whether anyone else falls, or anyone walks into the robot, before a better move replaces it.
    No risk is sampled: a head start is driven only while the search looks for a safe move.
    ``before`` are answers of the same move judged with fewer falls excused: each one where no fall is
    excused now is the imagination it would be again (it stops at the same fall), and is kept.
    """
    excused = spec.letting_dangers_fall()
    answers = [
        before[k] if k < len(before) and not _excuses_more(before[k], item.falling) else imagine(item)
        for k, item in enumerate(excused.items(move, None))
    ]
    return judge(move, answers, excused, RobotMargin.of(robot, uncertainty)), answers


def _excuses_more(answer: Answer, falling: Mapping[str, str]) -> bool:
    """Whether ``falling`` excuses a fall of ``answer``'s imagination (or it has none to tell)."""
    if answer.joint is None:
        return True
    return any(w.collided and falling.get(w.walk.person) == w.collision_object for w in answer.joint.walks)


def driven_on(
    scene: Scene, spec: SearchSpec, move: RobotMove, lead: Sequence[Answer], uncertainty: Uncertainty
) -> Verdict | None:
    """The verdict :func:`judge_move` gives the head start's own move driven on, read off the head start's answers.

    Driven on, the robot does just what it does in the head start's imagination, and so does everyone:
    the two imaginations part only where the head start lets a danger's own fall happen and goes on, and
    the move's judgement stops (:meth:`JointImagination.stopped_at_first_fall`). The risk is sampled round
    the same walks. None when that cannot be read off (see there).
    """
    answers: list[Callable[[], Answer]] = []
    for a in lead:
        if a.joint is None:
            return None
        excused = _excused(spec, a.joint)
        stopped = a.joint.stopped_at_first_fall(excused)
        if stopped is None:
            return None
        answers.append(partial(joint_answer, scene, stopped, uncertainty, excused))
    return _judged_in_turn(spec, move, answers, uncertainty, scene.robot_name)


def search(
    scene: Scene,
    spec: SearchSpec,
    imagine: Imagine,
    uncertainty: Uncertainty,
    threshold: float,
    max_moves: int,
    idle_risk: float = 1.0,
    judging: float = 0.0,
    moves: Sequence[RobotMove | None] | None = None,
    ahead: JudgeAhead | None = None,
    settle_after_clear: int = SETTLE_AFTER_CLEAR,
    head_start: Callable[[Verdict], None] | None = None,
) -> SearchResult:
    """Algorithm 2's search: judge the candidates one at a time, likeliest first, and stop at the first safe one.

    It stops also at a move that saves everyone at the gaze found risky and makes nothing worse at the others
    (:class:`NoWorse`), and ``settle_after_clear`` candidates past the first clear move that halves
    ``idle_risk`` (:class:`Settles`): judging on for a move safe at every gaze would send any move later.

    Each candidate is imagined with the robot starting ``judging`` seconds later than the one before, since
    the move is sent only once the search has judged it: the k-th candidate (from 1) after
    ``spec.delay + judging * k``. The result holds every verdict and the move to send (see :func:`choose`).
    A bystander's fall that happens with the robot as it is (:func:`falls_anyway`, imagined before any
    candidate, but after a head start that no such fall could refuse is sent) refuses no move; the chosen
    move's reason names it.
    ``moves`` replaces the generated candidates (to judge the move under way again, for instance; ``None``
    among them judges braking to a stop from the robot's current state). With
    ``ahead``, a helper process judges candidates meanwhile (same verdicts, less wall time).

    With ``head_start``, a robot at rest need not stand idle while the search judges: before anything
    else, the first candidate is judged as a head start (:func:`judge_lead`), and when it is
    :meth:`NoWorse.harmless` and another candidate is left to judge, it is handed to ``head_start`` to be
    sent at once. Every candidate is then judged as a switch from it, the robot driving it from its
    command until the candidate's; the first one, the same move driven on, is read off the head start's
    own imagination (:func:`driven_on`) when it can be, and takes no judgement. The head start's
    judgement takes the first slot, sent or not. The result's ``lead`` is that verdict. A head start
    lasts as long as the search: when no candidate is chosen, braking at the search's end is judged the
    same way, and the result's ``halt`` is that verdict if it is harmless too (the robot then brakes;
    otherwise it drives the head start on, which harms nobody). The result's ``judged`` counts the
    slots the search took.
    """
    verdicts: list[Verdict] = []
    generated = candidates(scene, spec.dangers, verdicts, spec.delay, judging)
    pool: Iterator[RobotMove | None] = islice(generated if moves is None else iter(moves), max_moves)
    no_worse = NoWorse(spec, imagine, uncertainty, threshold, scene.robot_name)
    settles = Settles(no_worse, idle_risk, settle_after_clear)
    judging_ = _Judging(scene, spec, imagine, uncertainty, judging, ahead, no_worse)
    no_worse.prepare = judging_.know_falls_anyway
    if head_start is not None and moves is None and spec.current is None:
        judging_.send_lead = head_start
    judging_.in_order(pool, threshold, verdicts, settles)
    spec = judging_.spec
    chosen = choose(verdicts, threshold, idle_risk)
    if chosen is not None and settles.by_count and not chosen.safe(threshold):
        chosen = _noted(verdicts, chosen, f"no safe move within {settle_after_clear} candidates past a clear one")
    if chosen is None and settles.by_no_worse:
        last = verdicts[-1]
        chosen = verdicts[-1] = replace(
            last, reason=f"clear at the gaze found risky; at another, {last.reason}, as with the robot as it is"
        )
    if chosen is not None and spec.falls_anyway:
        anyway = ", ".join(f"{w.person} into {hit}" for w, hit in spec.falls_anyway)
        chosen = _noted(verdicts, chosen, f"falls with the robot as it is too: {anyway}")
    slots = len(verdicts) + judging_.lead_judged - (judging_.read_off is not None)
    sets_off = None
    if chosen is not None:
        at = judging_.spec_at(next(k for k, v in enumerate(verdicts, start=1) if v is chosen))
        sets_off = at.delay + at.lead_for
    if judging_.lead is None:
        return SearchResult(chosen, tuple(verdicts), judged=slots, sets_off=sets_off)
    halt = None
    if chosen is None:
        braking, _ = judging_.judged_as_lead(lambda: judging_.spec_at(len(verdicts) + 1), None)
        halt = braking if no_worse.harmless(braking) else None
        slots += 1
    return SearchResult(chosen, tuple(verdicts), judging_.lead, halt, slots, sets_off)


def _noted(verdicts: list[Verdict], chosen: Verdict, note: str) -> Verdict:
    """``chosen``, one of ``verdicts``, with ``note`` added to its reason, there too."""
    k = next(k for k, v in enumerate(verdicts) if v is chosen)
    verdicts[k] = replace(chosen, reason=f"{chosen.reason}; {note}")
    return verdicts[k]


@dataclass(eq=False)  # compared by identity: it tags the moves it lends the helper
class _Judging:
    """Judges a search's candidates, the k-th (from 1) with the robot starting ``judging * k`` seconds later
    (one judgement more after a head start's).

    Alone, each candidate is judged in turn. With ``ahead``, once the first candidate has failed, the
    helper is lent the next candidates not yet handed out, :data:`AHEAD_DEPTH` at a time, while this
    process judges the others; the verdicts are gathered in candidate order, so the search sees what it
    would see alone. After a head start is sent, the first candidate's verdict is read off the head start's
    (:func:`driven_on`: a harmless head start imagined everyone, and nobody got stuck), so the helper is lent
    the candidates after the second at once when it fails.
    """

    scene: Scene
    spec: SearchSpec  # with its falls_anyway once know_falls_anyway has run
    imagine: Imagine
    uncertainty: Uncertainty
    judging: float
    ahead: JudgeAhead | None
    no_worse: NoWorse  # tells a harmless head start, and shares the spec
    send_lead: Callable[[Verdict], None] | None = None  # sends a head start, until one is decided on
    knows_falls_anyway: bool = False
    lead: Verdict | None = None  # the head start sent
    lead_judged: bool = False  # whether a head start was judged (sent or not): it took the first slot
    read_off: Verdict | None = None  # the first candidate's verdict, read off the head start's (see driven_on)

    def spec_at(self, k: int) -> SearchSpec:
        """The spec the k-th candidate is judged with: the robot switching to it once the judgements before it,
        and its own, are done.

        After a head start is sent, the robot drives it from its command until the switch.
        """
        if self.lead is None:
            return replace(self.spec, delay=self.spec.delay + self.judging * (k + self.lead_judged))
        judgements = k - (self.read_off is not None)  # the k-th's and those before it; one read off takes none
        return replace(self.lead_sent(), lead=self.lead.move, lead_for=self.judging * judgements)

    def lead_sent(self) -> SearchSpec:
        """The spec with the robot starting when a head start is sent: after its own judgement."""
        return replace(self.spec, delay=self.spec.delay + self.judging)

    def know_falls_anyway(self) -> bool:
        """Imagine :func:`falls_anyway` into the spec, once; whether it found any.

        Only when a verdict needs it (:meth:`settled`): most searches meet no fall it could excuse, and it
        imagines everyone to the end of their walk.
        """
        if not self.knows_falls_anyway:
            self.knows_falls_anyway = True
            self.spec = replace(self.spec, falls_anyway=falls_anyway(self.spec, self.imagine, self.scene.robot_name))
            self.no_worse.spec = self.spec
        return bool(self.spec.falls_anyway)

    def consider_head_start(self, first: RobotMove | None) -> None:
        """Judge the first candidate as a head start, and send it if it is harmless.

        It is judged before :func:`falls_anyway` is imagined, which only excuses falls: a head start clear
        without it is clear with it, on the same imaginations (no risk is sampled), and goes out one
        imagination sooner. One that is not clear is judged again if some bystander does fall anyway.
        """
        send, self.send_lead = self.send_lead, None
        if send is None or first is None:
            return
        self.lead_judged = True
        lead, answers = self.judged_as_lead(self.lead_sent, first)
        if self.no_worse.harmless(lead):
            self.lead = lead
            send(lead)
            knew = self.knows_falls_anyway
            read_off = driven_on(self.scene, self.spec, first, answers, self.uncertainty)
            if read_off is not None and self.excusable(read_off, knew) and self.know_falls_anyway():
                read_off = driven_on(self.scene, self.spec, first, answers, self.uncertainty)
            self.read_off = read_off

    def judged_as_lead(self, at: Callable[[], SearchSpec], move: RobotMove | None) -> tuple[Verdict, list[Answer]]:
        """:func:`judge_lead` of ``move`` (``None``: braking) with the spec ``at()`` gives; one refused before who
        falls anyway was known is judged again once it is, if someone does (only the walk sets whose imagination
        ended in a fall now excused are imagined anew). The robot as it is only ever excuses falls, so one clear
        without it is clear with it, on the same imaginations."""
        knew = self.knows_falls_anyway
        robot = self.scene.robot_name
        verdict, answers = judge_lead(at(), move, self.imagine, self.uncertainty, robot)
        if not knew and not verdict.clear and self.know_falls_anyway():
            verdict, answers = judge_lead(at(), move, self.imagine, self.uncertainty, robot, answers)
        return verdict, answers

    def excusable(self, verdict: Verdict, knew: bool) -> bool:
        """Whether ``verdict``, judged without knowing who falls anyway (``knew`` false), was refused for
        something that knowing it could excuse: a bystander's fall into something other than the robot, or a
        bystander's sampled risk."""
        if knew:
            return False
        endangered = {d.person for d in self.spec.dangers} | set(self.spec.falling)
        robot = self.scene.robot_name
        return any(f.obstacle is not None and f.obstacle != robot and f.person not in endangered for f in verdict.falls)

    def settled(self, k: int, move: RobotMove | None, verdict: Verdict, knew: bool) -> Verdict:
        """The k-th candidate's verdict as a search that knew who falls anyway from the start gives it.

        One judged without knowing differs only where a bystander's fall or sampled risk refused it (a fall
        that happens anyway neither ends an imagination nor counts in the sampled risk): then the robot as it
        is is imagined, and if someone does fall anyway, the candidate is judged again.
        """
        if self.excusable(verdict, knew) and self.know_falls_anyway():
            return self.judged_at(k, move)
        return verdict

    def judged_at(self, k: int, move: RobotMove | None) -> Verdict:
        """:func:`judge_move` of ``move`` as the k-th candidate, with the spec as the search knows it now."""
        return judge_move(self.spec_at(k), move, self.imagine, self.uncertainty, self.scene.robot_name)

    def in_order(
        self,
        moves: Iterator[RobotMove | None],
        threshold: float,
        verdicts: list[Verdict],
        settles: Callable[[Verdict], bool],
    ) -> None:
        """Fill ``verdicts`` in candidate order, up to the first safe one or one that ``settles`` the search.

        ``moves`` may read ``verdicts`` as they come in.
        """
        opening = list(islice(enumerate(moves, start=1), 2)) if self.send_lead is not None else []
        if len(opening) == 2:  # a head start is for a search that judges on past its first candidate
            self.consider_head_start(opening[0][1])
        positions = chain(opening, enumerate(moves, start=len(opening) + 1))
        judged: dict[int, Verdict] = {}
        # The candidates the helper is judging, by position, and whether who falls anyway was known when lent.
        lent: dict[int, tuple[RobotMove | None, bool]] = {}

        def exchange(wait: bool = False) -> None:
            """Take the helper's verdicts, then lend it the next candidates up to :data:`AHEAD_DEPTH`.

            Nothing more is lent before the first candidate has failed: most searches end with it, and a
            helper judging the next ones meanwhile would only take the second core from the rest of the stack.
            """
            ahead = self.ahead
            if ahead is None:
                return
            for (owner, k), verdict in ahead.answers(wait):
                if owner is self:
                    move, knew = lent.pop(k)
                    judged[k] = self.settled(k, move, verdict, knew) if verdict else self.judge(k, move)
            while verdicts and ahead.outstanding < AHEAD_DEPTH:
                k, move = next(positions, (0, None))
                if k == 0:
                    return
                if not ahead.lend((self, k), self.scene, self.spec_at(k), move, self.uncertainty):
                    judged[k] = self.judge(k, move)
                    return
                lent[k] = (move, self.knows_falls_anyway)

        def gather() -> bool:
            """Move the judged prefix into ``verdicts``; True once it ends with one that settles the search."""
            while (k := len(verdicts) + 1) in judged:
                verdicts.append(judged.pop(k))
                if verdicts[-1].safe(threshold) or settles(verdicts[-1]):
                    return True
            return False

        mine = next(positions, None)  # the next candidate this process judges: always the first not lent
        while mine is not None:
            judged[mine[0]] = self.judge(*mine)
            exchange()
            if gather():
                return
            mine = next(positions, None)
            exchange()
        while lent:
            exchange(wait=True)
            if gather():
                return
        gather()

    def judge(self, k: int, move: RobotMove | None) -> Verdict:
        if k == 1 and self.read_off is not None:
            return self.read_off
        knew = self.knows_falls_anyway
        return self.settled(k, move, self.judged_at(k, move), knew)


@dataclass(frozen=True)
class SearchItem:
    """Run the whole search for ``spec`` in the simulator (judging ``moves`` instead of the candidates, if given).

    A ``None`` among ``moves`` (null on the wire) is the robot braking to a stop. With ``head_start``, the
    asker takes a head start while the search judges on (see :func:`search`), sent by the simulator as it is found.
    """

    spec: SearchSpec
    uncertainty: Uncertainty
    threshold: float
    max_moves: int
    idle_risk: float = 1.0
    judging: float = 0.0
    moves: tuple[RobotMove | None, ...] | None = None
    head_start: bool = False

    def to_wire(self) -> dict[str, Any]:
        """``{"kind": "search", "spec", "uncertainty", "threshold", "max_moves", "idle_risk", "judging",
        "head_start", "moves"?}``."""
        out: dict[str, Any] = {
            "kind": "search",
            "spec": self.spec.to_wire(),
            "uncertainty": uncertainty_to_wire(self.uncertainty),
            "threshold": self.threshold,
            "max_moves": self.max_moves,
            "idle_risk": self.idle_risk,
            "judging": self.judging,
            "head_start": self.head_start,
        }
        if self.moves is not None:
            out["moves"] = [m.to_wire() if m is not None else None for m in self.moves]
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
            tuple(RobotMove.from_fields(m) if m is not None else None for m in f.children_or_null("moves"))
            if f.has("moves")
            else None,
            f.boolean("head_start", False),
        )

    def run(
        self,
        scene: Scene,
        imagine: Imagine,
        ahead: JudgeAhead | None = None,
        head_start: Callable[[Verdict], None] | None = None,
    ) -> SearchResult:
        """:func:`search` with this item's parameters; a head start goes to ``head_start`` if the item asks for one."""
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
            head_start=head_start if self.head_start else None,
        )
