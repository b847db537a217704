"""The assist agent: the robot's answer to a fall it could not prevent. It raises an alert and goes to the person.

``python -m agents.caregiving.assist --graph G --connect EP [--scenario S]``

When perception marks a person ``fallen`` in W, the agent raises an ``alert`` about them at once, and ends
it if they are seen standing again (:mod:`agents.caregiving.fall_response`). It then sends the robot to
them: a ``go_to`` the nearest pose beside them that harms nobody still walking, judged by the simulator as
Algorithm 2's moves are (:mod:`agents.caregiving.model.go_to`), everyone else imagined on the walks they may
be on, or may set off on (:func:`~agents.caregiving.fall_response.going_spec`). With nobody else up, there
is nobody to harm, and the nearest pose is taken. As the action agent's, a move is held until the moment its
search imagined it setting off (:mod:`agents.caregiving.set_off`).

Preventing a fall comes first. While any move is under way, or Algorithm 1 holds a risky walk of someone
not fallen, the robot is left where it is: the action agent judges a ``go_to`` under way as it judges its
own moves when a danger lands, and replaces it if it must.
When no pose harms nobody, the agent tries again ``--retry`` simulated seconds later. Once the robot
has reached someone still lying there, it stays.
"""

from __future__ import annotations

import argparse
from itertools import count

from agents.caregiving import keys
from agents.caregiving.model.go_to import GAP, going_to
from agents.caregiving.model.move_search import DEFAULT_MAX_MOVES
from agents.caregiving.model.robot_moves import moves_beside
from agents.caregiving.model.uncertainty import Uncertainty
from wm import Event, Node

from ..runtime import Agent, main, on
from .context import Context, episode_of, read_context
from .fall_response import (
    alerts,
    end_alert,
    fallen,
    going_spec,
    raise_alert,
    seen_to,
    someone_in_danger,
    write_go_to,
)
from .names import PERSON, WORLD
from .odometry import OdometryClock
from .risk_options import add_risk_arguments, add_walking_arguments, size_error, walking
from .robot_intentions import move_under_way
from .search_client import SearchClient, SearchTerms
from .set_off import SetOff, add_dispatch_argument


class Assist(Agent):
    """Raises an alert about each person who has fallen, and sends the robot to them."""

    name = "assist"

    @classmethod
    def add_arguments(cls, parser: argparse.ArgumentParser) -> None:
        add_risk_arguments(parser)
        add_walking_arguments(parser)
        parser.add_argument(
            "--retry", type=float, default=0.5, help="simulated seconds before a pose is looked for again"
        )
        add_dispatch_argument(parser)

    async def setup(self) -> None:
        self.size_error = size_error(self.args)
        self.searches = SearchClient(self.ask, keys.imagine(self.args.graph), self.log)
        self.clock = OdometryClock()
        self.set_off = SetOff(self.clock, self.args.dispatch)
        self.names = count(1)
        self.episode: int | None = None
        self.tried: dict[int, float] = {}  # person node id -> simulated time a pose beside them was last looked for

    @on(type=[PERSON, WORLD], kind=["node_added", "node_updated"], coalesce=True)
    async def attend(self, _events: list[Event]) -> None:
        """Raise and end alerts as people fall and get up, and send the robot to someone lying there."""
        lying, raised = fallen(self.g), alerts(self.g)
        if not lying and not raised:
            return
        ctx = read_context(self.g)
        if ctx is None:
            return
        if ctx.episode != self.episode:
            self.episode, self.tried = ctx.episode, {}
            self.clock.reset()
        down = {n.id for n in lying}
        for person, alert in raised.items():
            if person in ctx.names and person not in down:  # not one W no longer holds
                end_alert(self.g, alert)
                self.log.info("alert ended", person=ctx.names[person], because="seen standing again")
        for n in lying:
            if n.id not in raised and self._current(ctx):
                raise_alert(self.g, ctx, n, str(next(self.names)))
                self.log.warning("alert raised", person=n.name, fallen_at=n.get("fallen_at"))
        here = {p.name for p in ctx.scene.people}
        await self._go_to_someone(ctx, [n for n in lying if n.name in here])

    async def _go_to_someone(self, ctx: Context, lying: list[Node]) -> None:
        """Send the robot to the first of ``lying`` (the people fallen in ``ctx``, the earliest fall first), unless a
        move is under way, someone walks into danger (the robot may be standing where it keeps them from it), or
        the robot is with someone fallen already."""
        waiting = [n for n in lying if ctx.scene.time - self.tried.get(n.id, -1e9) >= self.args.retry]
        if not waiting or self._busy() or seen_to(self.g) & {n.id for n in lying}:
            return
        person = waiting[0].name
        moves = moves_beside(ctx.scene, person, GAP)
        spec = going_spec(self.g, ctx, walking(self.args))
        sets_off = None
        if not moves:
            move, why = None, "no pose beside them where the robot fits"
        elif not spec.bystanders:
            move, why = moves[0], "nobody else is up"
        else:
            found = await self.searches.run(going_to(spec, moves), self._terms(ctx))
            chosen = found.chosen if found is not None else None
            move = chosen.move if chosen is not None else None
            refused = sorted({v.reason for v in found.verdicts})[:3] if found is not None else ["search refused"]
            why = chosen.reason if chosen is not None else "; ".join(refused)
            sets_off = found.sets_off if found is not None else None
        self.tried[waiting[0].id] = ctx.scene.time  # a pose the world then refuses is not sent again at once
        if move is None:
            self.log.info("no harmless pose beside them yet", person=person, why=why[:300])
            return
        # Judged setting off later than its search ended, the move could cut across someone walking if sent at once.
        await self.set_off.hold(self.g, ctx.scene.time, sets_off, self.log)
        if self._busy() or not self._current(ctx):
            return  # a danger, or a move against it, came meanwhile; or the trial ended
        write_go_to(self.g, ctx, person, move, why, str(next(self.names)))
        self.log.info("going to", person=person, x=round(move.x, 2), y=round(move.y, 2), why=why)

    def _busy(self) -> bool:
        """Whether the robot is needed against a danger, or already on a move."""
        return move_under_way(self.g) is not None or someone_in_danger(self.g)

    def _current(self, ctx: Context) -> bool:
        """Whether ``ctx`` is still of the trial under way (W is cleared for the next one)."""
        return episode_of(self.g.find_node(WORLD)) == ctx.episode

    def _terms(self, ctx: Context) -> SearchTerms:
        return SearchTerms.reading(
            self.g,
            ctx.scene.time,
            self.set_off,
            Uncertainty(self.size_error, ctx.sigma, self.args.samples),
            self.args.risk_threshold,
            DEFAULT_MAX_MOVES,  # for generated candidates; the moves here are given
        )


if __name__ == "__main__":
    main(Assist)
