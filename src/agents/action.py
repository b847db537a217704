"""Algorithm 2: for each risky intention, find a robot move that removes the danger, and write it to W.

``python -m agents.action --graph G --connect EP [--scenario S]``

Triggered by each risky ``has_intention`` edge as it lands in W: only the
edges added or updated since the last search are searched, the most urgent
(shortest time to collision) first. A danger whose collision is already due is
skipped at once, and one no move removed is searched again only after
``--retry`` simulated seconds. The robot's only action is
``move_to(object)`` to a stand-off pose around it. The search is ordered so
that the first candidates are the likely ones, and stops at the first success:

1. objects: the one the person would hit first, then the others by distance to
   the collision point;
2. around each object, the stand-off poses straight behind it, then straight in
   front of it, along the person's way (a robot there is seen, and the detour
   around it also clears the obstacle), then the others;
3. an object whose nearest stand-off pose the robot cannot reach before the
   deadline in a straight line is skipped, and so is a move whose straight-line
   travel time misses it, without planning; the simulator plans the rest exactly.

Candidates are imagined in batches (one move first, then ``--batch``), each move together with every gaze
class of the person's replanned walk (with perception's uncertainty sampled).
A move removes the danger when the robot arrives before the predicted collision
and every class then walks safely; the search stops at the first such move that
arrives ``--react-margin`` seconds early, else takes the first that arrives at
all (or the budget ``--max-moves`` runs out). The chosen move
becomes the robot's ``intention`` node (``move_to``, target, imagined final
pose, ``status: proposed``, ``in_time: true``), linked ``robot -has-> intention``.

With ``--late-moves N`` (off by default: in the 180-trial run such moves caused
more collisions than they prevented, see docs/caregiving.md), when no move
arrives in time the search goes on, in the same batches, over the first ``--late-moves``
candidates in the same order without the deadline; the first after which every
gaze class walks safely is written with ``in_time: false`` (it removes the
danger only if the person is slower than imagined or sees the robot on its
way). If none does, nothing is written.
"""

from __future__ import annotations

import argparse
import math
import time
from collections.abc import Iterator
from dataclasses import dataclass
from itertools import count, islice
from typing import Any

import numpy as np

from bridges import bus, keys
from caregiving.geometry import bounding_radius
from caregiving.robot_moves import RobotMove, robot_fits, standoff_poses, travel_time
from caregiving.scene import Obstacle, Scene
from caregiving.visibility import WALL_KIND, GazeClass, gaze_classes
from wm import Edge

from .context import Context, read_context
from .intention import HAS_INTENTION, KNOWS
from .loop import Coalescer
from .risk_options import add_risk_arguments, size_error
from .runtime import Agent, main

INTENTION = "intention"
LIVE = ("proposed", "active", "done")


def travel_direction(path: list[tuple[float, float]], point: tuple[float, float]) -> tuple[float, float]:
    """Unit direction of the person's path where it comes closest to ``point``."""
    if len(path) < 2:
        return 1.0, 0.0
    pts = np.asarray(path, dtype=float)
    seg = np.diff(pts, axis=0)
    k = int(np.argmin(np.linalg.norm(pts[:-1] + seg / 2 - np.asarray(point), axis=1)))
    norm = float(np.hypot(*seg[k])) or 1.0
    return float(seg[k][0] / norm), float(seg[k][1] / norm)


def ordered_moves(scene: Scene, path: list[tuple[float, float]], point: tuple[float, float],
                  obstacle: str, deadline: float) -> Iterator[RobotMove]:
    """Stand-off moves a straight drive can finish by ``deadline``, most promising first, generated lazily.

    The order is the module documentation's. Around the obstacle that would be hit, the poses straight behind it and
    straight in front of it along the person's way come first: a robot there is
    in the walker's view and the detour around it also clears the obstacle.
    """
    robot = scene.robot
    assert robot is not None

    def reachable(o: Obstacle) -> bool:
        gap = math.hypot(o.shape.x - robot.x, o.shape.y - robot.y) - bounding_radius(o.shape) - max(robot.length,
                                                                                                     robot.width)
        return travel_time(max(gap, 0.0), robot.max_speed, robot.max_accel) < deadline

    objects = [o for o in scene.obstacles if o.kind != WALL_KIND and reachable(o)]
    objects.sort(key=lambda o: (o.name != obstacle, math.hypot(o.shape.x - point[0], o.shape.y - point[1])))
    dx, dy = travel_direction(path, point)
    for o in objects:
        around = standoff_poses(scene, o.name)
        cx, cy = o.shape.x, o.shape.y

        def key(m: RobotMove, cx: float = cx, cy: float = cy) -> tuple[float, float]:
            norm = math.hypot(m.x - cx, m.y - cy) or 1.0
            along = ((m.x - cx) * dx + (m.y - cy) * dy) / norm
            return -abs(along), -along

        # The fit test is the costly part: run it only on the moves the search reaches, after the cheap
        # straight-line time test.
        yield from (m for m in sorted(around, key=key)
                    if travel_time(math.hypot(m.x - robot.x, m.y - robot.y), robot.max_speed, robot.max_accel)
                    < deadline and robot_fits(scene, m))


@dataclass
class _Search:
    """The search for a move that removes one danger: its intention, candidates and what was found so far."""

    edge: Edge
    danger: tuple[int, int, str]
    person: str
    target: str
    ttc: float
    classes: tuple[GazeClass, ...]
    known: list[str]
    path: list[tuple[float, float]]
    point: tuple[float, float]
    obstacle: str
    moves: Iterator[RobotMove]
    tried: int = 0
    chosen: RobotMove | None = None
    margin: float = 0.0
    in_time: bool = True
    over: bool = False
    next_batch: int = 1  # moves to imagine in the next round: the likeliest alone, then --batch at a time


class Action(Agent):
    """Selects a robot move that removes a risky intention (Algorithm 2)."""

    name = "action"

    @classmethod
    def add_arguments(cls, parser: argparse.ArgumentParser) -> None:
        add_risk_arguments(parser)
        parser.add_argument("--react-margin", type=float, default=1.0,
                            help="seconds the robot should be in place before the collision")
        parser.add_argument("--batch", type=int, default=3, help="moves imagined per request")
        parser.add_argument("--max-moves", type=int, default=24, help="moves tried per danger at most")
        parser.add_argument("--late-moves", type=int, default=0,
                            help="moves imagined without the deadline when none arrives in time (default: none; "
                            "see docs/caregiving.md for why late moves are off)")
        parser.add_argument("--retry", type=float, default=1.0,
                            help="simulated seconds before a danger no move removed is searched again")

    async def setup(self) -> None:
        a = self.args
        self.size_error = size_error(a)
        self.session = self.g.network.session  # type: ignore[union-attr]
        self.episode: int | None = None
        self.names = count(1)
        self.searches = 0
        self.rpc_ms = self.sim_ms = 0.0  # the current search's imagine round trips, and their time in the simulator
        self.pending: set[tuple[int, int]] = set()
        self.new_episode = True
        self.failed: dict[tuple[int, int, str], float] = {}
        self.loop = Coalescer(self.search, self.log, "search")
        self.g.on(self._intention_changed, type=HAS_INTENTION, kind=["edge_added", "edge_updated"])
        self.g.on(self._world_changed, type="world")
        self.log.info("acting", size_error=self.size_error, react_margin=a.react_margin)

    async def teardown(self) -> None:
        self.loop.cancel()

    def _intention_changed(self, event: Any) -> None:
        self.pending.add((event.src, event.dst))
        self.loop.poke()

    def _world_changed(self, event: Any) -> None:
        if "episode" in event.attrs:
            self.new_episode = True
            self.loop.poke()

    def _clear(self, episode: int) -> None:
        """A new trial: forget the robot's intentions of the last one."""
        with self.g.batch():
            for node in self.g.nodes(INTENTION):
                self.g.delete_node(node.id)
        self.episode = episode
        self.failed.clear()

    async def search(self) -> None:
        """Search the risky intentions that landed since the last search, breadth first across them."""
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
        risky = sorted((e for e in landed if e is not None and e.get("risky") and not self._handled(e.src)),
                       key=lambda e: self._deadline(ctx, e))
        searches = [s for e in risky if (s := self._start(ctx, e)) is not None]
        started = time.perf_counter()
        self.rpc_ms = self.sim_ms = 0.0
        served: set[int] = set()  # people a move was written for
        while searches:
            rounds = [(s, list(islice(s.moves, s.next_batch))) for s in searches]
            asked = [(s, moves) for s, moves in rounds if moves]
            answers = await self._safe_moves(ctx, asked) if asked else []
            for (s, moves), good in zip(asked, answers, strict=True):
                s.tried, s.next_batch = s.tried + len(moves), self.args.batch
                for move, arrival in good:
                    if not s.in_time or arrival < s.ttc - self.args.react_margin:
                        s.chosen, s.margin = move, self.args.react_margin if s.in_time else 0.0
                        break
                    s.chosen = s.chosen or move  # in time but without the margin: take it rather than search on
            for s, moves in rounds:
                if s.edge.src in served:
                    continue
                if s.chosen is not None:
                    self._write(ctx, s, started)
                    served.add(s.edge.src)
                elif not moves or s.in_time and s.tried >= self.args.max_moves:
                    if s.in_time and self.args.late_moves > 0:
                        s.in_time, s.moves = False, islice(self._ordered(ctx, s, math.inf), self.args.late_moves)
                        s.next_batch = 1
                        continue
                    s.over = True
                    self.failed[s.danger] = ctx.scene.time
                    self.log.warning("no move removes the danger", person=s.person, target=s.target,
                                     ttc=round(s.ttc, 2), tried=s.tried)
            searches = [s for s, _ in rounds if s.chosen is None and not s.over and s.edge.src not in served]

    @staticmethod
    def _deadline(ctx: Context, edge: Edge) -> float:
        """Simulated seconds left before the intention's predicted collision."""
        return edge.get("time_to_collision", 0.0) - max(ctx.scene.time - edge.get("at_time", ctx.scene.time), 0.0)

    def _handled(self, person: int) -> bool:
        return any(n.get("person") == person and n.get("status") in LIVE for n in self.g.nodes(INTENTION))

    def _start(self, ctx: Context, edge: Edge) -> _Search | None:
        """The search for one danger, or None when it is due already or failed too recently."""
        names = {v: k for k, v in ctx.ids.items()}
        person, target, obstacle = names.get(edge.src), names.get(edge.dst), names.get(edge.get("collision_object"))
        if person is None or target is None or obstacle is None:
            return None
        ttc = self._deadline(ctx, edge)
        danger = (edge.src, edge.dst, obstacle)
        if ttc <= 0.0 or ctx.scene.time - self.failed.get(danger, -math.inf) < self.args.retry:
            return None
        self.searches += 1
        p = ctx.scene.person(person)
        flat = edge.get("path", ())
        path = list(zip(flat[0::2], flat[1::2], strict=True))
        point = tuple(edge.get("collision_point", (p.x, p.y)))
        pid = ctx.ids[person]
        known = sorted({self.g.get_node(e.dst).name for e in self.g.edges(type=KNOWS, src=pid)})
        s = _Search(edge, danger, person, target, ttc, gaze_classes(p, ctx.scene.bodies_around(person)), known,
                    path, point, obstacle, iter(()))
        s.moves = self._ordered(ctx, s, ttc)
        return s

    @staticmethod
    def _ordered(ctx: Context, s: _Search, deadline: float) -> Iterator[RobotMove]:
        """The search's candidate moves in order, without those a straight drive cannot finish by ``deadline``."""
        return ordered_moves(ctx.scene, s.path, s.point, s.obstacle, deadline)

    async def _safe_moves(self, ctx: Context, asked: list[tuple[_Search, list[RobotMove]]]
                          ) -> list[list[tuple[RobotMove, float]]]:
        """For each search, the moves (with arrival times) after which every gaze class walks safely, in order.

        One request holds every search's moves, each with every gaze class of its person. A search past
        its in-time moves does not hold the robot's arrival time against the time to collision.
        """
        a = self.args
        uncertainty = {"size_error": self.size_error, "sigma": ctx.sigma, "samples": a.samples, "seed": 0}
        items = [{"kind": "joint", "person": s.person, "target": s.target, "gaze": c.gaze, "move": m.to_wire(),
                  "known": s.known, "uncertainty": uncertainty} for s, moves in asked for m in moves for c in s.classes]
        sent = time.perf_counter()
        reply = await bus.ask(self.session, keys.imagine(a.graph), {"items": items})
        self.rpc_ms += (time.perf_counter() - sent) * 1e3
        self.sim_ms += reply["compute_ms"]
        results = iter(reply["results"])
        good: list[list[tuple[RobotMove, float]]] = []
        for s, moves in asked:
            good.append([])
            for m in moves:
                answers = list(islice(results, len(s.classes)))
                if all(self._safe(x, s.ttc if s.in_time else math.inf) for x in answers):
                    good[-1].append((m, answers[0]["result"]["robot_arrival"]))
        return good

    def _safe(self, answer: dict[str, Any], deadline: float) -> bool:
        if not answer["ok"]:
            return False
        r = answer["result"]
        walk = r["person"]
        return bool(r["robot_reachable"] and r["robot_arrival"] is not None and r["robot_arrival"] < deadline
                    and walk["reachable"] and not walk["collided"]
                    and answer["risk"]["probability"] < self.args.risk_threshold)

    def _write(self, ctx: Context, s: _Search, started: float) -> None:
        g, edge, move = self.g, s.edge, s.chosen
        robot = ctx.scene.robot
        assert robot is not None and move is not None
        if g.find_node(edge.src) is None:
            return
        with g.batch():
            node = g.insert_node(INTENTION, f"move_to_{ctx.episode}_{next(self.names)}", {
                "action": "move_to", "target": ctx.ids[move.target], "final_pose": [move.x, move.y, move.heading],
                "status": "proposed", "created_at": time.time(), "person": edge.src,
                "observed_at": edge.get("observed_at", 0.0), "risk_at": edge.get("updated_at", 0.0),
                "at_time": ctx.scene.time, "time_to_collision": edge.get("time_to_collision", 0.0),
                "in_time": s.in_time, "reason": f"prevents {edge.get('collision_object')} on the way to {edge.dst}; "
                + (f"margin {s.margin:g} s" if s.in_time else "arrives after the predicted collision")})
            g.insert_or_assign_edge(ctx.ids[robot.name], node, "has", {"status": "proposed", "updated_at": time.time()})
        self.log.info("move chosen", target=move.target, x=round(move.x, 2), y=round(move.y, 2), margin=s.margin,
                      in_time=s.in_time, tried=s.tried, search_ms=round((time.perf_counter() - started) * 1e3, 1),
                      rpc_ms=round(self.rpc_ms, 1), sim_ms=round(self.sim_ms, 1),
                      since_risk_ms=round((time.time() - edge.get("updated_at", time.time())) * 1e3, 1))


if __name__ == "__main__":
    main(Action)
