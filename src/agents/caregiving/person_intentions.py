"""The people's side of W for Algorithm 1: what each person surely knows, and the guesses written of them.

What a person sees at every gaze class is marked ``knows`` person -> object, and
``knows`` person -> robot carries the pose where they last saw it so (``seen_at``,
:mod:`agents.caregiving.model.robot_memory`). Each guess is a ``has_intention``
edge person -> target (risky ones with their path, collision point and object,
time to collision), and each risky one is marked with a ``collision`` edge
person -> object. An edge is rewritten only when its meaning changes, or every
``refresh`` simulated seconds, and deleted once it stops holding. These are the
intention agent's writes, so that the agent is only the flow of Algorithm 1.
"""

from __future__ import annotations

import time
from typing import Any

from agents.caregiving.model.guesses import Guess
from agents.caregiving.model.robot_memory import remembered_robot
from agents.caregiving.model.scene import Pose
from agents.caregiving.model.visibility import GazeClass, surely_seen
from wm import Edge, Graph

from .context import Context
from .names import COLLISION, HAS_INTENTION, KNOWS, OBJECT


def remember(g: Graph, ctx: Context, person: str, classes: tuple[GazeClass, ...]) -> list[str]:
    """Mark ``knows`` the objects ``person`` sees in every gaze class; all they know, the robot too, sorted.

    The person plans around them later too, even once they are out of view (as people do).
    """
    pid = ctx.ids[person]
    sure = surely_seen(classes)
    known = {g.get_node(e.dst).name for e in g.edges(type=KNOWS, src=pid)}
    fresh = [
        n
        for n in sure
        if n in ctx.ids
        and n not in known
        and ctx.ids[n] != pid
        and g.find_node(ctx.ids[n]) is not None
        and g.get_node(ctx.ids[n]).type == OBJECT
    ]
    if fresh:
        with g.batch():
            for name in fresh:
                g.insert_or_assign_edge(pid, ctx.ids[name], KNOWS, {"updated_at": time.time()})
    return sorted(known | set(fresh))


def remember_robot(g: Graph, ctx: Context, person: str) -> Pose | None:
    """Mark ``knows`` person -> robot, at the pose where ``person`` last surely saw the robot; that pose, if any.

    Called at every frame: the person looks at the robot again once it has moved a re-plan shift, and a
    robot driving out of their view meanwhile is remembered where it stood.
    """
    robot = ctx.scene.robot
    if robot is None or robot.name not in ctx.ids or g.find_node(ctx.ids[robot.name]) is None:
        return None
    pid, rid = ctx.ids[person], ctx.ids[robot.name]
    previous = seen_at(g.find_edge(pid, rid, KNOWS))
    now = remembered_robot(previous, ctx.scene.person(person), robot)
    if now is not None and now != previous:
        g.insert_or_assign_edge(pid, rid, KNOWS, {"seen_at": list(now), "updated_at": time.time()})
    return now


def seen_at(knows: Edge | None) -> Pose | None:
    """Where the person of a ``knows`` edge person -> robot remembers the robot (``None``: no pose on it)."""
    pose = knows.get("seen_at") if knows is not None else None
    return (pose[0], pose[1], pose[2]) if pose is not None else None


class GuessWriter:
    """Writes the guesses of the people evaluated, each edge only when it changes or every ``refresh`` s."""

    def __init__(self, refresh: float) -> None:
        self.refresh = refresh
        # (person id, target id) -> (risky, obstacle, simulated time) as last written
        self.written: dict[tuple[int, int], tuple[bool, str | None, float]] = {}

    def write(self, g: Graph, ctx: Context, people: list[str], guesses: list[Guess]) -> None:
        """Write ``guesses`` of ``people`` to ``g``, and delete their intentions and marks that no longer hold."""
        now = time.time()
        with g.batch():
            for x in guesses:
                src, dst = ctx.ids[x.person], ctx.ids[x.target]
                if g.find_node(src) is None or g.find_node(dst) is None:
                    continue  # perception dropped it meanwhile
                last = self.written.get((src, dst))
                stale = (
                    last is None
                    or last[0] != x.risky
                    or last[1] != x.obstacle
                    or ctx.scene.time - last[2] >= self.refresh
                )
                if stale:
                    self.written[(src, dst)] = (x.risky, x.obstacle, ctx.scene.time)
                    g.insert_or_assign_edge(src, dst, HAS_INTENTION, _intention(ctx, x, now))
            self._prune(g, ctx, people, guesses)

    def _prune(self, g: Graph, ctx: Context, people: list[str], guesses: list[Guess]) -> None:
        """Delete intentions and collision marks of evaluated people that no longer hold; mark new dangers."""
        evaluated = {ctx.ids[p] for p in people}
        keep = {(ctx.ids[x.person], ctx.ids[x.target]) for x in guesses}
        dangers: dict[tuple[int, int], Guess] = {}  # each pair marked by its first risky guess
        for x in guesses:
            if x.risky and x.obstacle is not None and x.obstacle in ctx.ids:
                dangers.setdefault((ctx.ids[x.person], ctx.ids[x.obstacle]), x)
        for e in g.edges(type=HAS_INTENTION):
            if e.src in evaluated and (e.src, e.dst) not in keep:
                g.delete_edge(e.src, e.dst, HAS_INTENTION)
                self.written.pop((e.src, e.dst), None)
        for e in g.edges(type=COLLISION):
            if e.src in evaluated and (e.src, e.dst) not in dangers:
                g.delete_edge(e.src, e.dst, COLLISION)
        for (src, dst), x in dangers.items():
            if (
                g.find_node(src) is not None
                and g.find_node(dst) is not None
                and g.find_edge(src, dst, COLLISION) is None
            ):
                g.insert_or_assign_edge(src, dst, COLLISION, {**_where(x), "updated_at": time.time()})


def _intention(ctx: Context, x: Guess, now: float) -> dict[str, Any]:
    """The ``has_intention`` attributes of guess ``x``, read at ``ctx``, written at ``now`` (wall time)."""
    attrs: dict[str, Any] = {
        "risky": x.risky,
        "path": [c for pt in x.path for c in pt],
        "gaze": x.gaze,
        "action": "walk_to",
        "probability": x.probability,
        "updated_at": now,
        "at_time": ctx.scene.time,
        "observed_at": ctx.written_at,
    }
    if x.risky and x.obstacle in ctx.ids:
        attrs.update(collision_object=ctx.ids[x.obstacle], **_where(x))
    return attrs


def _where(x: Guess) -> dict[str, Any]:
    """Where and how soon the risky guess ``x`` collides."""
    return {"collision_point": list(x.point or (0.0, 0.0)), "time_to_collision": x.ttc if x.ttc is not None else 0.0}
