"""When a move written now reaches the world, and holding one until the moment its search imagined it setting off.

The world has gone on past the context a search read (sensor latency, then Algorithm 1 and the search so
far: the robot's odometry in W says by how much), and the executor and the world take ``dispatch``
simulated seconds more to act on a move written. A search imagines its k-th candidate setting off
``judging * k`` after the first, from a running estimate of a candidate's cost; a search that ends sooner
than that would otherwise send the robot on its way before the moment its move was judged for, into a room
where people are elsewhere, so the move is held until then.
"""

from __future__ import annotations

import argparse
import asyncio
from dataclasses import dataclass

from agents.caregiving.model.rollout import DT
from wm import Graph

from ..logs import AgentLogger
from .odometry import OdometryClock


def add_dispatch_argument(parser: argparse.ArgumentParser) -> None:
    """``--dispatch``, of the agents that write robot moves: what :attr:`SetOff.dispatch` is."""
    parser.add_argument(
        "--dispatch",
        type=float,
        default=DT,
        help="simulated seconds from writing a move to the world acting on it: the world takes a command at its "
        "next step, so one step (default) covers the executor's hop and the wait for it",
    )


@dataclass
class SetOff:
    """Times a robot move against the world's clock as the robot's odometry in W shows it."""

    clock: OdometryClock
    dispatch: float  # simulated seconds from writing a move to the world acting on it

    def delay(self, g: Graph, time: float) -> float:
        """When a move decided now would reach the world, in simulated seconds after ``time`` (a context's)."""
        return self.clock.lag(g, time) + self.dispatch

    def early(self, g: Graph, time: float, sets_off: float | None) -> float:
        """How many simulated seconds before ``sets_off`` (after ``time``) a move written now would reach the world,
        give or take one world step (the world takes a command at its next step); 0 without a set-off time."""
        return sets_off - self.delay(g, time) - DT if sets_off is not None else 0.0

    async def hold(self, g: Graph, time: float, sets_off: float | None, log: AgentLogger) -> None:
        """Wait until a move written now would reach the world no sooner than ``sets_off`` after ``time``."""
        early = self.early(g, time, sets_off)
        if sets_off is not None and early > 0.0:
            log.info("move held", until_s=round(sets_off, 3), held_ms=round(early * 1e3, 1))
            await asyncio.sleep(early / self.clock.rate(g))
