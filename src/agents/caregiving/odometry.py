"""The simulated clock as the robot's odometry in W shows it.

Perception writes the robot node with each odometry message: ``stamp`` (the
world's simulated time) and ``written_at`` (the wall clock then). From these an
agent tells how far the world has gone on past a context it read, and how many
simulated seconds pass per wall second (the world may run slower or faster
than real time).
"""

from __future__ import annotations

from wm import Graph, Node

from .names import ROBOT


class OdometryClock:
    """How far the world is past a context, and the simulated rate since the first odometry of a trial."""

    def __init__(self) -> None:
        self._first: tuple[float, float] | None = None  # (simulated, wall) seconds of the first odometry seen

    def reset(self) -> None:
        """A new trial: its clock starts again."""
        self._first = None

    def lag(self, g: Graph, time: float) -> float:
        """Simulated seconds the world has gone on past ``time`` (a context's), as the newest odometry shows."""
        robot = _robot(g)
        newest = robot.get("stamp", time) if robot is not None else time
        return max(newest - time, 0.0)

    def rate(self, g: Graph) -> float:
        """Simulated seconds per wall second since the first odometry of the trial (1 until half a second has
        passed)."""
        robot = _robot(g)
        if robot is None or robot.get("stamp") is None or robot.get("written_at") is None:
            return 1.0
        now = (float(robot.get("stamp")), float(robot.get("written_at")))
        if self._first is None or now[0] < self._first[0]:
            self._first = now
        sim, wall = now[0] - self._first[0], now[1] - self._first[1]
        return sim / wall if wall > 0.5 and sim > 0.0 else 1.0


def _robot(g: Graph) -> Node | None:
    return next(iter(g.nodes(ROBOT)), None)
