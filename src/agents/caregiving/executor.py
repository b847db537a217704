"""The executor: drives the robot to its chosen intention through the world bridge.

``python -m agents.caregiving.executor --graph G --connect EP``

A ``proposed`` robot ``intention`` (``move_to`` or ``go_to`` with a ``final_pose``, or ``stop``)
is sent as a command on ``robot/cmd``; it becomes ``active`` when the world accepts it
and ``failed`` when it refuses (no path) or cannot be reached. An active
intention is ``done`` once the robot, as placed in W, rests at the final pose
(a ``stop``: once it rests).
A new proposed intention while one is under way is sent at once: the world
changes the robot's course without stopping (the action agent has marked the
old one ``superseded``).
The status is written on the node and on its ``robot -has-> intention`` edge.
"""

from __future__ import annotations

import argparse
import math
import time
from typing import Any

from agents.caregiving import keys
from wm import Event, Node

from ..messaging import MessageError
from ..runtime import Agent, every, main, on
from .context import episode_of
from .names import HAS, INTENTION, MOVES, ROBOT, STOP, WORLD


class Executor(Agent):
    """Turns the robot's intentions into motion commands and reports how they end."""

    name = "executor"

    @classmethod
    def add_arguments(cls, parser: argparse.ArgumentParser) -> None:
        parser.add_argument("--arrived", type=float, default=0.05, help="metres from the final pose counted as there")

    async def setup(self) -> None:
        self.commands = 0

    def _status(self, node: Node, status: str, reason: str | None = None) -> None:
        g = self.g
        with g.batch():
            g.update_node(node.id, {"status": status, **({"reason": reason} if reason else {})})
            for e in g.edges(type=HAS, dst=node.id):
                g.insert_or_assign_edge(e.src, node.id, HAS, {"status": status, "updated_at": time.time()})

    @on(type=INTENTION, kind="node_added", coalesce=True)
    async def dispatch(self, _events: list[Event]) -> None:
        """Send every proposed move that has not been sent yet."""
        world = self.g.find_node(WORLD)
        episode = episode_of(world)
        for node in self.g.nodes(INTENTION):
            if node.get("status") != "proposed" or node.get("action") not in MOVES:
                continue
            request: dict[str, Any] = {"trial": episode, "move": None, "action": node.get("action")}  # None: brake
            if node.get("action") != STOP:
                x, y, heading = node.get("final_pose")
                request["move"] = {"target": str(node.get("target")), "x": x, "y": y, "heading": heading}
            try:
                reply: dict[str, Any] = await self.ask(keys.robot_cmd(self.args.graph), request, timeout=2.0)
            except MessageError as exc:
                self._status(node, "failed", str(exc))
                self.log.warning("command refused", intention=node.name, error=str(exc))
                continue
            self.commands += 1
            now = self.g.find_node(node.id)
            if now is not None and now.get("status") == "proposed":  # not superseded meanwhile
                self._status(
                    node,
                    "active" if reply["accepted"] else "failed",
                    None if reply["accepted"] else "no path to the final pose",
                )
            self.log.info("command sent", intention=node.name, accepted=reply["accepted"])

    @every(0.1)
    async def watch(self) -> None:
        robots = self.g.nodes(ROBOT)
        if not robots:
            return
        for node in self.g.nodes(INTENTION):
            if node.get("status") != "active":
                continue
            resting = robots[0].get("speed", 0.0) < 1e-3
            if node.get("action") == STOP:
                arrived = True
            else:
                x, y, _ = self.g.rt.pose2d(WORLD, robots[0].id)
                fx, fy, _ = node.get("final_pose")
                arrived = math.hypot(fx - x, fy - y) <= self.args.arrived
            if arrived and resting:
                self._status(node, "done")


if __name__ == "__main__":
    main(Executor)
