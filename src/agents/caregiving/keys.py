"""The Zenoh key layout of the caregiving stack, outside the working memory itself.

``cg/<graph>/sensors/frame``   one frame of noisy detections (world -> perception)
``cg/<graph>/robot/state``     the robot's own pose and speed, from odometry (world -> perception, executor)
``cg/<graph>/robot/cmd``       queryable: drive the robot to a pose, or stop (executor -> world)
``cg/<graph>/world/control``   queryable: prepare a trial, start it, stop it (experiment -> world)
``cg/<graph>/world/outcome``   what really happened in a finished trial (world -> experiment)
``wm/<graph>/sim/imagine``     queryable: batched imagine requests (intention, action -> simulation)

All payloads are msgpack maps (see :mod:`agents.messaging`).
"""

from __future__ import annotations

from wm.net import keys as wm_keys

ROOT = "cg"


def frame(graph: str) -> str:
    return f"{ROOT}/{graph}/sensors/frame"


def robot_state(graph: str) -> str:
    return f"{ROOT}/{graph}/robot/state"


def robot_cmd(graph: str) -> str:
    return f"{ROOT}/{graph}/robot/cmd"


def world_control(graph: str) -> str:
    return f"{ROOT}/{graph}/world/control"


def world_outcome(graph: str) -> str:
    return f"{ROOT}/{graph}/world/outcome"


def sim(graph: str, service: str = "**") -> str:
    """The simulation agent's request/reply services, inside the graph's own key space."""
    return f"{wm_keys.ROOT}/{graph}/sim/{service}"


def imagine(graph: str) -> str:
    return sim(graph, "imagine")
