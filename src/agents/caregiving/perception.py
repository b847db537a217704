"""Perception: noisy detections and robot odometry from the world bridge, as nodes and RT edges in W.

``python -m agents.caregiving.perception --graph G --connect EP [--scenario S]``

It keeps, all placed by an RT edge from the ``world`` node:

* ``world``: the room size and the current ``episode`` (the world's trial number);
* the ``robot``: size and limits, pose and speed from odometry;
* a ``person`` node per confirmed person track: radius, eye height and the
  robot's generic model of people (fields of view, vertical gaze range), plus
  the tracked velocity, position uncertainty, sensor stamp and write time, and
  their walking speed: the model's, until their walk measures otherwise
  (:mod:`agents.caregiving.walking_speed`), and whether they have ``fallen``:
  their newest :data:`LOW_FRAMES` detections all lower than :data:`LYING_FRACTION`
  of the height they stood at (``fallen_at``: the first such frame's stamp);
* an ``object`` node per confirmed object track: kind, shape, size, target flag.

Poses and the other high-rate attributes are volatile. An object's pose and size
are rewritten only when their estimate has moved by ``--object-step`` (1 cm): the
estimate converges, and unchanged shapes keep the planners' inflated-mask caches
valid in every agent. Ids persist for as long
as a track lives; a track unseen for ``--forget`` seconds is deleted. When the
world starts a new trial every person and object node is cleared first.
"""

from __future__ import annotations

import argparse
import math
import time
from collections import defaultdict
from typing import Any

from agents.caregiving import keys
from agents.caregiving.model.scenario import load_scenario

from ..runtime import Agent, main
from .names import OBJECT, PERSON, ROBOT, WORLD
from .tracking import PERSON as PERSON_TRACK
from .tracking import Track, Tracker
from .walking_speed import WalkingSpeed

#: A person is seen fallen when detected lower than this share of the height they stood at ...
LYING_FRACTION = 0.5
#: ... in this many frames in a row (one low frame, a stoop or a bad detection, is not a fall).
LOW_FRAMES = 3
#: The velocity error (m/s) written for a person whose window holds too few detections to fit a line: W
#: holds finite numbers only, and this is beyond any walking pace.
UNFITTED_VELOCITY_SIGMA = 10.0


class Perception(Agent):
    """Turns detections into tracked person and object nodes in W."""

    name = "perception"

    @classmethod
    def add_arguments(cls, parser: argparse.ArgumentParser) -> None:
        parser.add_argument("--scenario", help="take the sensor noise and the model of people from this scenario")
        parser.add_argument("--position-sigma", type=float, help="sensor position noise, metres (default 0.05)")
        parser.add_argument("--hfov-deg", type=float, help="people's horizontal field of view (default 120)")
        parser.add_argument("--vfov-deg", type=float, help="people's vertical field of view (default 40)")
        parser.add_argument("--gaze-deg", type=float, nargs=2, help="people's vertical gaze range (default 6 10)")
        parser.add_argument(
            "--walk-speed",
            type=float,
            help="people's walking speed until their walk shows otherwise, m/s (default 0.5)",
        )
        parser.add_argument("--forget", type=float, default=1.0, help="seconds before an unseen track is dropped")
        parser.add_argument(
            "--object-step",
            type=float,
            default=0.01,
            help="metres an object's position or size estimate must change before it is rewritten",
        )

    async def setup(self) -> None:
        a = self.args
        spec = load_scenario(a.scenario) if a.scenario else None
        person = spec.people[0] if spec and spec.people else None

        def pick(value: float | None, from_spec: float | None, default: float) -> float:
            return value if value is not None else from_spec if from_spec is not None else default

        sigma = pick(a.position_sigma, spec.sensors.position_sigma if spec and spec.sensors.enabled else None, 0.05)
        gaze = a.gaze_deg or (list(person.gaze_range_deg) if person else [6.0, 10.0])
        self.person_model = {
            "fov": math.radians(pick(a.hfov_deg, person.hfov_deg if person else None, 120.0)),
            "vfov": math.radians(pick(a.vfov_deg, person.vfov_deg if person else None, 40.0)),
            "gaze_range": [math.radians(gaze[0]), math.radians(gaze[1])],
        }
        self.walk_speed = pick(a.walk_speed, person.speed if person else None, 0.5)
        self.tracker = Tracker(max(sigma, 1e-3), forget=a.forget)
        self.episode: int | None = None
        self.nodes: dict[int, int] = {}  # track id -> node id
        self.speeds: defaultdict[int, WalkingSpeed] = defaultdict(lambda: WalkingSpeed(self.walk_speed))
        self.frames = 0
        self.subscribe(keys.frame(a.graph), self.on_frame)
        self.subscribe(keys.robot_state(a.graph), self.on_robot)
        self.log.info("listening", sigma=sigma, forget=a.forget)

    # -- episodes ------------------------------------------------------------------------------
    def _new_episode(self, trial: int) -> None:
        g = self.g
        with g.batch():
            for node in g.nodes(PERSON) + g.nodes(OBJECT):
                g.delete_node(node.id)
            if g.find_node(WORLD) is None:
                g.insert_node(WORLD, WORLD)
            g.update_node(WORLD, {"episode": trial, "sim_time": 0.0})
        self.tracker.reset()
        self.nodes.clear()
        self.speeds.clear()
        self.episode = trial
        self.log.info("new episode", trial=trial)

    # -- the robot -----------------------------------------------------------------------------
    async def on_robot(self, m: dict[str, Any]) -> None:
        g = self.g
        if m.get("trial") != self.episode:
            self._new_episode(int(m["trial"]))
        now = time.time()
        with g.batch():
            if g.find_node(m["name"]) is None:
                g.insert_node(
                    ROBOT,
                    m["name"],
                    {
                        "size": [m["length"], m["width"], m["height"]],
                        "footprint": [m["width"], m["length"]],
                        "max_speed": m["max_speed"],
                        "max_accel": m["max_accel"],
                    },
                )
            world = g.get_node(WORLD)
            if world.get("room_size") is None:
                x0, y0, x1, y1 = m["bounds"]
                g.update_node(WORLD, {"room_size": [x1 - x0, y1 - y0]})
            if not any(n.get("kind") == "wall" for n in g.nodes(OBJECT)):
                for i, w in enumerate(m.get("walls", [])):
                    node = g.insert_node(
                        OBJECT,
                        f"wall_{self.episode}_{i}",
                        {
                            "kind": "wall",
                            "shape": "box",
                            "size": [2 * w["hx"], 2 * w["hy"], m["wall_height"]],
                            "is_obstacle": True,
                            "is_target": False,
                        },
                    )
                    g.rt.set_pose2d(WORLD, node, w["x"], w["y"], w["theta"])
            g.update_node(
                m["name"], {"speed": m["speed"], "route": m.get("route", []), "stamp": m["time"], "written_at": now}
            )
            g.update_node(WORLD, {"sim_time": m["time"]})
            g.rt.set_pose2d(WORLD, m["name"], m["x"], m["y"], m["heading"])

    # -- detections ----------------------------------------------------------------------------
    async def on_frame(self, m: dict[str, Any]) -> None:
        if m.get("trial") != self.episode:
            return  # a frame of a finished trial, or before the first robot state
        stamp = float(m["stamp"])
        touched = self.tracker.update(stamp, m["dets"])
        gone = self.tracker.prune(stamp)
        now = time.time()
        g = self.g
        with g.batch():
            for t in touched:
                if self.tracker.confirmed(t):
                    self._write(t, stamp, now)
            for t in gone:
                self.speeds.pop(t.id, None)
                node = self.nodes.pop(t.id, None)
                if node is not None and g.find_node(node) is not None:
                    g.delete_node(node)
        self.frames += 1

    def _write(self, t: Track, stamp: float, now: float) -> None:
        g = self.g
        sx, sy, height = t.size()
        volatile: dict[str, Any] = {"stamp": stamp, "last_seen": stamp, "written_at": now, "position_sigma": t.sigma}
        node = self.nodes.get(t.id)
        if t.kind == PERSON_TRACK:
            volatile.update(velocity=[t.vx, t.vy], velocity_sigma=min(t.velocity_sigma, UNFITTED_VELOCITY_SIGMA))
            speed = self.speeds[t.id]
            if (pace := speed.observe(t, self.tracker.window)) is not None:
                volatile.update(speed=pace)
            if stamp - t.first <= self.tracker.window:  # the first second refines where the walk began
                volatile.update(origin=list(t.origin(self.tracker.window)))
            if node is None:
                node = self.nodes[t.id] = g.insert_node(
                    PERSON,
                    f"person_{t.id}",
                    {
                        "radius": sx / 2,
                        "eye_height": height,
                        "track_id": t.id,
                        "speed": speed.written,
                        **self.person_model,
                        **volatile,
                    },
                )
            else:
                g.update_node(node, volatile)
                self._write_fallen(t, node, stamp)
        elif node is None:
            node = self.nodes[t.id] = g.insert_node(
                OBJECT,
                f"{t.kind}_{t.id}",
                {
                    "kind": t.kind,
                    "shape": t.shape,
                    "size": [sx, sy, height],
                    "is_obstacle": True,
                    "is_target": t.target,
                    "track_id": t.id,
                    **volatile,
                },
            )
        else:
            g.update_node(node, volatile)
            old = g.get_node(node).get("size")
            if (
                old is None
                or max(abs(a - b) for a, b in zip(old, (sx, sy, height), strict=True)) > self.args.object_step
            ):
                g.update_node(node, {"size": [sx, sy, height]})
            x, y, yaw = g.rt.pose2d(WORLD, node)
            if math.hypot(t.x - x, t.y - y) <= self.args.object_step and abs(t.heading - yaw) <= 0.02:
                return  # an object's estimate only moves in steps, so the planners' cached masks stay valid
        g.rt.set_pose2d(WORLD, node, t.x, t.y, t.heading)

    def _write_fallen(self, t: Track, node: int, stamp: float) -> None:
        """Mark whether person ``t`` lies fallen, on their node, when that changes."""
        person = self.g.get_node(node)
        fallen = t.lower_than(LYING_FRACTION * person.get("eye_height", 0.0), LOW_FRAMES)
        if fallen != person.get("fallen", False):
            self.g.update_node(node, {"fallen": fallen, "fallen_at": stamp} if fallen else {"fallen": False})
            self.log.info("fallen" if fallen else "up again", person=person.name, at=round(stamp, 2))


if __name__ == "__main__":
    main(Perception)
