"""What a move search must protect, and the walk sets every move is imagined with.

A :class:`SearchSpec` names the dangers (each endangered person's risky walk), the gaze
classes to imagine them at, the bystanders walking alongside, and the robot's state (the
move under way, a head start sent). It travels to the simulator in its wire form
(:mod:`agents.caregiving.model.move_search`), and :meth:`SearchSpec.items` turns one move into
the simulator items that judge it.
"""

from __future__ import annotations

import math
from collections.abc import Iterable
from dataclasses import dataclass, field, replace
from typing import Any, TypeVar

from .candidates import Danger
from .fields import Fields
from .imagine_request import MAX_DELAY, JointItem, falling_from_fields
from .joint import optional_pose, walk_from_fields, walk_to_wire
from .robot_moves import RobotMove
from .scene import Pose
from .uncertainty import Uncertainty
from .world_model import Walk

T = TypeVar("T")

#: Metres: the most a spec may ask the robot to keep from anyone (a room's width).
MAX_KEEP_CLEAR = 5.0


@dataclass(frozen=True)
class SearchSpec:
    """What a search must protect: the dangers, every gaze class to imagine their people at, and the bystanders.

    A spec with no danger judges moves made for another reason (going to someone who has fallen) with the
    bystanders alone: a move must trip none of them, nor raise their risk.

    ``gazes`` maps each endangered person to the gaze pitches (one per gaze class) their walk is imagined at;
    ``bystanders`` are the other people's walks, imagined alongside so that a move never trips them: each
    bystander's first walk is their likeliest, in every walk set; a later walk of the same bystander is one
    they may be on instead, imagined in a walk set of its own (see :meth:`walk_sets`).
    ``falling`` names the bystanders who walk into something with the robot as it is (their danger is not
    searched now, say because no move saved them a moment ago), and what they walk into: a move is not
    refused for that same fall, only for one it would cause. It may name a danger too, with its own
    obstacle: its fall is then let happen (see :meth:`letting_dangers_fall`).
    ``falls_anyway`` pairs a bystander's walk with what they walk into on it with the robot as it is, the
    search finds (see :func:`~agents.caregiving.model.judging.as_it_is`): in a walk set where they walk it, a move is not refused for that
    fall either.
    ``risks_anyway`` pairs a bystander's walk with its sampled risk with the robot as it is (see
    :func:`~agents.caregiving.model.judging.as_it_is`): in a walk set where they walk it, their risk
    refuses a move only where the move raises it.
    ``current`` is the move the robot is driving now (if any), which it keeps for ``delay`` seconds.
    ``lead`` is a head start the search sent (see :func:`~agents.caregiving.model.move_search.search`), driven for ``lead_for`` seconds after that.
    ``keep_clear`` is the least the robot keeps from anyone while it drives (see
    :class:`~agents.caregiving.model.judging.RobotMargin`): a move made for no danger gives way widely.
    ``robot_at`` is where each endangered person who knows the robot remembers it (see :class:`Walk`).
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
    risks_anyway: tuple[tuple[Walk, float], ...] = ()
    keep_clear: float = 0.0
    robot_at: dict[str, Pose] = field(default_factory=dict)

    @property
    def sets_off(self) -> float:
        """When the robot sets off on the move this spec judges, in seconds after the scene: ``delay`` on, and
        ``lead_for`` more when it drives a head start first."""
        return self.delay + self.lead_for

    def falling_in(self, walks: Iterable[Walk]) -> dict[str, str]:
        """The falls that do not refuse a move in a walk set of ``walks``: ``falling``'s, and ``falls_anyway``'s
        where the bystander walks that walk."""
        return {**self.falling, **_by_person(self.falls_anyway, walks)}

    def anyway_in(self, walks: Iterable[Walk]) -> dict[str, float]:
        """The bystanders' sampled risks with the robot as it is, in a walk set of ``walks``."""
        return _by_person(self.risks_anyway, walks)

    def alone(self, danger: Danger) -> SearchSpec:
        """The spec protecting ``danger`` alone: the other endangered people walk on beside them as bystanders, on
        the walk found risky and with the robot where they remember it, their own falls let happen (no move here
        saves them, but none may trip them another way or walk them into the robot)."""
        others = [d for d in self.dangers if d is not danger]
        mine = danger.person
        return replace(
            self,
            dangers=(danger,),
            gazes={mine: self.gazes[mine]},
            bystanders=tuple(self._walk(d) for d in others) + self.bystanders,
            falling=self._letting_fall(others),
            robot_at={p: pose for p, pose in self.robot_at.items() if p == mine},
        )

    def letting_dangers_fall(self) -> SearchSpec:
        """The spec with the dangers' own falls let happen too, as they do with the robot idle."""
        return replace(self, falling=self._letting_fall(self.dangers))

    def _letting_fall(self, dangers: Iterable[Danger]) -> dict[str, str]:
        """``falling`` with the own falls of ``dangers`` let happen too."""
        return {**self.falling, **{d.person: d.obstacle for d in dangers}}

    def _walk(self, danger: Danger, gaze: float | None = None) -> Walk:
        """``danger``'s person on their walk at ``gaze`` (by default the gaze class found risky)."""
        pitch = self.gazes[danger.person][0] if gaze is None else gaze
        known = self.known.get(danger.person, ())
        return Walk(danger.person, danger.target, pitch, known, self.robot_at.get(danger.person))

    def walk_sets(self) -> list[tuple[Walk, ...]]:
        """The sets of walks to imagine each move with: every gaze class of each endangered person in turn, with
        every bystander on their likeliest walk; then each other walk a bystander may be on, in a set of its own
        with the endangered people at the gaze found risky."""
        first = {d.person: self._walk(d) for d in self.dangers}
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
                walks[d.person] = self._walk(d, gaze)
                sets.append(tuple(walks.values()) + tuple(likeliest.values()))
        if not self.dangers and likeliest:
            sets.append(tuple(likeliest.values()))  # no danger (the robot going to someone): the walkers alone
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
                self.anyway_in(walks),
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
            "risks_anyway": [{"walk": walk_to_wire(w), "risk": risk} for w, risk in self.risks_anyway],
            "keep_clear": self.keep_clear,
            "robot_at": {p: list(pose) for p, pose in self.robot_at.items()},
        }

    @classmethod
    def from_fields(cls, f: Fields) -> SearchSpec:
        """Parse :meth:`to_wire` output nested in a larger message; every endangered person needs a gaze."""
        dangers = tuple(Danger.from_fields(d) for d in f.children("dangers"))
        gazes_f, known_f = f.child("gazes"), f.child("known", {})
        gazes: dict[str, tuple[float, ...]] = {}
        for d in dangers:
            values = gazes_f.numbers(d.person)
            if not values or not all(-math.pi / 2 <= g <= math.pi / 2 for g in values):
                raise gazes_f.fail(d.person, "expected one or more pitches in [-pi/2, pi/2] rad")
            gazes[d.person] = values
        bystanders = tuple(walk_from_fields(w) for w in f.children("bystanders", []))
        if not dangers and not bystanders:
            raise f.fail("dangers", "expected a danger, or a bystander to judge moves beside")

        def bystander(entry: Fields) -> Walk:
            walk = walk_from_fields(entry.child("walk"))
            if walk not in bystanders:
                raise entry.fail("walk", "expected one of the bystanders' walks")
            return walk

        falls = tuple((bystander(e), e.string("object")) for e in f.children("falls_anyway", []))
        risks = tuple(
            (bystander(e), e.number("risk", non_negative=True, at_most=1.0)) for e in f.children("risks_anyway", [])
        )
        return cls(
            dangers,
            gazes,
            {p: known_f.strings(p) for p in known_f.keys()},
            bystanders,
            RobotMove.optional_from(f, "current"),
            f.number("delay", 0.0, non_negative=True, at_most=MAX_DELAY),
            _falling_from_fields(f.child("falling", {}), dangers, bystanders),
            RobotMove.optional_from(f, "lead"),
            f.number("lead_for", 0.0, non_negative=True, at_most=MAX_DELAY),
            falls,
            risks,
            f.number("keep_clear", 0.0, non_negative=True, at_most=MAX_KEEP_CLEAR),
            _poses_from_fields(f.child("robot_at", {}), dangers),
        )


def _poses_from_fields(f: Fields, dangers: tuple[Danger, ...]) -> dict[str, Pose]:
    """``robot_at``: an ``[x, y, heading]`` for some of the endangered people."""
    endangered = {d.person for d in dangers}
    poses: dict[str, Pose] = {}
    for person in f.keys():
        if person not in endangered:
            raise f.fail(person, "expected one of the endangered people")
        pose = optional_pose(f, person)
        if pose is not None:
            poses[person] = pose
    return poses


def _falling_from_fields(f: Fields, dangers: tuple[Danger, ...], bystanders: tuple[Walk, ...]) -> dict[str, str]:
    """``falling``: the bystanders' falls, and the dangers' own (:meth:`SearchSpec.letting_dangers_fall`)."""
    falling = falling_from_fields(f, {w.person for w in bystanders} | {d.person for d in dangers})
    for d in dangers:
        if falling.get(d.person, d.obstacle) != d.obstacle:
            raise f.fail(d.person, f"expected the danger's own obstacle {d.obstacle!r}, got {falling[d.person]!r}")
    return falling


def _by_person(pairs: Iterable[tuple[Walk, T]], walks: Iterable[Walk]) -> dict[str, T]:
    """``{person: value}`` of the ``pairs`` whose walk is one of ``walks``."""
    on = set(walks)
    return {w.person: value for w, value in pairs if w in on}
