"""The internal simulator: answers batched "imagine" requests over Zenoh against a frozen context.

``python -m agents.caregiving.simulation --graph G --connect EP [--rollout numpy|bullet]``

It mirrors W into a scene (and, with ``--rollout bullet``, into its persistent
PyBullet DIRECT world, moving bodies rather than re-creating them) and serves
the queryable ``wm/<g>/sim/imagine`` with :mod:`agents.caregiving.model.service` (the request
and item forms are documented there). A request's optional ``scene`` pins the
context; without it the context is W as this replica holds it when the request
arrives, frozen for the whole batch. The reply is an
:class:`~agents.caregiving.model.imagine_reply.ImagineReply`.

A search that asks for a head start gets it as soon as it is found, in a progress
reply before the final one (:meth:`agents.messaging.Messaging.serve_progress`).
A malformed item gets its own error entry; a malformed request an error reply.
Items are served one at a time, by one request handler at a time: it serves the
queued batches' items, batches that judge robot moves (searches and joint
imaginations: Algorithm 2, where the reaction time is spent) before batches of
person-only imaginations, until its own batch is done, and hands over to the next.
Each batch of robot moves logs where its time went (``served robot moves``):
reading W and parsing the request, serving its items (and the CPU time of that: the whole process's,
and the serving thread's own, without the transport's threads), and waiting for the items of other batches.
With ``--record DIR`` each batch of robot moves is written to DIR as served, with its scene, to be served
again offline (:mod:`agents.caregiving.model.recorded_batch`), once its reply is on its way.
With ``--judge-ahead``, once a search's first candidate has failed (or, after a
head start, from its second candidate), a helper process judges later candidates
beside it (:mod:`agents.caregiving.model.judge_ahead`). It is off by default: on
recorded searches it saves no wall time, and live its CPU is taken from the rest
of the stack.
"""

from __future__ import annotations

import argparse
import asyncio
import time
from dataclasses import dataclass, field
from itertools import count
from pathlib import Path
from typing import Any

from agents.caregiving import keys
from agents.caregiving.model import imagine_reply
from agents.caregiving.model.imagine_reply import Answer, ImagineReply
from agents.caregiving.model.judge_ahead import JudgeAhead
from agents.caregiving.model.recorded_batch import last_number, write_batch
from agents.caregiving.model.rollout import BulletRollout, NumpyRollout, Rollout
from agents.caregiving.model.scene import Scene
from agents.caregiving.model.service import HeadStart, Serving, batch_scene, judges_robot_moves, serve_one
from agents.caregiving.model.verdict import SearchResult, Verdict
from wm import Event

from ..messaging import Progress
from ..runtime import Agent, main, on
from .context import Context, read_context
from .names import OBJECT, PERSON, ROBOT, RT, WORLD


@dataclass
class _Job:
    """A batch being served: its frozen scene, items and results so far."""

    priority: int
    seq: int
    scene: Scene
    items: list[Any]
    head_start: HeadStart | None = None  # sends a search's head start to the asker as a progress reply
    results: list[Answer] = field(default_factory=list)
    wall_s: float = 0.0  # spent serving its items
    cpu_s: float = 0.0  # of which this process's CPU time (the helper's is not counted)
    thread_s: float = 0.0  # of which the serving thread's own CPU time (not the transport's threads)

    @property
    def done(self) -> bool:
        return len(self.results) == len(self.items)


class Simulation(Agent):
    """Serves imagine requests against a frozen copy of W."""

    name = "simulation"

    @classmethod
    def add_arguments(cls, parser: argparse.ArgumentParser) -> None:
        parser.add_argument(
            "--rollout",
            choices=["numpy", "bullet"],
            default="numpy",
            help="walk rollouts with the vectorised numpy path or with PyBullet (default: %(default)s)",
        )
        parser.add_argument(
            "--judge-ahead",
            action=argparse.BooleanOptionalAction,
            default=False,
            help="once a search's first candidate has failed (after a head start, from the second), judge later "
            "ones in a helper process beside it (default: off)",
        )
        parser.add_argument(
            "--record",
            metavar="DIR",
            default="",
            help="write each batch of robot moves served, with its scene, to DIR to be served again offline "
            "(default: none)",
        )

    async def setup(self) -> None:
        self.bullet = BulletRollout.shared() if self.args.rollout == "bullet" else None
        self.rollout: Rollout = self.bullet or NumpyRollout()
        self.ahead = JudgeAhead() if self.args.judge_ahead else None
        self.context: Context | None = None
        self.dirty = True
        self.served = 0
        self.jobs: list[_Job] = []
        self._seq = count()
        self._serving = asyncio.Lock()
        self.record = Path(self.args.record) if self.args.record else None
        self.recorded = 0  # batches in the record directory, an earlier run's included: a new one is numbered on
        if self.record is not None:
            self.record.mkdir(parents=True, exist_ok=True)
            self.recorded = last_number(self.record)
        self.serve_progress(keys.imagine(self.args.graph), self.imagine)
        self.log.info(
            "serving", key=keys.imagine(self.args.graph), rollout=self.args.rollout, judge_ahead=self.ahead is not None
        )

    async def teardown(self) -> None:
        if self.ahead is not None:
            self.ahead.close()

    @on(type=[PERSON, OBJECT, ROBOT, WORLD, RT], coalesce=True)
    async def changed(self, _events: list[Event]) -> None:
        """W changed: the next request reads the context again."""
        self.dirty = True

    def _context(self) -> Context | None:
        if self.dirty:
            self.context = read_context(self.g)
            self.dirty = False
            if self.bullet is not None and self.context is not None:
                s = self.context.scene
                self.bullet.place([*s.obstacles, *(p.body() for p in s.people), *([s.robot.body()] if s.robot else [])])
        return self.context

    async def imagine(self, request: Any, progress: Progress) -> dict[str, Any]:
        """Freeze the context now, queue the batch, and answer when its last item is done.

        A search's head start is sent on the way, as a progress reply whose one result is a search
        with no verdicts and that head start as its lead.
        """
        start = time.perf_counter()
        ctx = self._context()
        scene, items = batch_scene(request, ctx.scene if ctx else None)
        context = ctx if ctx is not None and scene is ctx.scene else None  # None: the request pinned its scene

        def reply(results: tuple[Answer, ...]) -> dict[str, Any]:
            return imagine_reply.encode(
                ImagineReply(
                    context.episode if context else None,
                    scene.time,
                    context.written_at if context else None,
                    (time.perf_counter() - start) * 1e3,
                    results,
                )
            )

        def head_start(lead: Verdict) -> None:
            progress(reply((Answer(search=SearchResult(None, (), lead, judged=1)),)))

        job = _Job(0 if judges_robot_moves(items) else 1, next(self._seq), scene, items, head_start)
        read = time.perf_counter()
        self.jobs.append(job)
        async with self._serving:
            await self._serve_until(job)
        self.served += len(job.results)
        if job.priority == 0:
            total = time.perf_counter() - start
            self.log.info(
                "served robot moves",
                items=len(items),
                judged=sum(len(a.search.verdicts) for a in job.results if a.search is not None),
                ms=round(total * 1e3, 1),
                context_ms=round((read - start) * 1e3, 1),
                serving_ms=round(job.wall_s * 1e3, 1),
                cpu_ms=round(job.cpu_s * 1e3, 1),
                thread_ms=round(job.thread_s * 1e3, 1),
                waiting_ms=round((total - (read - start) - job.wall_s) * 1e3, 1),
            )
        answer = reply(tuple(job.results))
        if self.record is not None and job.priority == 0:
            self.recorded += 1
            args = (self.record, self.recorded, scene, items, answer, job.thread_s * 1e3)
            asyncio.get_running_loop().call_soon(self._record, *args)  # once the reply is sent
        return answer

    def _record(self, directory: Path, *batch: Any) -> None:
        """Write one served batch; a failed write is logged, and serving goes on."""
        try:
            write_batch(directory, *batch)
        except OSError as exc:
            self.log.warning("batch not recorded", directory=str(directory), error=str(exc))

    async def _serve_until(self, mine: _Job) -> None:
        """Serve queued items one at a time, robot-move batches (Algorithm 2) first, until ``mine`` is done.

        Between items it yields, so a batch that arrives meanwhile is queued at
        once and, if it has priority, served next rather than after the current batch.
        """
        while not mine.done:
            job = min(self.jobs, key=lambda j: (j.priority, j.seq))
            wall, cpu, own = time.perf_counter(), time.process_time(), time.thread_time()
            job.results.append(
                serve_one(job.scene, job.items[len(job.results)], Serving(self.rollout, self.ahead, job.head_start))
            )
            job.wall_s += time.perf_counter() - wall
            job.cpu_s += time.process_time() - cpu
            job.thread_s += time.thread_time() - own
            if job.done:
                self.jobs.remove(job)
            await asyncio.sleep(0)


if __name__ == "__main__":
    main(Simulation)
