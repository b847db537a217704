"""The physical oracle: could any robot move, commanded when the danger became observable, have saved a trial?

It searches the ground truth, not the robot's beliefs. The world is stepped to
the moment the danger first became observable (the context time of the first
risky guess), then each move of a broad set is commanded in a fork of it and run
to the end, with the people reacting as the world's people do. A trial is
*saveable* when some move leaves nobody touching anything. A person who falls with
the robot idle is saveable when some move leaves them untouched and trips nobody
who would not fall anyway: where two people fall in different places, one move may
not save both, but each may be saved alone.

The broad move set is every stand-off pose around every object, plus a lattice
of free poses (:data:`LATTICE` metres apart, :data:`HEADINGS` headings) in the
corridor :data:`CORRIDOR` metres either side of each person's idle walk, from
where they are to just past where they hit something. That corridor holds the
region between the person and the obstacle and the poses on and beside their
path. The stand-off-only oracle uses the stand-offs alone, so that the figures
show what the free poses add.

The search stops at the first move that saves the trial (it saves every person
too; without one, the whole set is searched, person by person) and skips poses where
the robot does not fit (the world refuses a command there, so it cannot save
anything); :func:`saving_moves` is the exhaustive version the tests hold it to.
"""

from __future__ import annotations

import math
from collections.abc import Iterator
from dataclasses import dataclass

import numpy as np

from agents.caregiving.model.geometry import Polyline
from agents.caregiving.model.planner import GridPlanner
from agents.caregiving.model.robot_moves import RobotMove, robot_fits, standoff_poses
from agents.caregiving.model.scenario import Scenario
from agents.caregiving.model.scene import Scene
from agents.caregiving.model.visibility import WALL_KIND
from agents.caregiving.model.world_model import Outcome, World

LATTICE = 0.2
HEADINGS = (0.0, math.pi / 4, math.pi / 2, 3 * math.pi / 4)
CORRIDOR = 0.6
#: Metres past the collision point that the corridor reaches.
BEYOND = 0.5


@dataclass(frozen=True)
class OracleVerdict:
    """Whether some move saves the trial, the first one found, whether a stand-off alone does, and the people
    falling with the robot idle whom some move saves, each alone or together."""

    saveable: bool
    standoff_saveable: bool
    move: RobotMove | None
    saveable_people: frozenset[str] = frozenset()


def idle_run(trial: Scenario, planner: GridPlanner) -> World:
    """The ground truth of ``trial`` run to its end with the robot idle: who falls, and each walker's gaze."""
    world = World.from_scenario(trial, planner=planner)
    world.run(60.0)
    return world


def world_at(trial: Scenario, at: float, planner: GridPlanner) -> World:
    """The ground truth of ``trial`` stepped to time ``at`` (or to its end, if sooner)."""
    world = World.from_scenario(trial, planner=planner)
    while world.time < at - 1e-9 and not world.done:
        world.step()
    return world


def standoff_moves_all(scene: Scene) -> list[RobotMove]:
    """Every stand-off pose around every object but the walls."""
    return [m for o in scene.obstacles if o.kind != WALL_KIND for m in standoff_poses(scene, o.name)]


def idle_from(world: World) -> World:
    """A fork of ``world`` run on to its end with the robot idle."""
    idle = world.fork()
    idle.run(idle.time + 30.0)
    return idle


def lattice_moves(world: World, idle: World) -> list[RobotMove]:
    """Free poses on a lattice in the corridor around each person's idle walk from now (``idle``: :func:`idle_from`
    ``world``), nearest the danger first."""
    scene = world.scene()
    x0, y0, x1, y1 = scene.bounds
    xs = np.arange(x0 + LATTICE / 2, x1, LATTICE)
    ys = np.arange(y0 + LATTICE / 2, y1, LATTICE)
    grid = np.stack(np.meshgrid(xs, ys, indexing="ij"), axis=-1).reshape(-1, 2)
    moves: list[RobotMove] = []
    for c in idle.outcome().collisions:
        track = idle.walker(c.person).track[len(world.walker(c.person).track) - 1 :]
        if len(track) < 2:
            continue
        samples = Polyline.of(track).remaining(0.0, LATTICE / 2)
        direction = samples[-1] - samples[-2]
        direction /= max(float(np.hypot(*direction)), 1e-9)
        beyond = samples[-1] + np.outer(np.arange(1, int(BEYOND / (LATTICE / 2)) + 1) * LATTICE / 2, direction)
        corridor = np.vstack([samples, beyond])
        near = np.min(
            np.hypot(grid[:, None, 0] - corridor[None, :, 0], grid[:, None, 1] - corridor[None, :, 1]), axis=1
        )
        cells = grid[near <= CORRIDOR]
        order = np.argsort(np.hypot(cells[:, 0] - c.point[0], cells[:, 1] - c.point[1]))
        moves += [RobotMove(c.obstacle, float(x), float(y), h) for x, y in cells[order] for h in HEADINGS]
    return moves


def broad_moves(world: World, idle: World) -> Iterator[tuple[RobotMove, bool]]:
    """The broad move set in search order, each flagged whether it is a stand-off; poses the robot cannot fit skipped
    (``idle``: :func:`idle_from` ``world``)."""
    scene = world.scene()
    for move in standoff_moves_all(scene):
        if robot_fits(scene, move):
            yield move, True
    for move in lattice_moves(world, idle):
        if robot_fits(scene, move):
            yield move, False


def commanded(world: World, move: RobotMove) -> Outcome | None:
    """How the trial ends when ``move`` is commanded now; None when the robot cannot reach it."""
    trial = world.fork()
    if not trial.command_robot(move):
        return None
    return trial.run(trial.time + 30.0)


def fell_after(world: World, move: RobotMove) -> frozenset[str] | None:
    """Who touches something when ``move`` is commanded now; None when the robot cannot reach it."""
    outcome = commanded(world, move)
    return frozenset(c.person for c in outcome.collisions) if outcome is not None else None


def saves(world: World, move: RobotMove) -> bool:
    """Whether commanding ``move`` now leaves everybody untouched to the end."""
    return fell_after(world, move) == frozenset()


def oracle(trial: Scenario, at: float, planner: GridPlanner) -> OracleVerdict:
    """Search the broad move set commanded at ``at``; stand-offs first, so the stand-off verdict comes for free."""
    world = world_at(trial, at, planner)
    if world.done:
        return OracleVerdict(not world.outcome().collided, not world.outcome().collided, None)
    idle = idle_from(world)
    fallers = frozenset(c.person for c in idle.outcome().collisions)
    saveable: set[str] = set()
    for move, standoff in broad_moves(world, idle):
        fell = fell_after(world, move)
        if fell is None:
            continue
        if not fell:
            return OracleVerdict(True, standoff, move, fallers)
        if fell <= fallers:  # it trips nobody who would not fall anyway
            saveable |= fallers - fell
    return OracleVerdict(False, False, None, frozenset(saveable))


def saving_moves(trial: Scenario, at: float, planner: GridPlanner) -> list[RobotMove]:
    """Exhaustive: every move of the broad set, fitting or not, that saves the trial when commanded at ``at``."""
    world = world_at(trial, at, planner)
    scene = world.scene()
    return [m for m in [*standoff_moves_all(scene), *lattice_moves(world, idle_from(world))] if saves(world, m)]
