"""Algorithm 2: for the risky intentions in W, find a robot move that removes the danger, and write it to W.

``python -m agents.caregiving.action --graph G --connect EP [--scenario S]``

Triggered by each risky ``has_intention`` edge as it lands in W, and by someone (or a
target) coming into W after the move under way was judged, who was never imagined
beside it, the agent is the flow of Algorithm 2 and nothing more:

* :mod:`agents.caregiving.robot_intentions` turns W into the search's input (each
  endangered person's most urgent danger, their gaze classes and what they know,
  the others' likeliest walks, the move under way);
* :mod:`agents.caregiving.model.response` decides what to do about them (keep the
  move under way, give it one more look, send a new move, brake, or find none),
  asking for each search it needs;
* :mod:`agents.caregiving.search_client` asks the simulator for each search, one
  request each (:mod:`agents.caregiving.model.move_search`: every candidate imagined
  in time with every gaze class of each endangered person, the other people beside
  them, perception's uncertainty sampled; a move that makes anything worse is never
  chosen); a head start found on the way is written at once as an intention with
  ``head_start`` set;
* the response is written to W; a move whose search ended well before the moment
  it imagined the move setting off is judged once more, to set off now, and sent
  at once if it still does what it was chosen for; otherwise it is held until then
  (:mod:`agents.caregiving.set_off`), as is the braking that ends a head start;
* someone who came into W during a search holds back its head start, and has the
  move it chose judged once more with them before it is sent; a move that harms them
  is not sent, and the dangers are searched again.

The chosen move becomes the robot's ``intention`` node (``move_to``, target,
final pose, ``status: proposed``, ``in_time``, ``reason``; or ``stop``, its target
the robot), linked ``robot -has-> intention``, superseding the move under way; the
executor drives it.
"""

from __future__ import annotations

import argparse
import time
from dataclasses import replace
from itertools import count

from agents.caregiving import keys
from agents.caregiving.model.move_search import DEFAULT_MAX_MOVES
from agents.caregiving.model.response import (
    Keep,
    NoMove,
    Policy,
    Response,
    Send,
    UnderWay,
    judged_with_newcomers,
    respond,
    set_off_sooner,
)
from agents.caregiving.model.search_spec import SearchSpec
from agents.caregiving.model.uncertainty import Uncertainty
from agents.caregiving.model.verdict import Verdict
from wm import Event, Node

from ..runtime import Agent, main, on
from .context import Context, episode_of, read_context
from .names import GO_TO, HAS_INTENTION, PERSON, WORLD
from .odometry import OdometryClock
from .risk_options import add_risk_arguments, add_walking_arguments, size_error, walking
from .robot_intentions import (
    Dangers,
    clear_intentions,
    dangers_in,
    move_of,
    move_under_way,
    search_spec,
    write_intention,
)
from .search_client import SearchClient, SearchTerms
from .set_off import SetOff, add_dispatch_argument


class Action(Agent):
    """Selects a robot move that removes the risky intentions (Algorithm 2)."""

    name = "action"

    @classmethod
    def add_arguments(cls, parser: argparse.ArgumentParser) -> None:
        add_risk_arguments(parser)
        add_walking_arguments(parser)
        parser.add_argument("--max-moves", type=int, default=DEFAULT_MAX_MOVES, help="moves tried per search at most")
        parser.add_argument(
            "--retry",
            type=float,
            default=0.5,
            help="simulated seconds before a danger no move removed is searched again (at its next update after that)",
        )
        add_dispatch_argument(parser)

    async def setup(self) -> None:
        self.size_error = size_error(self.args)
        self.episode: int | None = None
        self.names = count(1)
        self.searches = SearchClient(self.ask, keys.imagine(self.args.graph), self.log)
        self.pending: set[tuple[int, int]] = set()
        self.arrived: set[int] = set()  # people new to W since the last pass
        self.clock = OdometryClock()
        self.set_off = SetOff(self.clock, self.args.dispatch)
        self.new_episode = True
        self.failed: dict[int, float] = {}  # person node id -> simulated time their last search found no move
        self.doubted: str | None = None  # the move under way that failed its last judgement, if it did
        self.judged_in: frozenset[int] = frozenset()  # the people and objects in W at the last response's start
        self.log.info("acting", size_error=self.size_error)

    @on(
        kind=["edge_added", "edge_updated", "node_added", "node_updated"],
        type=[HAS_INTENTION, WORLD, PERSON],
        coalesce=True,
    )
    async def search(self, events: list[Event]) -> None:
        """Protect every person whose risky intention landed since the last search; judge the move under way
        again when someone, or a target, new to W since it was judged has come in."""
        for e in events:
            if e.type == HAS_INTENTION and e.src is not None and e.dst is not None:
                self.pending.add((e.src, e.dst))
            elif e.type == WORLD and "episode" in e.attrs:
                self.new_episode = True
            elif e.type == PERSON and e.kind == "node_added" and e.id is not None:
                self.arrived.add(e.id)
        if not self.pending and not self.arrived and not self.new_episode:
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
            self.judged_in = frozenset()
            self.clock.reset()
        landed = [self.g.find_edge(src, dst, HAS_INTENTION) for src, dst in self.pending]
        current = move_under_way(self.g)
        if current is not None and self._judged_without_some(current):
            self.log.info("move under way judged again: someone or a target new in W", under_way=current.name)
            landed = self.g.edges(type=HAS_INTENTION)  # every danger still flagged
        self.pending.clear()
        self.arrived.clear()
        risky = [e for e in landed if e is not None and e.get("risky")]
        dangers = dangers_in(ctx, risky, self.failed, self.args.retry)
        if not dangers:
            return
        self.judged_in = frozenset(ctx.ids.values())
        started = time.perf_counter()
        spec = search_spec(self.g, ctx, dangers, current, walking(self.args))
        idle_risks = {p: e.get("probability", 1.0) for p, (e, _) in dangers.items()}
        response, led = await self._respond(ctx, spec, idle_risks, dangers, current, started)
        if isinstance(response, Send) and not (response.braking or response.unsaved) and self._joined_since(ctx):
            now = read_context(self.g)
            judged = await self._judged_now(ctx, now, dangers, response, led or current) if now is not None else None
            if now is None or judged is None:
                self.pending |= {(e.src, e.dst) for e, _ in dangers.values()}  # searched again, with them
                return
            if judged is not response:  # judged on W now, and sent as judged then
                response, ctx = judged, now
            self.judged_in = frozenset(now.ids.values())
        elif isinstance(response, Send) and response.sets_off is not None:
            response = await self._sooner(ctx, spec, max(idle_risks.values()), response, led or current)
        if isinstance(response, Send | NoMove) and response.sets_off is not None:
            await self.set_off.hold(self.g, ctx.scene.time, response.sets_off, self.log)
            world = self.g.find_node(WORLD)
            if world is None or episode_of(world) != ctx.episode:
                return  # the trial ended while the move was held
        self._act(ctx, dangers, response, led or current, led, started)

    def _judged_without_some(self, under_way: Node) -> bool:
        """Whether someone, or a target of a guess just landed, has come into W since ``under_way`` was last
        judged (during or after its search): that move was never imagined with them."""
        new = self.arrived | {n for edge in self.pending for n in edge}
        return under_way.get("action") != GO_TO and not new <= self.judged_in

    def _joined_since(self, ctx: Context) -> bool:
        """Whether someone has come into W since ``ctx`` was read: a move decided on it never imagined them."""
        known = set(ctx.ids.values())
        return any(n.id not in known for n in self.g.nodes(PERSON))

    async def _judged_now(
        self, searched: Context, now: Context, dangers: Dangers, send: Send, under_way: Node | None
    ) -> Send | None:
        """``send``'s move, chosen on ``searched``, judged again on ``now``, with whoever came into W since
        (:func:`judged_with_newcomers`); ``None`` when it harms one of them."""
        spec = search_spec(self.g, now, dangers, under_way, walking(self.args))
        idle_risk = max(e.get("probability", 1.0) for e, _ in dangers.values())
        newcomers = frozenset(p.name for p in now.scene.people) - {p.name for p in searched.scene.people}
        judging = judged_with_newcomers(send, spec, idle_risk, self._policy(now), newcomers)
        judged = await self.searches.run(judging, self._terms(now))
        self.log.info("move judged again with someone new in W", sent=judged is not None, newcomers=sorted(newcomers))
        return judged

    async def _sooner(
        self, ctx: Context, spec: SearchSpec, idle_risk: float, send: Send, under_way: Node | None
    ) -> Send:
        """``send``, or its move judged again to set off now (:func:`set_off_sooner`) when its search ended more
        than two candidates' estimated cost before the moment it imagined the move setting off.

        Only a move that protects every endangered person is judged again; braking is sent as found.
        """
        early = self.set_off.early(self.g, ctx.scene.time, send.sets_off)
        if early <= 2 * self.searches.judging.seconds * self.clock.rate(self.g) or send.braking or send.unsaved:
            return send
        now = replace(spec, current=move_of(under_way, ctx) if under_way is not None else None)
        judged = await self.searches.run(set_off_sooner(send, now, idle_risk, self._policy(ctx)), self._terms(ctx))
        self.log.info(
            "move judged again to set off sooner",
            sent=judged is not send,
            hold_ms=round(early * 1e3, 1),
        )
        return judged

    async def _respond(
        self,
        ctx: Context,
        spec: SearchSpec,
        idle_risks: dict[str, float],
        dangers: Dangers,
        current: Node | None,
        started: float,
    ) -> tuple[Response, Node | None]:
        """Run :func:`respond`, each search it asks for by the simulator; also the head start written, if any."""
        self.searches.begin()
        led: Node | None = None

        def lead(verdict: Verdict) -> None:
            nonlocal led
            if move_under_way(self.g) is not None:  # a move came under way since: the lead was judged from rest
                self.log.info("head start dropped", because="a move came under way during the search")
                return
            if self._joined_since(ctx):
                self.log.info("head start dropped", because="someone came into W during the search")
                return
            if self._write(ctx, verdict, dangers, None, None, "", started, head_start=True):
                led = move_under_way(self.g)

        # A head start, or a move to someone fallen, is not made for this danger: it gets no second look.
        under_way = (
            UnderWay(
                move_of(current, ctx),
                self.doubted == current.name or bool(current.get("head_start")) or current.get("action") == GO_TO,
            )
            if current is not None
            else None
        )
        responding = respond(spec, idle_risks, under_way, self._policy(ctx))
        return await self.searches.run(responding, self._terms(ctx), lead, lambda: led is not None), led

    def _act(
        self,
        ctx: Context,
        dangers: Dangers,
        response: Response,
        current: Node | None,
        led: Node | None,
        started: float,
    ) -> None:
        """Carry out ``response``: ``current`` is the move under way now (the head start ``led``, if one was sent)."""
        match response:
            case Keep(again, doubted=True):
                self.doubted = current.name if current is not None else None
                self.log.info("move doubted", under_way=again.reason, risk=round(again.risk, 2))
            case Keep(again, best_new=None):
                self.doubted = None
                if not again.clear:
                    self.log.info("move kept", under_way=again.reason, risk=round(again.risk, 2))
            case Keep(again, best_new=Verdict() as best):
                self.log.info(
                    "move kept",
                    under_way=again.reason,
                    risk=round(again.risk, 2),
                    best_new=best.reason,
                    new_risk=round(best.risk, 2),
                    search_ms=self._ms(started),
                )
            case NoMove(halt):
                self._no_move(ctx, dangers, started, led is not None)
                newest = move_under_way(self.g)
                # The head start ends with the search that sent it, unless another move has come under way since.
                if halt is not None and led is not None and newest is not None and newest.id == led.id:
                    self._write(ctx, halt, dangers, led, None, "", started, head_start=True)
            case Send(chosen, again, unsaved, braking):
                if braking:
                    self._no_move(ctx, dangers, started, False)
                self._write(ctx, chosen, dangers, current, again, ", ".join(unsaved), started)

    def _no_move(self, ctx: Context, dangers: Dangers, started: float, head_start: bool) -> None:
        """No move removes the danger: the people in it are searched for again only after ``--retry``."""
        for person in dangers:
            self.failed[ctx.ids[person]] = ctx.scene.time
        self.log.warning(
            "no move removes the danger",
            people=sorted(dangers),
            search_ms=self._ms(started),
            tried=len(self.searches.tried),
            why=sorted({v.reason for v in self.searches.tried})[:4],
            head_start=head_start,
        )

    def _terms(self, ctx: Context) -> SearchTerms:
        """What each search of a response on ``ctx`` is asked with."""
        return SearchTerms.reading(
            self.g,
            ctx.scene.time,
            self.set_off,
            Uncertainty(self.size_error, ctx.sigma, self.args.samples),
            self.args.risk_threshold,
            self.args.max_moves,
        )

    def _policy(self, ctx: Context) -> Policy:
        return Policy(self.args.risk_threshold, self.args.samples, ctx.scene.robot_name)

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
            tried=len(self.searches.tried),
            refused=sorted({v.reason for v in self.searches.tried if not v.clear})[:4],
            replaces=current.name if current is not None else None,
            because=under_way.reason if under_way is not None else None,
            search_ms=self._ms(started),
            rpc_ms=round(self.searches.rpc_ms, 1),
            sim_ms=round(self.searches.sim_ms, 1),
            since_risk_ms=round((time.time() - edge.get("updated_at", time.time())) * 1e3, 1),
        )
        return True

    @staticmethod
    def _ms(started: float) -> float:
        return round((time.perf_counter() - started) * 1e3, 1)


if __name__ == "__main__":
    main(Action)
