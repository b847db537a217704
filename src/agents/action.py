"""Algorithm 2: for each risky intention, find a robot move that removes the danger, and write it to W.

``python -m agents.action --graph G --connect EP [--scenario S]``

Triggered by a risky ``has_intention`` edge. The robot's only action is
``move_to(object)`` to a stand-off pose around it. The search is ordered so
that the first candidates are the likely ones, and stops at the first success:

1. objects: the one the person would hit first, then the others by distance to
   the collision point;
2. around each object, the stand-off poses straight behind it, then straight in
   front of it, along the person's way (a robot there is seen, and the detour
   around it also clears the obstacle), then the others;
3. a move whose straight-line travel time already misses the deadline is
   discarded without planning; the simulator plans the rest exactly.

Candidates are imagined in batches (one move first, then ``--batch``), each move together with every gaze
class of the person's replanned walk (with perception's uncertainty sampled).
A move removes the danger when the robot arrives before the predicted collision
and every class then walks safely; the search stops at the first such move that
arrives ``--react-margin`` seconds early, else takes the first that arrives at
all (or the budget ``--max-moves`` runs out). The chosen move
becomes the robot's ``intention`` node (``move_to``, target, imagined final
pose, ``status: proposed``), linked ``robot -has-> intention``.
"""

from __future__ import annotations

import argparse
import math
import time
from collections.abc import Iterator
from itertools import count, islice
from typing import Any

import numpy as np

from bridges import bus, keys
from caregiving.robot_moves import RobotMove, standoff_moves, travel_time
from caregiving.scenario import load_scenario
from caregiving.scene import Scene
from caregiving.visibility import WALL_KIND, gaze_classes
from wm import Edge

from .context import Context, read_context
from .intention import HAS_INTENTION, KNOWS
from .loop import Coalescer
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
                  obstacle: str) -> Iterator[RobotMove]:
    """Stand-off moves, most promising first, generated lazily (see the module documentation).

    Around the obstacle that would be hit, the poses straight behind it and
    straight in front of it along the person's way come first: a robot there is
    in the walker's view and the detour around it also clears the obstacle.
    """
    objects = [o for o in scene.obstacles if o.kind != WALL_KIND]
    objects.sort(key=lambda o: (o.name != obstacle, math.hypot(o.shape.x - point[0], o.shape.y - point[1])))
    dx, dy = travel_direction(path, point)
    for o in objects:
        around = standoff_moves(scene, o.name)
        cx, cy = o.shape.x, o.shape.y

        def key(m: RobotMove, cx: float = cx, cy: float = cy) -> tuple[float, float]:
            norm = math.hypot(m.x - cx, m.y - cy) or 1.0
            along = ((m.x - cx) * dx + (m.y - cy) * dy) / norm
            return -abs(along), -along

        yield from sorted(around, key=key)


class Action(Agent):
    """Selects a robot move that removes a risky intention (Algorithm 2)."""

    name = "action"

    @classmethod
    def add_arguments(cls, parser: argparse.ArgumentParser) -> None:
        parser.add_argument("--scenario", help="take the sensors' size error from this scenario")
        parser.add_argument("--size-error", type=float, help="bound of the object size bias (default 0.2)")
        parser.add_argument("--samples", type=int, default=64, help="sampled worlds per imagined walk")
        parser.add_argument("--risk-threshold", type=float, default=0.05, help="collision probability deemed risky")
        parser.add_argument("--react-margin", type=float, default=1.0,
                            help="seconds the robot should be in place before the collision")
        parser.add_argument("--batch", type=int, default=3, help="moves imagined per request")
        parser.add_argument("--max-moves", type=int, default=24, help="moves tried per danger at most")

    async def setup(self) -> None:
        a = self.args
        spec = load_scenario(a.scenario) if a.scenario else None
        self.size_error = a.size_error if a.size_error is not None else \
            (spec.sensors.size_error if spec and spec.sensors.enabled else 0.2)
        self.session = self.g.network.session  # type: ignore[union-attr]
        self.episode: int | None = None
        self.names = count(1)
        self.searches = 0
        self.loop = Coalescer(self.search, self.log, "search")
        self.g.on(self.loop.poke, type=HAS_INTENTION, kind=["edge_added", "edge_updated"])
        self.g.on(self._world_changed, type="world")
        self.log.info("acting", size_error=self.size_error, react_margin=a.react_margin)

    async def teardown(self) -> None:
        self.loop.cancel()

    def _world_changed(self, event: Any) -> None:
        if "episode" in event.attrs:
            self.loop.poke()

    def _clear(self, episode: int) -> None:
        """A new trial: forget the robot's intentions of the last one."""
        with self.g.batch():
            for node in self.g.nodes(INTENTION):
                self.g.delete_node(node.id)
        self.episode = episode

    async def search(self) -> None:
        ctx = read_context(self.g)
        if ctx is None:
            return
        if ctx.episode != self.episode:
            self._clear(ctx.episode)
        for edge in self.g.edges(type=HAS_INTENTION):
            if not edge.get("risky") or self._handled(edge.src):
                continue
            await self._act(ctx, edge)

    def _handled(self, person: int) -> bool:
        return any(n.get("person") == person and n.get("status") in LIVE for n in self.g.nodes(INTENTION))

    async def _act(self, ctx: Context, edge: Edge) -> None:
        a = self.args
        names = {v: k for k, v in ctx.ids.items()}
        person, target, obstacle = names.get(edge.src), names.get(edge.dst), names.get(edge.get("collision_object"))
        if person is None or target is None or obstacle is None:
            return
        self.searches += 1
        p = ctx.scene.person(person)
        flat = edge.get("path", ())
        path = list(zip(flat[0::2], flat[1::2], strict=True))
        ttc = edge.get("time_to_collision", 0.0) - max(ctx.scene.time - edge.get("at_time", ctx.scene.time), 0.0)
        point = tuple(edge.get("collision_point", (p.x, p.y)))
        classes = gaze_classes(p, ctx.scene.bodies_around(person))
        robot = ctx.scene.robot
        assert robot is not None
        feasible = (m for m in ordered_moves(ctx.scene, path, point, obstacle)
                    if travel_time(math.hypot(m.x - robot.x, m.y - robot.y), robot.max_speed, robot.max_accel) < ttc)
        fallback: RobotMove | None = None
        tried, size, started = 0, 1, time.perf_counter()
        while tried < a.max_moves and (batch := list(islice(feasible, size))):
            tried += len(batch)
            for move, arrival in await self._safe_moves(ctx, person, target, batch, classes, ttc):
                if arrival < ttc - a.react_margin:
                    self._write(ctx, edge, move, a.react_margin, tried, started)
                    return
                fallback = fallback or move
            if fallback is not None:
                break  # a move in time but without the margin: take it rather than search on
            size = a.batch
        if fallback is not None:
            self._write(ctx, edge, fallback, 0.0, tried, started)
            return
        self.log.warning("no move removes the danger", person=person, target=target, ttc=round(ttc, 2), tried=tried)

    async def _safe_moves(self, ctx: Context, person: str, target: str, moves: list[RobotMove],
                          classes: tuple[Any, ...], deadline: float) -> list[tuple[RobotMove, float]]:
        """The moves (with their arrival times) after which every gaze class walks safely, in order."""
        a = self.args
        uncertainty = {"size_error": self.size_error, "sigma": ctx.sigma, "samples": a.samples, "seed": 0}
        pid = ctx.ids[person]
        known = sorted({self.g.get_node(e.dst).name for e in self.g.edges(type=KNOWS, src=pid)})
        items = [{"kind": "joint", "person": person, "target": target, "gaze": c.gaze, "move": m.to_wire(),
                  "known": known, "uncertainty": uncertainty} for m in moves for c in classes]
        asked = time.perf_counter()
        reply = await bus.ask(self.session, keys.imagine(a.graph), {"items": items})
        self.log.debug("imagined", items=len(items), rpc_ms=round((time.perf_counter() - asked) * 1e3, 1),
                       compute_ms=round(reply["compute_ms"], 1))
        results = reply["results"]
        per = len(classes)
        good = []
        for k, m in enumerate(moves):
            answers = results[k * per:(k + 1) * per]
            if all(self._safe(x, deadline) for x in answers):
                good.append((m, answers[0]["result"]["robot_arrival"]))
        return good

    def _safe(self, answer: dict[str, Any], deadline: float) -> bool:
        if not answer["ok"]:
            return False
        r = answer["result"]
        walk = r["person"]
        return bool(r["robot_reachable"] and r["robot_arrival"] is not None and r["robot_arrival"] < deadline
                    and walk["reachable"] and not walk["collided"]
                    and answer["risk"]["probability"] < self.args.risk_threshold)

    def _write(self, ctx: Context, edge: Edge, move: RobotMove, margin: float, tried: int, started: float) -> None:
        g = self.g
        robot = ctx.scene.robot
        assert robot is not None
        if g.find_node(edge.src) is None:
            return
        with g.batch():
            node = g.insert_node(INTENTION, f"move_to_{ctx.episode}_{next(self.names)}", {
                "action": "move_to", "target": ctx.ids[move.target], "final_pose": [move.x, move.y, move.heading],
                "status": "proposed", "created_at": time.time(), "person": edge.src,
                "observed_at": edge.get("observed_at", 0.0), "risk_at": edge.get("updated_at", 0.0),
                "at_time": ctx.scene.time, "time_to_collision": edge.get("time_to_collision", 0.0),
                "reason": f"prevents {edge.get('collision_object')} on the way to {edge.dst}; margin {margin:g} s"})
            g.insert_or_assign_edge(ctx.ids[robot.name], node, "has", {"status": "proposed", "updated_at": time.time()})
        self.log.info("move chosen", target=move.target, x=round(move.x, 2), y=round(move.y, 2), margin=margin,
                      tried=tried, search_ms=round((time.perf_counter() - started) * 1e3, 1),
                      since_risk_ms=round((time.time() - edge.get("updated_at", time.time())) * 1e3, 1))


if __name__ == "__main__":
    main(Action)
