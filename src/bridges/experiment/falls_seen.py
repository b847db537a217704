"""Whether perception saw each fall: a ``fallen`` mark in W near where someone fell, in the trial as run.

The world's outcome lists every fall of the trial with the robot acting (time and point of contact). The
harness keeps each person node's first ``fallen`` mark (a :class:`~bridges.experiment.fallers.Mark`: its
stamp and where perception held the person then). A fall is seen when a mark lies within :data:`REACH` of
its point, stamped at or after it; its delay is the first such mark's, and each mark sees one fall. A mark
that sees no fall is a fall seen where nobody fell. The world stops as soon as nobody walks any more, so the
last walker's fall ends the trial before any frame shows them lying: only a fall the trial ran on
:data:`SETTLE` seconds after could be seen.
"""

from __future__ import annotations

import math
from collections.abc import Iterable, Mapping, Sequence
from dataclasses import dataclass
from typing import Any

from .fallers import Mark

#: Metres from a fall's point of contact to where perception may hold the person who fell (a radius and
#: several sigmas of the sensors' error).
REACH = 0.5
#: Seconds a trial must run on after a fall for perception to see it: frames enough at the slowest camera
#: shipped (5 Hz) and its latency.
SETTLE = 1.0


@dataclass(frozen=True)
class FallsSeen:
    """Per fall of a trial in time order, the seconds until perception marked it (None: never) and whether the
    trial ran on long enough to see it; and the marks of no fall."""

    delays: tuple[float | None, ...]
    seeable: tuple[bool, ...]
    unmatched: int

    @property
    def seen(self) -> list[float]:
        """The delays of the seeable falls perception marked."""
        return [d for d, s in zip(self.delays, self.seeable, strict=True) if s and d is not None]


def falls_seen(collisions: Sequence[Mapping[str, Any]], marks: Iterable[Mark], ended_at: float) -> FallsSeen:
    """Match the falls of a trial's outcome (``{time, point, ...}``) to perception's ``fallen`` marks; the trial
    ended at ``ended_at`` (simulated s)."""
    left = sorted(marks, key=lambda m: m.at_time)
    falls = sorted(collisions, key=lambda c: c["time"])
    delays: list[float | None] = []
    for fall in falls:
        mark = next(
            (m for m in left if m.at_time >= fall["time"] - 1e-9 and math.dist(m.at, fall["point"]) <= REACH), None
        )
        if mark is not None:
            left.remove(mark)
        delays.append(mark.at_time - fall["time"] if mark is not None else None)
    seeable = tuple(fall["time"] <= ended_at - SETTLE for fall in falls)
    return FallsSeen(tuple(delays), seeable, len(left))
