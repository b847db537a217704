"""The internal simulator: answers batched "imagine" requests over Zenoh against a frozen context.

``python -m agents.caregiving.simulation --graph G --connect EP [--rollout numpy|bullet]``

It mirrors W into a scene (and, with ``--rollout bullet``, into its persistent
PyBullet DIRECT world, moving bodies rather than re-creating them) and serves
the queryable ``wm/<g>/sim/imagine`` with :mod:`agents.caregiving.model.service` (the request
and item forms are documented there). A request's optional ``scene`` pins the
context; without it the context is W as this replica holds it when the request
arrives, frozen for the whole batch. The reply is ::

    {"episode", "stamp", "written_at", "compute_ms", "results": [ANSWER, ...]}

A malformed item gets its own error entry; a malformed request an error reply.
Items are served one at a time; batches holding robot moves (Algorithm 2, where
the reaction time is spent) go before batches of person-only imaginations.
"""

from __future__ import annotations

import argparse
import asyncio
import time
from dataclasses import dataclass, field
from itertools import count
from typing import Any

from agents import bus
from agents.caregiving import keys
from agents.caregiving.model.rollout import BulletRollout, NumpyRollout, Rollout
from agents.caregiving.model.scene import Scene
from agents.caregiving.model.service import batch_scene, serve_one

from ..runtime import Agent, main
from .context import Context, read_context


@dataclass
class _Job:
    """A batch being served: its frozen scene, items, results so far and the future to resolve."""

    priority: int
    seq: int
    scene: Scene
    items: list[Any]
    done: asyncio.Future[list[dict[str, Any]]]
    results: list[dict[str, Any]] = field(default_factory=list)


class Simulation(Agent):
    """Serves imagine requests against a frozen copy of W."""

    name = "simulation"

    @classmethod
    def add_arguments(cls, parser: argparse.ArgumentParser) -> None:
        parser.add_argument("--rollout", choices=["numpy", "bullet"], default="numpy",
                            help="walk rollouts with the vectorised numpy path or with PyBullet (default: %(default)s)")

    async def setup(self) -> None:
        self.bullet = BulletRollout.shared() if self.args.rollout == "bullet" else None
        self.rollout: Rollout = self.bullet or NumpyRollout()
        self.context: Context | None = None
        self.dirty = True
        self.served = 0
        self.jobs: list[_Job] = []
        self._seq = count()
        self._wake = asyncio.Event()
        self._worker = asyncio.get_running_loop().create_task(self._work(), name="imagine-worker")
        self.g.on(self._changed, type=["person", "object", "robot", "world", "RT"])
        self._queryable = bus.serve(self.g.network.session, keys.imagine(self.args.graph), self.imagine)  # type: ignore[union-attr]
        self.log.info("serving", key=keys.imagine(self.args.graph), rollout=self.args.rollout)

    async def teardown(self) -> None:
        self._queryable.undeclare()
        self._worker.cancel()

    def _changed(self, _event: object) -> None:
        self.dirty = True

    def _context(self) -> Context | None:
        if self.dirty:
            self.context = read_context(self.g)
            self.dirty = False
            if self.bullet is not None and self.context is not None:
                s = self.context.scene
                self.bullet.place([*s.obstacles, *(p.body() for p in s.people), *([s.robot.body()] if s.robot else [])])
        return self.context

    async def imagine(self, request: Any) -> dict[str, Any]:
        """Freeze the context now, queue the batch, and answer when its last item is done."""
        start = time.perf_counter()
        ctx = self._context()
        scene, items = batch_scene(request, ctx.scene if ctx else None)
        joint = any(isinstance(i, dict) and i.get("kind") == "joint" for i in items)
        job = _Job(0 if joint else 1, next(self._seq), scene, items, asyncio.get_running_loop().create_future())
        self.jobs.append(job)
        self._wake.set()
        results = await job.done
        self.served += len(results)
        pinned = ctx is None or scene is not ctx.scene
        return {"episode": None if pinned else ctx.episode, "stamp": scene.time,
                "written_at": None if pinned else ctx.written_at, "results": results,
                "compute_ms": (time.perf_counter() - start) * 1e3}

    async def _work(self) -> None:
        """Serve queued items one at a time, robot-move batches (Algorithm 2) before the others.

        Between items the loop yields, so a batch that arrives meanwhile is queued
        at once and, if it has priority, served next rather than after the current batch.
        """
        while True:
            if not self.jobs:
                self._wake.clear()
                await self._wake.wait()
                continue
            job = min(self.jobs, key=lambda j: (j.priority, j.seq))
            job.results.append(serve_one(job.scene, job.items[len(job.results)], self.rollout))
            if len(job.results) == len(job.items):
                self.jobs.remove(job)
                if not job.done.done():
                    job.done.set_result(job.results)
            await asyncio.sleep(0)


if __name__ == "__main__":
    main(Simulation)
