"""Who falls with the robot idle, whether Algorithm 1 flagged each of them, themselves, before they fell, and
whether the robot acting saved them.

Table I counts a trial as predicted when any risky intention arose in it. In a room of several people
that can hide a miss: a false alarm about one person makes the trial predicted while the person who
falls is flagged late or never. Here each person's first risky ``has_intention`` the harness saw
(:class:`Mark`) is matched to the true person who stood nearest the start of its imagined path at its
moment, and each person who falls with the robot idle is flagged when one of their own was written at
or before their fall. A trial is prevented only when nobody falls; where two people fall in different
places, no single move may save both, and saving one of them counts here, person by person.
"""

from __future__ import annotations

import math
from collections.abc import Collection, Iterable
from dataclasses import dataclass

from agents.caregiving.model.world_model import World


@dataclass(frozen=True)
class Mark:
    """Something W showed of a person, a risky intention or a ``fallen`` mark: its moment (simulated s) and
    where the person stood then."""

    at_time: float
    at: tuple[float, float]


@dataclass(frozen=True)
class Faller:
    """A person who falls with the robot idle, when, when Algorithm 1 first flagged them (None: not before), and
    whether they fell with the robot acting too."""

    person: str
    falls_at: float
    flagged_at: float | None
    fell_acting: bool

    @property
    def lead(self) -> float | None:
        """Seconds from their first flag to their fall."""
        return self.falls_at - self.flagged_at if self.flagged_at is not None else None


def position_at(world: World, person: str, time: float) -> tuple[float, float]:
    """Where ``person`` stood at ``time`` in a world run from its start (still where they stopped, after)."""
    track = world.walker(person).track
    step = min(max(round((time - world.started) / world.dt), 0), len(track) - 1)
    return track[step]


def fallers(idle: World, flags: Iterable[Mark], fell_acting: Collection[str]) -> tuple[Faller, ...]:
    """The people who fell in ``idle`` (a world run with the robot idle), each with their first own flag;
    ``fell_acting`` names who fell with the robot acting."""
    people = idle.people()
    first: dict[str, float] = {}
    for flag in flags:
        nearest = min(people, key=lambda p: math.dist(position_at(idle, p, flag.at_time), flag.at))
        first[nearest] = min(first.get(nearest, math.inf), flag.at_time)
    out = []
    for c in idle.outcome().collisions:
        flagged = first.get(c.person)
        flagged = flagged if flagged is not None and flagged <= c.time + 1e-9 else None
        out.append(Faller(c.person, c.time, flagged, c.person in fell_acting))
    return tuple(out)
