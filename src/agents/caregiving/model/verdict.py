"""What Algorithm 2's move search decides: a verdict on each move it judged, and the move it chose.

A verdict lists the falls its imagination showed (a :class:`Fall` per walk set that is not clear),
so the search can tell where a refused move failed: which gaze class, who, into what and where.

Both are plain dataclasses with a wire form (msgpack-friendly dicts), so the
simulator can run the whole search next to its imagination and answer with them
(:mod:`agents.caregiving.model.imagine_reply`). A search result names its
chosen move by position among its verdicts, so the two cannot disagree.
"""

from __future__ import annotations

from collections.abc import Mapping
from dataclasses import dataclass, field
from typing import Any

from .fields import Fields
from .robot_moves import RobotMove
from .uncertainty import Risk


@dataclass(frozen=True)
class Fall:
    """The first fall imagined in one walk set: who, into what (``None``: stuck) and where they touched it.

    ``made_worse`` marks a fall imagined in a world where, with the robot as it is, they walk clear: one the
    robot as it is does not bring, whoever falls at the belief's centre. ``close_pass`` marks a pass within the
    margin round the robot (:class:`~agents.caregiving.model.judging.RobotMargin`): no touch was imagined, but
    perception's error leaves room for one, so it counts as a walk into the robot.
    """

    walk_set: int
    person: str
    obstacle: str | None
    point: tuple[float, float] | None
    made_worse: bool = False
    close_pass: bool = False

    def trips(self, robot: str | None) -> bool:
        """Whether it is a walk into the robot (named ``robot``) or getting stuck."""
        return self.obstacle is None or self.obstacle == robot

    def to_wire(self) -> dict[str, Any]:
        """A msgpack-friendly dict."""
        return {
            "walk_set": self.walk_set,
            "person": self.person,
            "obstacle": self.obstacle,
            "point": list(self.point) if self.point else None,
            "made_worse": self.made_worse,
            "close_pass": self.close_pass,
        }

    @classmethod
    def from_fields(cls, f: Fields) -> Fall:
        """Parse :meth:`to_wire` output nested in a larger message."""
        walk_set = f.number("walk_set", non_negative=True)
        if not walk_set.is_integer():
            raise f.fail("walk_set", f"expected the index of a walk set, got {walk_set!r}")
        obstacle = f.string("obstacle") if f.has("obstacle") else None
        point = f.numbers("point", 2) if f.has("point") else None
        where = (point[0], point[1]) if point else None
        return cls(
            int(walk_set),
            f.string("person"),
            obstacle,
            where,
            f.boolean("made_worse", False),
            f.boolean("close_pass", False),
        )


@dataclass(frozen=True)
class Verdict:
    """A move judged over every walk set: whether everyone imagined walks clear, the sampled risk, the arrival.

    ``falls`` holds the first fall of each walk set imagined that is not clear (a move refused in the
    first set is not imagined in the others). ``risk`` is sampled over the sets that are clear: 1.0 when
    the first is not. ``near`` is where a clear move's largest sampled risk lies: the walk set, whose walk,
    what they may touch and the earliest sampled contact (``None`` when no risk was sampled). ``sampled``
    holds, per walk set imagined, each person's sampled risk with the worlds their walk collides in (see
    :attr:`~agents.caregiving.model.uncertainty.Risk.worlds`; ``None`` where none was sampled): they are
    compared with the robot's as it is in the process that judged, and are not on the wire.
    """

    move: RobotMove | None
    clear: bool
    risk: float
    arrival: float | None
    reason: str
    falls: tuple[Fall, ...] = ()
    near: Fall | None = None
    sampled: tuple[Mapping[str, Risk] | None, ...] = field(default=(), compare=False, repr=False)

    def safe(self, threshold: float) -> bool:
        """Clear in every walk set, and the sampled risk under ``threshold``."""
        return self.clear and self.risk < threshold

    @property
    def clear_where_found(self) -> bool:
        """Clear in the first walk set (the gaze class the danger was found at): everywhere, or falls at others only."""
        return self.clear or bool(self.falls) and self.falls[0].walk_set > 0

    def trips(self, robot: str | None) -> bool:
        """Whether someone, at some gaze, walks into the robot (named ``robot``) or gets stuck with this move."""
        return any(f.trips(robot) for f in self.falls)

    def trips_where_found(self, robot: str | None) -> bool:
        """:meth:`trips` in the first walk set, the gaze class the danger was found at, by a touch imagined: a pass
        within the margin round the robot is not one."""
        return any(f.trips(robot) and not f.close_pass and f.walk_set == 0 for f in self.falls)

    def in_time(self, time_to_collision: float) -> bool:
        """Whether the robot is imagined at rest at the pose before the predicted collision."""
        return self.arrival is not None and self.arrival < time_to_collision

    def to_wire(self) -> dict[str, Any]:
        """A msgpack-friendly dict."""
        return {
            "move": self.move.to_wire() if self.move else None,
            "clear": self.clear,
            "risk": self.risk,
            "arrival": self.arrival,
            "reason": self.reason,
            "falls": [fall.to_wire() for fall in self.falls],
            "near": self.near.to_wire() if self.near else None,
        }

    @classmethod
    def from_fields(cls, f: Fields) -> Verdict:
        """Parse :meth:`to_wire` output nested in a larger message."""
        return cls(
            RobotMove.optional_from(f, "move"),
            f.boolean("clear"),
            f.number("risk", non_negative=True, at_most=1.0),
            f.optional_number("arrival"),
            f.string("reason"),
            tuple(Fall.from_fields(fall) for fall in f.children("falls", [])),
            Fall.from_fields(near) if (near := f.optional_child("near")) is not None else None,
        )


@dataclass(frozen=True)
class SearchResult:
    """Every move a search judged, in order, and the one it chose (``None``: no move removes the danger).

    ``lead`` is the head start the search sent while it judged on, if it sent one (see
    :func:`agents.caregiving.model.move_search.search`); ``halt``, when none is chosen after it, braking
    at the search's end, judged harmless (``None``: the robot drives the head start on). ``judged`` is how
    many judgements the search took in turn, the head start's and braking's included: its time, in
    candidate slots. ``sets_off`` is when the chosen move (or the halt) was imagined to set off (switching from
    the head start, if one was sent), in simulated seconds after the scene: the robot must not set off on it
    sooner.
    ``lead_sets_off`` is the same for the head start, once the judgements it waited for are done (``None``: when it
    was sent, as the simulator does the moment it finds one).
    """

    chosen: Verdict | None
    verdicts: tuple[Verdict, ...]
    lead: Verdict | None = None
    halt: Verdict | None = None
    judged: int = 0
    sets_off: float | None = None
    lead_sets_off: float | None = None

    def __post_init__(self) -> None:
        if self.judged < len(self.verdicts):
            raise ValueError(f"a search of {len(self.verdicts)} verdicts took at least as many judgements")
        if self.sets_off is not None and (self.chosen is None and self.halt is None or self.sets_off < 0.0):
            raise ValueError(
                f"a set-off time ({self.sets_off}) is for a chosen move or a halt, and not before the scene"
            )
        if self.lead_sets_off is not None and (self.lead is None or self.lead_sets_off < 0.0):
            raise ValueError(f"a set-off time ({self.lead_sets_off}) is for a head start, and not before the scene")

    def to_wire(self) -> dict[str, Any]:
        """A msgpack-friendly dict; the chosen move is an index into the verdicts."""
        index = next((k for k, v in enumerate(self.verdicts) if v is self.chosen), None)
        if self.chosen is not None and index is None:
            raise ValueError("the chosen verdict is not one of the verdicts")
        return {
            "chosen": index,
            "verdicts": [v.to_wire() for v in self.verdicts],
            "lead": self.lead.to_wire() if self.lead is not None else None,
            "halt": self.halt.to_wire() if self.halt is not None else None,
            "judged": self.judged,
            "sets_off": self.sets_off,
            "lead_sets_off": self.lead_sets_off,
        }

    @classmethod
    def from_fields(cls, f: Fields) -> SearchResult:
        """Parse :meth:`to_wire` output nested in a larger message."""
        verdicts = tuple(Verdict.from_fields(v) for v in f.children("verdicts"))
        lead_f, halt_f = f.optional_child("lead"), f.optional_child("halt")
        lead = Verdict.from_fields(lead_f) if lead_f is not None else None
        halt = Verdict.from_fields(halt_f) if halt_f is not None else None
        judged = f.number("judged")
        if not judged.is_integer() or judged < len(verdicts):
            raise f.fail("judged", f"expected a whole number of judgements, {len(verdicts)} or more, got {judged!r}")
        index = f.optional_number("chosen")
        sets_off = f.optional_number("sets_off")
        if sets_off is not None and (index is None and halt is None or sets_off < 0.0):
            raise f.fail(
                "sets_off",
                f"expected no set-off time before the scene, nor without a chosen move or a halt, got {sets_off!r}",
            )
        lead_sets_off = f.optional_number("lead_sets_off")
        if lead_sets_off is not None and (lead is None or lead_sets_off < 0.0):
            raise f.fail(
                "lead_sets_off",
                f"expected no set-off time before the scene, nor without a head start, got {lead_sets_off!r}",
            )
        if index is None:
            return cls(None, verdicts, lead, halt, int(judged), sets_off, lead_sets_off)
        if not index.is_integer() or not 0 <= index < len(verdicts):
            raise f.fail("chosen", f"expected the index of one of {len(verdicts)} verdicts, got {index!r}")
        return cls(verdicts[int(index)], verdicts, lead, halt, int(judged), sets_off, lead_sets_off)
