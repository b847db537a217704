"""Whether perception saw each fall: a ``fallen`` mark in W near where someone fell, in the trial as run.

The world's outcome lists every fall of the trial with the robot acting (time and point of contact). The
harness keeps each person node's first ``fallen`` mark (a :class:`~bridges.experiment.fallers.Mark`: its
stamp and where perception held the person then). A fall is seen when a mark lies within :data:`REACH` of
its point, stamped at or after it; its delay is the first such mark's, and each mark sees one fall. A mark
that sees no fall is a fall seen where nobody fell.
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


@dataclass(frozen=True)
class FallsSeen:
    """Per fall of a trial, the seconds until perception marked it (None: never); and the marks of no fall."""

    delays: tuple[float | None, ...]
    unmatched: int


def falls_seen(collisions: Sequence[Mapping[str, Any]], marks: Iterable[Mark]) -> FallsSeen:
    """Match the falls of a trial's outcome (``{time, point, ...}``) to perception's ``fallen`` marks."""
    left = sorted(marks, key=lambda m: m.at_time)
    delays: list[float | None] = []
    for fall in sorted(collisions, key=lambda c: c["time"]):
        mark = next(
            (m for m in left if m.at_time >= fall["time"] - 1e-9 and math.dist(m.at, fall["point"]) <= REACH), None
        )
        if mark is not None:
            left.remove(mark)
        delays.append(mark.at_time - fall["time"] if mark is not None else None)
    return FallsSeen(tuple(delays), len(left))
