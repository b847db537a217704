"""The world bridge: :class:`agents.caregiving.model.world_model.World` stepped on a simulation clock.

One process holds the ground truth of the room. It is driven through the
``world/control`` queryable: ``prepare`` builds trial ``index`` of the scenario
(sampled from ``seed``; no index means the nominal scenario) and holds it at
t = 0, ``go`` starts the clock, ``stop`` halts it. While a trial runs it steps
every ``dt`` of simulated time, ``rate`` simulated seconds per wall second, and

* publishes each sensor frame (noisy, late, with drop-outs, without identities)
  on ``sensors/frame`` once its latency has passed;
* publishes the robot's own state (odometry is exact) on ``robot/state``, also
  at 10 Hz between trials so that perception can reset for the next one;
* follows ``robot/cmd`` requests within the robot's speed and acceleration;
* when nobody walks any more (or ``max_time`` passes) publishes the record of
  what really happened on ``world/outcome``: collisions with time and place,
  closest approaches, arrivals, the robot's commands and everyone's track.

Every message carries the trial number and simulated time, which is the clock
all agents use; latency figures are taken in wall time. The requests, the
heartbeat and the running trial are tasks of one task group, all cancelled and
awaited before anything is undeclared.
"""

from __future__ import annotations

import asyncio
import logging
import math
from collections.abc import Callable
from dataclasses import dataclass, field
from typing import Any

import numpy as np
import zenoh

from agents.caregiving import keys
from agents.caregiving.model.errors import RequestError
from agents.caregiving.model.fields import Fields
from agents.caregiving.model.planner import GridPlanner
from agents.caregiving.model.robot_moves import RobotMove
from agents.caregiving.model.rollout import DT
from agents.caregiving.model.scenario import Scenario, load_scenario, sample_trial
from agents.caregiving.model.scene import shape_to_wire
from agents.caregiving.model.world_model import World
from agents.caregiving.names import MOVE_TO, MOVES, STOP
from agents.messaging import Messaging, logging_guard

from .sensors import Detection, Sensors

log = logging.getLogger("bridges.world")
IDLE_STATE_PERIOD = 0.1
TRACK_EVERY = 2  # record every other step in the outcome's tracks


def trial_for(scenario: Scenario, seed: int, index: int | None) -> Scenario:
    """Trial ``index`` drawn from ``seed`` (the nominal scenario when ``index`` is None)."""
    if index is None:
        return scenario
    return sample_trial(scenario, np.random.default_rng([seed, index]))


def detection_to_wire(d: Detection) -> dict[str, Any]:
    """A detection without its identity: kind, footprint, heading, height and target flag."""
    return {
        "kind": d.kind,
        "shape": shape_to_wire(d.shape),
        "heading": d.heading,
        "height": d.height,
        "target": d.target,
    }


@dataclass
class _Trial:
    number: int
    spec: Scenario
    world: World
    sensors: Sensors
    commands: list[dict[str, Any]] = field(default_factory=list)
    tracks: dict[str, list[list[float]]] = field(default_factory=dict)


class WorldBridge:
    """Steps trials and talks to the stack over Zenoh."""

    def __init__(
        self,
        session: zenoh.Session,
        graph: str,
        scenario: Scenario,
        rate: float = 1.0,
        dt: float = DT,
        max_time: float = 30.0,
    ) -> None:
        self.graph = graph
        self.scenario = scenario
        self.rate = rate
        self.dt = dt
        self.max_time = max_time
        self.planner = GridPlanner(scenario.scene().bounds)
        self.trial: _Trial | None = None
        self._tasks: asyncio.TaskGroup | None = None
        self._runner: asyncio.Task[None] | None = None
        self._trials = 0
        self.messaging = Messaging(session, logging_guard(log))
        self._frames = self.messaging.publisher(keys.frame(graph), express=True)
        self._states = self.messaging.publisher(keys.robot_state(graph), express=True)
        self._outcomes = self.messaging.publisher(keys.world_outcome(graph))
        self.messaging.serve(keys.world_control(graph), self.control)
        self.messaging.serve(keys.robot_cmd(graph), self.command)

    async def run(self, ready: Callable[[], None] = lambda: None) -> None:
        """Answer requests, run trials and send the between-trials heartbeat until cancelled.

        ``ready()`` is called once the queryables are declared. On the way out every
        task is cancelled and awaited first; only then is anything undeclared.
        """
        try:
            async with asyncio.TaskGroup() as tasks:
                self._tasks = tasks
                self.messaging.start(tasks)
                tasks.create_task(self._idle_states(), name="idle states")
                ready()
        finally:
            self._tasks = None
            self.messaging.close()

    # -- requests ------------------------------------------------------------------------------
    async def control(self, request: Any) -> dict[str, Any]:
        """``{"op": "prepare", "seed": S, "index": K | None, "scenario": FILE?}``, ``{"op": "go"}``, ``{"op": "stop"}``.

        ``scenario`` switches the room to another scenario file (same room size) from this trial on.
        """
        f = Fields(request, "control", RequestError)
        op = f.string("op", choices=frozenset({"prepare", "go", "stop", "status"}))
        if op == "prepare":
            index = f.optional_number("index")
            self._halt()
            if "scenario" in request:
                self._switch(load_scenario(f.string("scenario")))
            spec = trial_for(self.scenario, int(f.number("seed", 0)), None if index is None else int(index))
            self._trials += 1
            sensor_seed = [int(f.number("seed", 0)), 0 if index is None else int(index) + 1, 1]
            self.trial = _Trial(
                self._trials,
                spec,
                World.from_scenario(spec, self.dt, self.planner),
                Sensors(spec.sensors, np.random.default_rng(sensor_seed)),
            )
            self._publish_state()
            log.info("trial %d prepared (index %s)", self._trials, index)
            return {"trial": self._trials, "running": False}
        if op == "go":
            if self.trial is None:
                raise RequestError("go: no trial is prepared")
            if self._tasks is None:
                raise RequestError("go: the world is shutting down")
            if self._runner is None or self._runner.done():
                self._runner = self._tasks.create_task(self._run(self.trial), name=f"trial {self.trial.number}")
            return {"trial": self.trial.number, "running": True}
        if op == "stop":
            self._halt()
        return {"trial": self.trial.number if self.trial else 0, "running": self._running()}

    def _switch(self, scenario: Scenario) -> None:
        if scenario.scene().bounds != self.scenario.scene().bounds:
            raise RequestError(f"prepare.scenario: {scenario.name} has another room size")
        self.scenario = scenario

    async def command(self, request: Any) -> dict[str, Any]:
        """``{"trial": N, "move": {target, x, y, heading} | None, "action"?}``: drive there, or brake.

        ``action`` is the robot intention's (default ``move_to``, or ``stop`` with no move): the trial's
        record keeps it, so that a move made for another reason than a danger is told apart.
        """
        f = Fields(request, "command", RequestError)
        trial = self.trial
        if trial is None or int(f.number("trial")) != trial.number or not self._running():
            raise RequestError(f"command: trial {f.number('trial'):g} is not running")
        move = RobotMove.optional_from(f, "move")
        action = f.string("action", MOVE_TO if move is not None else STOP, choices=frozenset(MOVES))
        accepted = trial.world.command_robot(move)
        trial.commands.append(
            {"time": trial.world.time, "move": move.to_wire() if move else None, "accepted": accepted, "action": action}
        )
        return {"trial": trial.number, "accepted": accepted, "time": trial.world.time}

    # -- running -------------------------------------------------------------------------------
    def _running(self) -> bool:
        return self._runner is not None and not self._runner.done()

    def _halt(self) -> None:
        if self._runner is not None:
            self._runner.cancel()
            self._runner = None

    async def _idle_states(self) -> None:
        while True:
            if not self._running():
                self._publish_state()
            await asyncio.sleep(IDLE_STATE_PERIOD)

    async def _run(self, trial: _Trial) -> None:
        loop = asyncio.get_running_loop()
        world = trial.world
        start = loop.time()
        steps = 0
        try:
            while not world.done and world.time < self.max_time - 1e-9:
                world.step()
                steps += 1
                scene = world.scene()
                trial.sensors.observe(scene, world.fallen())
                ready = trial.sensors.ready(world.time)
                if ready:
                    self._frames.put(
                        {
                            "trial": trial.number,
                            "time": world.time,
                            "stamp": ready[-1].stamp,
                            "dets": [detection_to_wire(d) for d in ready],
                        }
                    )
                self._publish_state()
                if steps % TRACK_EVERY == 0:
                    self._record(trial)
                await asyncio.sleep(max(0.0, start + steps * self.dt / self.rate - loop.time()))
            self._record(trial)
            self._outcomes.put(self.outcome(trial))
            log.info(
                "trial %d finished at t=%.2f s: %d collision(s)",
                trial.number,
                world.time,
                len(world.outcome().collisions),
            )
        except Exception:
            log.exception("trial %d failed", trial.number)

    def _record(self, trial: _Trial) -> None:
        scene = trial.world.scene()
        r = scene.robot
        assert r is not None
        trial.tracks.setdefault(r.name, []).append([scene.time, r.x, r.y, r.heading])
        for p in scene.people:
            trial.tracks.setdefault(p.name, []).append([scene.time, p.x, p.y, p.heading])

    def _publish_state(self) -> None:
        trial = self.trial
        if trial is None:
            return
        world = trial.world
        r = world.robot
        walls = [shape_to_wire(o.shape) for o in trial.world.scene().obstacles[4:] if o.kind == "wall"]
        self._states.put(
            {
                "trial": trial.number,
                "time": world.time,
                "running": self._running(),
                "name": r.name,
                "x": r.x,
                "y": r.y,
                "heading": r.heading,
                "speed": world.robot_speed,
                "route": [c for point in world.robot_route for c in point],
                "length": r.length,
                "width": r.width,
                "height": r.height,
                "max_speed": r.max_speed,
                "max_accel": r.max_accel,
                "bounds": list(world.scene().bounds),
                "walls": walls,
                "wall_height": trial.spec.room.wall_height,
            }
        )

    def outcome(self, trial: _Trial) -> dict[str, Any]:
        """The record of a trial, as published on ``world/outcome``."""
        o = trial.world.outcome()
        return {
            "trial": trial.number,
            "duration": o.duration,
            "collisions": [
                {"time": c.time, "person": c.person, "obstacle": c.obstacle, "point": list(c.point)}
                for c in o.collisions
            ],
            "min_clearance": {k: (v if math.isfinite(v) else None) for k, v in o.min_clearance.items()},
            "closest": o.closest,
            "arrival": o.arrival,
            "commands": trial.commands,
            "tracks": trial.tracks,
        }
