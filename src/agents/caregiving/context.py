"""The context ``ctx = getContext(W)`` of the paper: a frozen :class:`~agents.caregiving.model.scene.Scene` read from W.

Perception keeps these in W: a ``world`` node (``room_size``, ``episode``), the
``robot`` node, ``person`` and ``object`` nodes, each placed by an RT edge from
``world`` (x, y, yaw). :func:`read_context` turns them into the immutable scene
every imagination runs on, plus what the agents need beside it: node ids, the
tracked position uncertainty, velocities and their errors, the people perception sees fallen and
the wall time of the newest perception write behind the snapshot.
"""

from __future__ import annotations

import math
from dataclasses import dataclass, field
from functools import cached_property

from agents.caregiving.model.geometry import Box, Circle, Shape
from agents.caregiving.model.guesses import Walking
from agents.caregiving.model.scenario import RoomSpec
from agents.caregiving.model.scene import Obstacle, PersonState, RobotState, Scene
from wm import Graph, Node

from .names import OBJECT, PERSON, ROBOT, RT, WORLD

WALL_THICKNESS = 0.1
WALL_HEIGHT = 2.5


@dataclass(frozen=True)
class Context:
    """A frozen snapshot of W and what goes with it."""

    scene: Scene
    episode: int
    ids: dict[str, int]
    sigma: dict[str, float]
    velocity: dict[str, tuple[float, float]]
    written_at: float
    fallen: frozenset[str] = frozenset()  # people lying where they fell: they walk nowhere
    velocity_sigma: dict[str, float] = field(default_factory=dict)  # per axis, m/s; none known: exact

    @cached_property
    def names(self) -> dict[int, str]:
        """Node id -> name: the inverse of :attr:`ids`."""
        return {v: k for k, v in self.ids.items()}

    def speed(self, person: str) -> float:
        vx, vy = self.velocity.get(person, (0.0, 0.0))
        return math.hypot(vx, vy)

    def walks(self, person: str, walking: Walking) -> bool:
        """Whether ``person`` may be walking, by their tracked speed and its error (:meth:`Walking.walks`)."""
        return walking.walks(self.speed(person), self.velocity_sigma.get(person, 0.0))


def node_shape(node: Node, x: float, y: float, yaw: float) -> Shape:
    """The footprint of an ``object`` node placed at ``(x, y, yaw)``."""
    sx, sy, _ = node.get("size", (0.2, 0.2, 0.2))
    if node.get("shape") == "circle":
        return Circle(x, y, sx / 2)
    return Box(x, y, sx / 2, sy / 2, yaw)


def read_context(g: Graph) -> Context | None:
    """The current context, or None until perception has written the world and the robot."""
    world = g.find_node(WORLD)
    robots = g.nodes(ROBOT)
    if world is None or not robots or world.get("room_size") is None:
        return None
    width, depth = world.get("room_size")
    room = RoomSpec(width, depth, WALL_HEIGHT, WALL_THICKNESS, ())
    ids: dict[str, int] = {}
    sigma: dict[str, float] = {}
    velocity: dict[str, tuple[float, float]] = {}
    velocity_sigma: dict[str, float] = {}
    fallen: set[str] = set()
    written = 0.0
    obstacles = list(room.wall_obstacles())
    for node in g.nodes(OBJECT):
        pose = _pose(g, node)
        if pose is None:
            continue
        height = node.get("size", (0.0, 0.0, 0.2))[2]
        obstacles.append(
            Obstacle(
                node.name,
                node.get("kind", "object"),
                node_shape(node, *pose),
                max(height, 1e-3),
                bool(node.get("is_target", False)),
            )
        )
        ids[node.name] = node.id
        sigma[node.name] = node.get("position_sigma", 0.0)
        written = max(written, node.get("written_at", 0.0))
    people = []
    for node in g.nodes(PERSON):
        pose = _pose(g, node)
        if pose is None:
            continue
        gaze = node.get("gaze_range", (0.0, 0.0))
        vx, vy = node.get("velocity", (0.0, 0.0))
        people.append(
            PersonState(
                node.name,
                pose[0],
                pose[1],
                pose[2],
                max(node.get("speed", 0.5), 0.05),
                node.get("radius", 0.25),
                node.get("eye_height", 1.6),
                node.get("fov", math.pi),
                node.get("vfov", math.radians(40)),
                gaze[0],
                gaze[1],
                _point(node.get("origin")),
            )
        )
        ids[node.name] = node.id
        sigma[node.name] = node.get("position_sigma", 0.0)
        velocity[node.name] = (vx, vy)
        velocity_sigma[node.name] = node.get("velocity_sigma", 0.0)
        if node.get("fallen", False):
            fallen.add(node.name)
        written = max(written, node.get("written_at", 0.0))
    r = robots[0]
    pose = _pose(g, r) or (0.0, 0.0, 0.0)
    length, width_r, height = r.get("size", (0.5, 0.4, 1.5))
    route = r.get("route", ())
    robot = RobotState(
        r.name,
        pose[0],
        pose[1],
        pose[2],
        length,
        width_r,
        height,
        r.get("max_speed", 0.5),
        r.get("max_accel", 0.5),
        max(float(r.get("speed", 0.0)), 0.0),
        tuple(zip(route[0::2], route[1::2], strict=True)),
    )
    ids[r.name] = r.id
    stamp = max([world.get("sim_time", 0.0)] + [n.get("stamp", 0.0) for n in g.nodes(PERSON)])
    scene = Scene(room.bounds, tuple(obstacles), tuple(people), robot, stamp)
    return Context(scene, episode_of(world), ids, sigma, velocity, written, frozenset(fallen), velocity_sigma)


def episode_of(world: Node | None) -> int:
    """The trial W's ``world`` node says is running (0 before the world has said)."""
    return int(world.get("episode", 0)) if world is not None else 0


def _pose(g: Graph, node: Node) -> tuple[float, float, float] | None:
    edge = g.find_edge(WORLD, node.id, RT)
    if edge is None or edge.get("rt_translation") is None:
        return None
    t = edge.get("rt_translation")
    rot = edge.get("rt_rotation_euler_xyz", (0.0, 0.0, 0.0))
    return float(t[0]), float(t[1]), float(rot[2])


def _point(value: object) -> tuple[float, float] | None:
    """An ``[x, y]`` attribute as a point, ``None`` when absent."""
    if not isinstance(value, (list, tuple)) or len(value) != 2:
        return None
    return float(value[0]), float(value[1])
