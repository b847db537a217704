"""Algorithm 2: for the risky intentions in W, find a robot move that removes the danger, and write it to W.

``python -m agents.caregiving.action --graph G --connect EP [--scenario S]``

Triggered by each risky ``has_intention`` edge as it lands in W. The search
itself is :mod:`agents.caregiving.model.move_search`; this agent turns W into its input
(:mod:`agents.caregiving.robot_intentions` reads and writes W for it), asks the
simulator to imagine the candidates, and writes the result:

* every endangered person is protected by one search, which the simulator runs
  next to its imagination in one request (no round trip per candidate): the
  candidates of all their dangers, interleaved, each imagined in time
  (:mod:`agents.caregiving.model.joint`) with every gaze class of each endangered
  person, the other people walking their likeliest intentions beside them, and
  perception's uncertainty sampled, one at a time up to the first safe one;
* a robot at rest does not stand idle while the search judges: when every
  danger is at least even odds (``HEAD_START_RISK``), the first candidate is
  judged first as a head start, and if it harms nobody (it trips nobody, and
  whoever falls with it falls with the robot idle too), the simulator sends it
  back at once, written as an intention with ``head_start`` set, and every
  candidate is judged as a switch from it; the move chosen supersedes it (the
  same move, when the first candidate is the one chosen). A head
  start lasts as long as the search: when none is chosen, the robot brakes (a
  ``stop`` with ``head_start`` set), or, when braking there would trip someone,
  drives on with it until a later search replaces it;
* when no single move keeps everyone safe, each danger is searched alone, most
  urgent first, and the move found is written with the people it leaves unsaved;
* while a move is under way, a new risky intention first re-imagines that move
  from the robot's current state, speed included; it is kept while it still keeps
  everyone safe at the gaze found risky and trips nobody at any gaze
  (:func:`~agents.caregiving.model.move_search.holds`). One that fails without
  walking anyone into the robot is kept for one more look, and given up only if it
  fails again (:func:`~agents.caregiving.model.move_search.gives_up`); then a new
  move is searched, and only one that ranks clearly above it, judged in the same
  frame, replaces it (:func:`~agents.caregiving.model.move_search.replaces`); the
  old one is then marked ``superseded``;
* a move is never sent when its imagination shows a fall that would not happen
  without it: every imagined walk with it is clear, but for a bystander's fall
  into the very object their own risky intention already heads for (a danger not
  searched now, say because no move saved it a moment ago), and but for a gaze
  other than the one the danger was found at, where the person falls with the
  robot as it is too (the move then saves them if their gaze is the one found):
  the robot never causes a collision its imagination can see;
* when the move under way, judged again, has someone walk into the robot or get
  stuck, and no move replaces it, braking to a stop is judged from the robot's
  current state; if it ranks clearly above carrying on, the robot brakes (a
  ``stop`` intention).

The chosen move becomes the robot's ``intention`` node (``move_to``, target,
final pose, ``status: proposed``, ``in_time``, ``reason``; or ``stop``, its target
the robot), linked ``robot -has-> intention``; the executor drives it.
"""

from __future__ import annotations

import argparse
import time
from collections.abc import Callable
from dataclasses import replace
from itertools import count

from agents.caregiving import keys
from agents.caregiving.model import imagine_reply
from agents.caregiving.model.move_search import (
    HEAD_START_RISK,
    SearchItem,
    SearchSpec,
    gives_up,
    holds,
    replaces,
)
from agents.caregiving.model.robot_moves import RobotMove
from agents.caregiving.model.rollout import DT
from agents.caregiving.model.uncertainty import Uncertainty
from agents.caregiving.model.verdict import SearchResult, Verdict
from wm import Event, Node

from ..runtime import Agent, main, on
from .context import Context, read_context
from .names import HAS_INTENTION, WORLD
from .odometry import OdometryClock
from .risk_options import add_risk_arguments, size_error
from .robot_intentions import (
    Dangers,
    clear_intentions,
    dangers_in,
    move_of,
    move_under_way,
    search_spec,
    write_intention,
)

#: Wall seconds one candidate move takes to judge in the simulator, until the first search has measured it.
JUDGING = 0.03
#: Weight of the newest search in the running estimate of the time a candidate takes to judge.
JUDGING_WEIGHT = 0.3


class Action(Agent):
    """Selects a robot move that removes the risky intentions (Algorithm 2)."""

    name = "action"

    @classmethod
    def add_arguments(cls, parser: argparse.ArgumentParser) -> None:
        add_risk_arguments(parser)
        parser.add_argument("--max-moves", type=int, default=24, help="moves tried per search at most")
        parser.add_argument(
            "--retry",
            type=float,
            default=0.5,
            help="simulated seconds before a danger no move removed is searched again (at its next update after that)",
        )
        parser.add_argument(
            "--dispatch",
            type=float,
            default=DT,
            help="simulated seconds from writing a move to the world acting on it: the world takes a command at its "
            "next step, so one step (default) covers the executor's hop and the wait for it",
        )

    async def setup(self) -> None:
        self.size_error = size_error(self.args)
        self.episode: int | None = None
        self.names = count(1)
        self.rpc_ms = self.sim_ms = 0.0
        self.pending: set[tuple[int, int]] = set()
        self.tried: list[Verdict] = []  # the moves the last search judged, for its log line
        self.judging = JUDGING  # wall seconds per candidate judged, measured by every search
        self.clock = OdometryClock()
        self.new_episode = True
        self.failed: dict[int, float] = {}  # person node id -> simulated time their last search found no move
        self.doubted: str | None = None  # the move under way that failed its last judgement, if it did
        self.log.info("acting", size_error=self.size_error)

    @on(kind=["edge_added", "edge_updated", "node_added", "node_updated"], type=[HAS_INTENTION, WORLD], coalesce=True)
    async def search(self, events: list[Event]) -> None:
        """Protect every person whose risky intention landed since the last search."""
        for e in events:
            if e.type == HAS_INTENTION and e.src is not None and e.dst is not None:
                self.pending.add((e.src, e.dst))
            elif e.type == WORLD and "episode" in e.attrs:
                self.new_episode = True
        if not self.pending and not self.new_episode:
            return
        self.new_episode = False
        ctx = read_context(self.g)
        if ctx is None:
            return
        if ctx.episode != self.episode:
            clear_intentions(self.g)
            self.episode = ctx.episode
            self.failed.clear()
            self.doubted = None
            self.clock.reset()
        landed = [self.g.find_edge(src, dst, HAS_INTENTION) for src, dst in self.pending]
        self.pending.clear()
        risky = [e for e in landed if e is not None and e.get("risky")]
        dangers = dangers_in(ctx, risky, self.failed, self.args.retry)
        if not dangers:
            return
        started = time.perf_counter()
        self.rpc_ms = self.sim_ms = 0.0
        current = move_under_way(self.g)
        spec = search_spec(self.g, ctx, dangers, current)
        under_way: Verdict | None = None
        if current is not None:
            again = await self._search(ctx, spec, 1.0, [move_of(current, ctx)])
            under_way = again.verdicts[0] if again is not None and again.verdicts else None
        robot = ctx.scene.robot_name
        if under_way is not None and holds(under_way, self.args.risk_threshold, robot):
            self.doubted = None
            if not under_way.clear:
                self.log.info("move kept", under_way=under_way.reason, risk=round(under_way.risk, 2))
            return  # the move under way still keeps everyone safe, at least at the gaze found risky
        if (
            current is not None
            and under_way is not None
            and not gives_up(under_way, self.doubted == current.name or bool(current.get("head_start")), robot)
        ):
            self.doubted = current.name
            self.log.info("move doubted", under_way=under_way.reason, risk=round(under_way.risk, 2))
            return  # kept for one more look
        idle_risk = max(e.get("probability", 1.0) for e, _ in dangers.values())
        self.tried = []
        led: Node | None = None  # the head start written, if any

        def lead(verdict: Verdict) -> None:
            nonlocal led
            if move_under_way(self.g) is not None:  # a move came under way since: the lead was judged from rest
                self.log.info("head start dropped", because="a move came under way during the search")
                return
            if self._write(ctx, verdict, dangers, None, None, "", started, head_start=True):
                led = move_under_way(self.g)

        likely = min(e.get("probability", 1.0) for e, _ in dangers.values()) >= HEAD_START_RISK
        found = await self._find(ctx, spec, idle_risk, lead if current is None and likely else None)
        chosen, unsaved = found.chosen if found is not None else None, ""
        if led is not None:
            current = led
        if chosen is None and len(spec.dangers) > 1:
            for d in sorted(spec.dangers, key=lambda d: d.time_to_collision):
                alone = replace(spec, dangers=(d,))
                alone_found = await self._find(ctx, alone, dangers[d.person][0].get("probability", 1.0))
                chosen = alone_found.chosen if alone_found is not None else None
                if chosen is not None:
                    unsaved = ", ".join(sorted(p for p in dangers if p != d.person))
                    break
        if chosen is None:
            for person in dangers:
                self.failed[ctx.ids[person]] = ctx.scene.time
            self.log.warning(
                "no move removes the danger",
                people=sorted(dangers),
                search_ms=self._ms(started),
                tried=len(self.tried),
                why=sorted({v.reason for v in self.tried})[:4],
                head_start=led is not None,
            )
            halt = found.halt if found is not None else None
            newest = move_under_way(self.g)
            # The head start ends with the search that sent it, unless another move has come under way since.
            if halt is not None and led is not None and newest is not None and newest.id == led.id:
                self._write(ctx, halt, dangers, current, None, "", started, head_start=True)
            elif under_way is not None and under_way.move is not None and under_way.trips(robot):
                braking = await self._braking(ctx, spec, under_way, robot)
                if braking is not None:
                    self._write(ctx, braking, dangers, current, under_way, "", started)
            return
        if under_way is not None and not replaces(chosen, under_way, self.args.samples, robot):
            self.log.info(
                "move kept",
                under_way=under_way.reason,
                risk=round(under_way.risk, 2),
                best_new=chosen.reason,
                new_risk=round(chosen.risk, 2),
                search_ms=self._ms(started),
            )
            return
        self._write(ctx, chosen, dangers, current, under_way, unsaved, started)

    # -- asking the simulator ------------------------------------------------------------------
    async def _search(
        self,
        ctx: Context,
        spec: SearchSpec,
        idle_risk: float,
        moves: list[RobotMove | None] | None = None,
        head_start: Callable[[Verdict], None] | None = None,
    ) -> SearchResult | None:
        """One search, run by the simulator; each candidate imagines the robot starting when its command would arrive.

        ``moves`` judges those moves instead of the generated candidates (``None``: braking). With
        ``head_start``, a head start the simulator finds on the way is handed to it as soon as it arrives.
        None when the simulator refused.
        """
        item = SearchItem(
            replace(spec, delay=self._delay(ctx)),
            Uncertainty(self.size_error, ctx.sigma, self.args.samples),
            self.args.risk_threshold,
            len(moves) if moves else self.args.max_moves,
            idle_risk,
            self.judging * self.clock.rate(self.g),
            tuple(moves) if moves else None,
            head_start is not None,
        )

        def progress(reply: imagine_reply.ImagineReply) -> None:
            found = reply.search
            if head_start is not None and found is not None and found.lead is not None:
                head_start(found.lead)

        sent = time.perf_counter()
        reply = await self.ask(
            keys.imagine(self.args.graph), {"items": [item.to_wire()]}, decode=imagine_reply.decode, progress=progress
        )
        self.rpc_ms += (time.perf_counter() - sent) * 1e3
        self.sim_ms += reply.compute_ms
        found = reply.search
        if found is None:
            self.log.error("the simulator refused the search", error=reply.results[0].error if reply.results else None)
            return None
        if found.judged:
            per_move = reply.compute_ms / 1e3 / found.judged
            self.judging += JUDGING_WEIGHT * (per_move - self.judging)
        return found

    async def _find(
        self, ctx: Context, spec: SearchSpec, idle_risk: float, head_start: Callable[[Verdict], None] | None = None
    ) -> SearchResult | None:
        """The search for ``spec`` (None when the simulator refused); every verdict on the way joins :attr:`tried`."""
        found = await self._search(ctx, spec, idle_risk, head_start=head_start)
        if found is not None:
            self.tried += found.verdicts
        return found

    async def _braking(self, ctx: Context, spec: SearchSpec, under_way: Verdict, robot: str | None) -> Verdict | None:
        """Braking to a stop, judged now, if it ranks clearly above the move under way."""
        found = await self._search(ctx, spec, 1.0, [None])
        braking = found.verdicts[0] if found is not None and found.verdicts else None
        return braking if braking is not None and replaces(braking, under_way, self.args.samples, robot) else None

    def _delay(self, ctx: Context) -> float:
        """When a move decided now would reach the world, in simulated seconds after the context.

        The world has gone on past the context already (sensor latency, then Algorithm 1 and the search so
        far: the robot's odometry in W says by how much), and the executor and the world take ``--dispatch``
        more. The search adds the time it spends judging, candidate by candidate.
        """
        return self.clock.lag(self.g, ctx.scene.time) + self.args.dispatch

    # -- writing W -----------------------------------------------------------------------------
    def _write(
        self,
        ctx: Context,
        chosen: Verdict,
        dangers: Dangers,
        current: Node | None,
        under_way: Verdict | None,
        unsaved: str,
        started: float,
        head_start: bool = False,
    ) -> bool:
        """Write ``chosen`` as the robot's intention (a ``head_start`` while the search judges on); False if not."""
        written = write_intention(self.g, ctx, chosen, dangers, current, str(next(self.names)), unsaved, head_start)
        if written is None:
            return False
        edge, danger = written
        move = chosen.move
        self.log.info(
            ("head start" if move else "head start ends, braking")
            if head_start
            else "move chosen"
            if move
            else "braking",
            **({"target": move.target, "x": round(move.x, 2), "y": round(move.y, 2)} if move else {}),
            in_time=chosen.in_time(danger.time_to_collision),
            risk=round(chosen.risk, 2),
            chosen=chosen.reason,
            people=len(dangers),
            tried=len(self.tried),
            refused=sorted({v.reason for v in self.tried if not v.clear})[:4],
            replaces=current.name if current is not None else None,
            because=under_way.reason if under_way is not None else None,
            search_ms=self._ms(started),
            rpc_ms=round(self.rpc_ms, 1),
            sim_ms=round(self.sim_ms, 1),
            since_risk_ms=round((time.time() - edge.get("updated_at", time.time())) * 1e3, 1),
        )
        return True

    @staticmethod
    def _ms(started: float) -> float:
        return round((time.perf_counter() - started) * 1e3, 1)


if __name__ == "__main__":
    main(Action)
