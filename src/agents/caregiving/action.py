"""Algorithm 2: for the risky intentions in W, find a robot move that removes the danger, and write it to W.

``python -m agents.caregiving.action --graph G --connect EP [--scenario S]``

Triggered by each risky ``has_intention`` edge as it lands in W. The search
itself is :mod:`agents.caregiving.model.move_search`; this agent turns W into its input,
asks the simulator to imagine the candidates, and writes the result:

* every endangered person is protected by one search, which the simulator runs
  next to its imagination in one request (no round trip per candidate): the
  candidates of all their dangers, interleaved, each imagined in time
  (:mod:`agents.caregiving.model.joint`) with every gaze class of each endangered
  person, the other people walking their likeliest intentions beside them, and
  perception's uncertainty sampled, one at a time up to the first safe one;
* when no single move keeps everyone safe, each danger is searched alone, most
  urgent first, and the move found is written with the people it leaves unsaved;
* while a move is under way, a new risky intention first re-imagines that move
  from the robot's current state, speed included; only if it no longer keeps
  everyone safe is a new move searched, and only a move that ranks clearly above
  it, judged in the same frame, replaces it (:func:`~agents.caregiving.model.move_search.replaces`);
  the old one is then marked ``superseded``;
* a move is never sent when its imagination shows a fall that would not happen
  without it: every imagined walk with it is clear, but for a bystander's fall
  into the very object their own risky intention already heads for (a danger not
  searched now, say because no move saved it a moment ago), and but for a gaze
  other than the one the danger was found at, where the person falls with the
  robot as it is too (the move then saves them if their gaze is the one found):
  robot never causes a collision its imagination can see;
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
import math
import time
from dataclasses import replace
from itertools import count

from agents.caregiving import keys
from agents.caregiving.model import imagine_reply
from agents.caregiving.model.candidates import Danger
from agents.caregiving.model.move_search import SearchItem, SearchSpec, replaces
from agents.caregiving.model.robot_moves import RobotMove
from agents.caregiving.model.rollout import DT
from agents.caregiving.model.uncertainty import Uncertainty
from agents.caregiving.model.verdict import SearchResult, Verdict
from agents.caregiving.model.visibility import GazeClass, gaze_classes
from agents.caregiving.model.world_model import Walk
from wm import Edge, Event, Node

from ..runtime import Agent, main, on
from .context import Context, read_context
from .names import HAS, HAS_INTENTION, INTENTION, KNOWS, ROBOT, WORLD
from .risk_options import add_risk_arguments, size_error

LIVE = ("proposed", "active")
#: Wall seconds one candidate move takes to judge in the simulator, until the first search has measured it.
JUDGING = 0.03
#: Weight of the newest search in the running estimate of the time a candidate takes to judge.
JUDGING_WEIGHT = 0.3


def risky_first(classes: tuple[GazeClass, ...], risky: float) -> tuple[float, ...]:
    """The classes' gazes, the class holding the ``risky`` gaze first."""
    gazes = [c.gaze for c in classes]
    first = min(
        range(len(classes)),
        key=lambda k: 0.0 if classes[k].low <= risky <= classes[k].high else abs(classes[k].gaze - risky),
    )
    return (gazes[first], *gazes[:first], *gazes[first + 1 :])


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
        self.clock: tuple[float, float] | None = None  # (simulated, wall) seconds of the first odometry this trial
        self.new_episode = True
        self.failed: dict[int, float] = {}
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
            self._clear(ctx.episode)
        landed = [self.g.find_edge(src, dst, HAS_INTENTION) for src, dst in self.pending]
        self.pending.clear()
        dangers = self._dangers(ctx, [e for e in landed if e is not None and e.get("risky")])
        if not dangers:
            return
        started = time.perf_counter()
        self.rpc_ms = self.sim_ms = 0.0
        current = self._current()
        spec = self._spec(ctx, dangers, current)
        under_way: Verdict | None = None
        if current is not None:
            again = await self._search(ctx, spec, 1.0, [self._move_of(current)])
            under_way = again.verdicts[0] if again is not None and again.verdicts else None
            if under_way is not None and under_way.safe(self.args.risk_threshold):
                return  # the move under way still keeps everyone safe
        robot = ctx.scene.robot.name if ctx.scene.robot else None
        idle_risk = max(e.get("probability", 1.0) for e, _ in dangers.values())
        self.tried = []
        chosen, unsaved = await self._find(ctx, spec, idle_risk), ""
        if chosen is None and len(spec.dangers) > 1:
            for d in sorted(spec.dangers, key=lambda d: d.time_to_collision):
                alone = replace(spec, dangers=(d,))
                chosen = await self._find(ctx, alone, dangers[d.person][0].get("probability", 1.0))
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
            )
            if under_way is not None and under_way.move is not None and under_way.trips(robot):
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

    # -- reading W -----------------------------------------------------------------------------
    def _clear(self, episode: int) -> None:
        """A new trial: forget the robot's intentions of the last one."""
        with self.g.batch():
            for node in self.g.nodes(INTENTION):
                self.g.delete_node(node.id)
        self.episode = episode
        self.failed.clear()
        self.clock = None

    def _dangers(self, ctx: Context, risky: list[Edge]) -> dict[str, tuple[Edge, Danger]]:
        """Each endangered person's most urgent danger that is not yet due nor failed too recently."""
        names = {v: k for k, v in ctx.ids.items()}
        out: dict[str, tuple[Edge, Danger]] = {}
        for edge in risky:
            person, target, obstacle = names.get(edge.src), names.get(edge.dst), names.get(edge.get("collision_object"))
            ttc = edge.get("time_to_collision", 0.0) - max(ctx.scene.time - edge.get("at_time", ctx.scene.time), 0.0)
            recent = ctx.scene.time - self.failed.get(edge.src, -math.inf) < self.args.retry
            if person is None or target is None or obstacle is None or ttc <= 0.0 or recent:
                continue
            flat = edge.get("path", ())
            p = ctx.scene.person(person)
            danger = Danger(
                person,
                target,
                tuple(zip(flat[0::2], flat[1::2], strict=True)),
                tuple(edge.get("collision_point", (p.x, p.y))),
                obstacle,
                ttc,
            )
            if person not in out or ttc < out[person][1].time_to_collision:
                out[person] = (edge, danger)
        return out

    def _spec(self, ctx: Context, dangers: dict[str, tuple[Edge, Danger]], current: Node | None) -> SearchSpec:
        scene, names = ctx.scene, {v: k for k, v in ctx.ids.items()}
        known = {
            p: tuple(sorted(names[e.dst] for e in self.g.edges(type=KNOWS, src=ctx.ids[p]) if e.dst in names))
            for p in dangers
        }
        gazes = {
            p: risky_first(gaze_classes(scene.person(p), scene.bodies_around(p)), edge.get("gaze", 0.0))
            for p, (edge, _) in dangers.items()
        }
        bystanders, falling = [], {}
        for p in scene.people:
            walks = [e for e in self.g.edges(type=HAS_INTENTION, src=ctx.ids[p.name]) if e.dst in names]
            if p.name not in dangers and walks:
                e = max(walks, key=lambda e: e.get("updated_at", 0.0))  # their likeliest walk: the latest guessed
                bystanders.append(Walk(p.name, names[e.dst], e.get("gaze", 0.0)))
                if e.get("risky") and e.get("collision_object") in names:  # a danger not searched now
                    falling[p.name] = names[e.get("collision_object")]
        return SearchSpec(
            tuple(d for _, d in dangers.values()),
            gazes,
            known,
            tuple(bystanders),
            self._move_of(current) if current is not None else None,
            falling=falling,
        )

    def _current(self) -> Node | None:
        """The robot's move under way (or about to be), if any."""
        live = [n for n in self.g.nodes(INTENTION) if n.get("status") in LIVE]
        return max(live, key=lambda n: n.get("created_at", 0.0), default=None)

    @staticmethod
    def _move_of(node: Node) -> RobotMove | None:
        """The move an intention drives, ``None`` for a stop."""
        if node.get("action") == "stop":
            return None
        x, y, heading = node.get("final_pose")
        return RobotMove(str(node.get("target")), x, y, heading)

    # -- asking the simulator ------------------------------------------------------------------
    async def _search(
        self, ctx: Context, spec: SearchSpec, idle_risk: float, moves: list[RobotMove | None] | None = None
    ) -> SearchResult | None:
        """One search, run by the simulator; each candidate imagines the robot starting when its command would arrive.

        ``moves`` judges those moves instead of the generated candidates (``None``: braking). None when the
        simulator refused.
        """
        item = SearchItem(
            replace(spec, delay=self._delay(ctx)),
            self._uncertainty(ctx),
            self.args.risk_threshold,
            len(moves) if moves else self.args.max_moves,
            idle_risk,
            self.judging * self._rate(),
            tuple(moves) if moves else None,
        )
        sent = time.perf_counter()
        reply = await self.ask(keys.imagine(self.args.graph), {"items": [item.to_wire()]}, decode=imagine_reply.decode)
        self.rpc_ms += (time.perf_counter() - sent) * 1e3
        self.sim_ms += reply.compute_ms
        found = reply.results[0].search if len(reply.results) == 1 else None
        if found is None:
            self.log.error("the simulator refused the search", error=reply.results[0].error if reply.results else None)
            return None
        if found.verdicts:
            per_move = reply.compute_ms / 1e3 / len(found.verdicts)
            self.judging += JUDGING_WEIGHT * (per_move - self.judging)
        return found

    async def _braking(self, ctx: Context, spec: SearchSpec, under_way: Verdict, robot: str | None) -> Verdict | None:
        """Braking to a stop, judged now, if it ranks clearly above the move under way."""
        found = await self._search(ctx, spec, 1.0, [None])
        braking = found.verdicts[0] if found is not None and found.verdicts else None
        return braking if braking is not None and replaces(braking, under_way, self.args.samples, robot) else None

    def _uncertainty(self, ctx: Context) -> Uncertainty:
        return Uncertainty(self.size_error, ctx.sigma, self.args.samples)

    async def _find(self, ctx: Context, spec: SearchSpec, idle_risk: float) -> Verdict | None:
        """The move the search chose for ``spec``, if any; every verdict on the way joins :attr:`tried`."""
        found = await self._search(ctx, spec, idle_risk)
        if found is None:
            return None
        self.tried += found.verdicts
        return found.chosen

    # -- writing W -----------------------------------------------------------------------------
    def _write(
        self,
        ctx: Context,
        chosen: Verdict,
        dangers: dict[str, tuple[Edge, Danger]],
        current: Node | None,
        under_way: Verdict | None,
        unsaved: str,
        started: float,
    ) -> None:
        g, move = self.g, chosen.move
        robot = ctx.scene.robot
        assert robot is not None
        edge, danger = min(dangers.values(), key=lambda x: x[1].time_to_collision)
        if g.find_node(edge.src) is None:
            return
        reason = f"{chosen.reason}; protects {', '.join(sorted(dangers))}"
        if unsaved:
            reason += f"; not saved: {unsaved} (no single move keeps everyone safe)"
        with g.batch():
            if current is not None and g.find_node(current.id) is not None:
                g.update_node(current.id, {"status": "superseded"})
            node = g.insert_node(
                INTENTION,
                f"{'move_to' if move else 'stop'}_{ctx.episode}_{next(self.names)}",
                {
                    **(
                        {
                            "action": "move_to",
                            "target": ctx.ids.get(move.target, 0),
                            "final_pose": [move.x, move.y, move.heading],
                        }
                        if move
                        else {"action": "stop", "target": ctx.ids[robot.name]}
                    ),
                    "status": "proposed",
                    "created_at": time.time(),
                    "person": edge.src,
                    "observed_at": edge.get("observed_at", 0.0),
                    "risk_at": edge.get("updated_at", 0.0),
                    "at_time": ctx.scene.time,
                    "time_to_collision": danger.time_to_collision,
                    "in_time": chosen.in_time(danger.time_to_collision),
                    "reason": reason,
                },
            )
            g.insert_or_assign_edge(ctx.ids[robot.name], node, HAS, {"status": "proposed", "updated_at": time.time()})
        self.log.info(
            "move chosen" if move else "braking",
            **({"target": move.target, "x": round(move.x, 2), "y": round(move.y, 2)} if move else {}),
            in_time=chosen.in_time(danger.time_to_collision),
            risk=round(chosen.risk, 2),
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

    def _delay(self, ctx: Context) -> float:
        """When a move decided now would reach the world, in simulated seconds after the context.

        The world has gone on past the context already (sensor latency, then Algorithm 1 and the search so
        far: the robot's odometry in W says by how much), and the executor and the world take ``--dispatch``
        more. The search adds the time it spends judging, candidate by candidate.
        """
        robot = self._robot_node()
        lag = (robot.get("stamp", ctx.scene.time) if robot is not None else ctx.scene.time) - ctx.scene.time
        return max(lag, 0.0) + self.args.dispatch

    def _rate(self) -> float:
        """Simulated seconds per wall second, as the robot's odometry in W shows them (1 until it has)."""
        robot = self._robot_node()
        if robot is None or robot.get("stamp") is None or robot.get("written_at") is None:
            return 1.0
        now = (float(robot.get("stamp")), float(robot.get("written_at")))
        if self.clock is None or now[0] < self.clock[0]:
            self.clock = now
        sim, wall = now[0] - self.clock[0], now[1] - self.clock[1]
        return sim / wall if wall > 0.5 and sim > 0.0 else 1.0

    def _robot_node(self) -> Node | None:
        """The robot as W holds it, with its odometry (``stamp``, ``written_at``)."""
        return next(iter(self.g.nodes(ROBOT)), None)

    @staticmethod
    def _ms(started: float) -> float:
        return round((time.perf_counter() - started) * 1e3, 1)


if __name__ == "__main__":
    main(Action)
