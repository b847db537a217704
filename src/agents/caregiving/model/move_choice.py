"""Which judged move Algorithm 2 sends, keeps or replaces, and when a search may stop short of a safe one.

:func:`choose` picks the move to send among a search's verdicts; :func:`standing` ranks moves,
:func:`holds`, :func:`gives_up` and :func:`replaces` rule on the move under way judged again;
:class:`NoWorse` and :class:`Settles` tell the search when to stop short of a move safe at
every gaze class.
"""

from __future__ import annotations

import math
from collections.abc import Callable
from dataclasses import dataclass, field, replace

from .judging import Imagine, RobotMargin, judge
from .search_spec import SearchSpec
from .uncertainty import Uncertainty
from .verdict import Fall, Verdict

#: The share of sampled worlds in which a move may walk someone into something that, in the same world, they pass
#: clear of with the robot as it is (see :meth:`NoWorse.worsened`): one world in 64, sampling's own grain.
MADE_WORSE = 1 / 64

#: Candidates judged past the first clear move that halves the idle risk before the search settles for the
#: least risky clear move: each one judged sends whichever move is chosen later (see docs/caregiving.md).
SETTLE_AFTER_CLEAR = 3


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

    A move that walks someone into the robot or leaves them stuck at the gaze class found risky is given
    up at once. Any other only when it also failed on the look before (``failed_before``): one frame's
    belief may refuse a move that the next frame's clears again, and a robot that switches on every such
    frame goes back and forth between two poses and reaches neither. That holds too for a walk into the
    robot at another gaze class: which class the person is at is what the belief knows least, and a
    robot that brakes or turns away on one frame's word leaves the person it was saving to fall. And for
    a pass within the margin round the robot at the gaze class found risky, where no touch was imagined:
    a pass of a few centimetres either side of the margin is what one frame's belief of the person's
    position tells least.
    """
    return failed_before or under_way.trips_where_found(robot)


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

    def as_idle(self, verdict: Verdict, made_worse_too: bool = False) -> bool:
        """Whether everyone who falls with the move, in any walk set, falls there with the robot as it is too (a fall
        :attr:`~agents.caregiving.model.verdict.Fall.made_worse` never does, unless ``made_worse_too``: then only
        who falls at the belief's centre counts)."""
        return all(
            (made_worse_too or not f.made_worse) and any(g.person == f.person for g in self._idle_in(f.walk_set).falls)
            for f in verdict.falls
        )

    def harmless(self, verdict: Verdict, made_worse_too: bool = False) -> bool:
        """Whether a move judged at every walk set can be driven without harm: the robot reaches it, it trips
        nobody, and whoever falls with it falls with the robot as it is too (:meth:`as_idle`; with
        ``made_worse_too``, harmless where the falls it lets happen do happen)."""
        imagined = verdict.clear or bool(verdict.falls)
        return imagined and not verdict.trips(self.robot) and self.as_idle(verdict, made_worse_too)

    def worsened(self, verdict: Verdict) -> Verdict:
        """``verdict``, refused if its move brings someone a fall the robot as it is does not: in more than
        :data:`MADE_WORSE` of the sampled worlds, they walk into something they pass clear of in the same world
        with the robot as it is.

        A move's sampled risk may be lower than the robot's as it is and still lie in other worlds: the person,
        walking round the robot, passes the obstacle on its other side, and perception's belief cannot tell
        which side they truly have room on. Only walk sets where everyone walks clear with the robot as it is,
        at the belief's centre, are compared: where someone falls there, the move is judged by whether it
        saves them.
        """
        if not verdict.clear or verdict.risk == 0.0:
            return verdict
        allowed = MADE_WORSE * max(self.uncertainty.samples, 1)
        for k, sampled in enumerate(verdict.sampled):
            if not sampled or all(r.worlds.bit_count() <= allowed for r in sampled.values()):
                continue  # too few falls to be worse in too many worlds: the robot as it is need not be imagined
            idle = self._idle_in(k).sampled
            as_it_is = idle[0] if idle else None
            if as_it_is is None:
                continue
            for person, risk in sampled.items():
                kept_clear = as_it_is[person].worlds if person in as_it_is else 0
                worse = (risk.worlds & ~kept_clear).bit_count()
                if worse > allowed:
                    return replace(
                        verdict,
                        clear=False,
                        risk=1.0 if k == 0 else verdict.risk,
                        reason=f"{person} may walk into {risk.obstacle} in {worse} of {self.uncertainty.samples} "
                        "sampled worlds where the robot as it is keeps them clear",
                        falls=(Fall(k, person, risk.obstacle, risk.point, made_worse=True),),
                        near=None,
                    )
        return verdict

    def _idle_in(self, walk_set: int) -> Verdict:
        if walk_set not in self._idle:
            self.prepare()
            item = self.spec.items(self.spec.current, self.uncertainty)[walk_set]
            margin = RobotMargin.of(self.robot, self.uncertainty, self.spec)
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
