"""Running trials over the live stack and recording what the working memory showed.

The harness is itself a (passive) replica of W. For each trial it asks the
world bridge to prepare it, waits until perception and the agents have cleared
W for it, starts the clock, and records from its replica: the stamp of the first
frame perception wrote a person from, whether any intention arose, the first risky
``has_intention`` (and each person's first, where they
stood then), each person's first ``fallen`` mark, and the robot's first ``intention``
(with the wall-clock stamps their writers put on them), plus a snapshot of W at
the moment of the action for the figures. The world's record of what really
happened arrives on ``world/outcome``.
"""

from __future__ import annotations

import asyncio
import logging
import math
import time
from collections.abc import AsyncIterator
from contextlib import asynccontextmanager
from dataclasses import dataclass, field
from typing import Any

import zenoh

import wm
from agents.caregiving import keys
from agents.caregiving.context import read_context
from agents.caregiving.names import HAS_INTENTION, INTENTION, KNOWS, OBJECT, PERSON, PREVENTING, WORLD
from agents.caregiving.person_intentions import seen_at
from agents.messaging import Messaging, TaskSet, logging_guard
from wm import Event, Graph
from wm.net.connection import close_session, open_session

from .fallers import Mark

log = logging.getLogger(__name__)


class TrialError(RuntimeError):
    """A trial could not be run (the stack did not answer or reset in time)."""


@dataclass
class Snapshot:
    """What W held when the robot decided: the scene, the person's intentions and the chosen move, what each
    person is known to have seen (``knows``: person -> names) and where they remember the robot (``robot_at``:
    person -> x, y, heading)."""

    scene: dict[str, Any]
    intentions: list[dict[str, Any]]
    action: dict[str, Any] | None
    knows: dict[str, list[str]] = field(default_factory=dict)
    robot_at: dict[str, list[float]] = field(default_factory=dict)


@dataclass
class TrialRecord:
    """Everything the harness saw of one trial."""

    index: int | None
    intentions: int = 0
    risky: dict[str, Any] | None = None
    action: dict[str, Any] | None = None  # the first robot intention that is not a head start
    head_start: dict[str, Any] | None = None  # the first head start, sent while the search judged on
    last_head_start: dict[str, Any] | None = None  # the latest head start before the action
    outcome: dict[str, Any] = field(default_factory=dict)
    snapshot: Snapshot | None = None
    seen_risky_at: float | None = None
    seen_action_at: float | None = None
    flags: dict[int, Mark] = field(default_factory=dict)  # each person node's first risky intention
    fall_marks: dict[int, Mark] = field(default_factory=dict)  # each person node's first ``fallen`` mark
    answers: dict[str, dict[int, float]] = field(default_factory=dict)  # alert, go_to: person node -> first at_time
    person_seen_at: float | None = None  # the stamp of the first frame perception wrote a person from

    @property
    def set_off(self) -> dict[str, Any] | None:
        """The intention the robot set off on its action with: the head start the action drives on with (the
        same move, chosen once the search ended), or else the action itself."""
        led, action = self.last_head_start, self.action
        if led is not None and action is not None and action.get("action") == "move_to":
            if (led.get("target"), led.get("final_pose")) == (action.get("target"), action.get("final_pose")):
                return led
        return action

    @property
    def reaction_ms(self) -> float | None:
        """Paper's definition: risky intention written -> the robot intention it set off on its action with."""
        return _after_risk_ms(self.set_off)

    @property
    def decision_ms(self) -> float | None:
        """Risky intention written -> the action written, once its search ended."""
        return _after_risk_ms(self.action)

    @property
    def head_start_ms(self) -> float | None:
        """Risky intention written -> head start written (the robot moving while the search judged on)."""
        return _after_risk_ms(self.head_start)

    @property
    def first_response_ms(self) -> float | None:
        """Risky intention written -> the robot's first intention written, head start or move."""
        times = [t for t in (self.head_start_ms, self.reaction_ms) if t is not None]
        return min(times) if times else None

    @property
    def e2e_ms(self) -> float | None:
        """From the perception write behind the danger to the robot intention it set off on its action with."""
        set_off = self.set_off
        if set_off is None or not set_off.get("observed_at"):
            return None
        return (set_off["created_at"] - set_off["observed_at"]) * 1e3

    @property
    def collided(self) -> bool:
        return bool(self.outcome.get("collisions"))


def _after_risk_ms(intention: dict[str, Any] | None) -> float | None:
    """Milliseconds from the risky intention an intention answers to the intention's own writing."""
    if intention is None:
        return None
    return (intention["created_at"] - intention["risk_at"]) * 1e3


def snapshot(g: Graph, action: dict[str, Any] | None) -> Snapshot | None:
    """The context and intentions in ``g`` now, in plain data."""
    ctx = read_context(g)
    if ctx is None:
        return None
    names = ctx.names
    intentions = [
        {"person": names.get(e.src), "target": names.get(e.dst), **dict(e.attrs)} for e in g.edges(type=HAS_INTENTION)
    ]
    knows: dict[str, list[str]] = {}
    robot_at: dict[str, list[float]] = {}
    for e in g.edges(type=KNOWS):
        if e.src in names and e.dst in names:
            knows.setdefault(names[e.src], []).append(names[e.dst])
            if (pose := seen_at(e)) is not None:
                robot_at[names[e.src]] = list(pose)
    return Snapshot(ctx.scene.to_wire(), intentions, action, {p: sorted(n) for p, n in knows.items()}, robot_at)


class Harness:
    """Drives trials through the world bridge and watches W (a replica over ``session``)."""

    def __init__(self, g: Graph, session: zenoh.Session, graph: str) -> None:
        self.g = g
        self.graph = graph
        self._outcomes: dict[int, asyncio.Future[dict[str, Any]]] = {}
        self._record: TrialRecord | None = None
        self._episode = 0
        self._tasks = TaskSet()
        self.messaging = Messaging(session, logging_guard(log))
        self.messaging.subscribe(keys.world_outcome(graph), self._on_outcome)
        self.messaging.start(self._tasks)
        g.on(self._on_event, type=[HAS_INTENTION, INTENTION, PERSON])

    async def close(self) -> None:
        """Stop listening to the world bridge."""
        await self._tasks.aclose()
        self.messaging.close()

    async def _on_outcome(self, message: dict[str, Any]) -> None:
        future = self._outcomes.get(message.get("trial", -1))
        if future is not None and not future.done():
            future.set_result(message)

    def _on_event(self, event: Event) -> None:
        rec = self._record
        world = self.g.find_node(WORLD)
        if rec is None or world is None or world.get("episode") != self._episode:
            return
        if event.type == HAS_INTENTION and event.kind.value in ("edge_added", "edge_updated"):
            rec.intentions += 1
            edge = self.g.find_edge(event.src, event.dst, HAS_INTENTION)  # type: ignore[arg-type]
            if edge is None or not edge.get("risky"):
                return
            path: list[float] = list(edge.get("path") or [])
            if len(path) >= 2 and edge.src not in rec.flags:
                rec.flags[edge.src] = Mark(float(edge.get("at_time", 0.0)), (float(path[0]), float(path[1])))
            if rec.risky is None:
                rec.risky, rec.seen_risky_at = dict(edge.attrs), time.time()
                rec.snapshot = snapshot(self.g, None)
        elif event.type == PERSON and rec.person_seen_at is None and event.kind.value in ("node_added", "node_updated"):
            # The stamp is volatile: it may reach this replica after the node itself.
            node = self.g.find_node(event.id)  # type: ignore[arg-type]
            if node is not None and (stamp := node.get("stamp")) is not None:
                rec.person_seen_at = float(stamp)
        elif event.type == PERSON and event.kind.value == "node_updated" and event.id not in rec.fall_marks:
            node = self.g.find_node(event.id)  # type: ignore[arg-type]
            if node is not None and node.get("fallen"):
                x, y, _ = self.g.rt.pose2d(WORLD, node.id)
                rec.fall_marks[node.id] = Mark(float(node.get("fallen_at", 0.0)), (x, y))
        elif event.type == INTENTION and event.kind.value == "node_added":
            node = self.g.find_node(event.id)  # type: ignore[arg-type]
            if node is not None and node.get("action") not in PREVENTING:  # an answer to a fall, not to a danger
                firsts = rec.answers.setdefault(node.get("action"), {})
                firsts.setdefault(int(node.get("person", 0)), float(node.get("at_time", 0.0)))
                return
            if node is None or rec.action is not None:
                return
            if node.get("head_start"):
                rec.head_start = rec.head_start or dict(node.attrs)
                rec.last_head_start = dict(node.attrs)
                return
            rec.action, rec.seen_action_at = dict(node.attrs), time.time()
            rec.snapshot = snapshot(self.g, rec.action)

    async def _ask(self, request: dict[str, Any]) -> dict[str, Any]:
        return await self.messaging.ask(keys.world_control(self.graph), request, timeout=10.0)

    async def _cleared(self, trial: int, timeout: float) -> None:
        def clean() -> bool:
            world = self.g.find_node(WORLD)
            return (
                world is not None
                and world.get("episode") == trial
                and not self.g.nodes(PERSON)
                and not self.g.nodes(INTENTION)
                and not self.g.edges(type=HAS_INTENTION)
                and all(n.get("kind") == "wall" for n in self.g.nodes(OBJECT))
            )

        deadline = time.monotonic() + timeout
        while not clean():
            if time.monotonic() > deadline:
                raise TrialError(f"W was not cleared for trial {trial} within {timeout:g} s")
            await asyncio.sleep(0.01)

    async def run(self, seed: int, index: int | None, timeout: float, scenario: str | None = None) -> TrialRecord:
        """Run one trial (of another scenario file, if given) to its end and return what was seen."""
        request: dict[str, Any] = {"op": "prepare", "seed": seed, "index": index}
        if scenario is not None:
            request["scenario"] = scenario
        prepared = await self._ask(request)
        trial = int(prepared["trial"])
        await self._cleared(trial, 10.0)
        record = TrialRecord(index)
        self._record, self._episode = record, trial
        future: asyncio.Future[dict[str, Any]] = asyncio.get_running_loop().create_future()
        self._outcomes[trial] = future
        try:
            await self._ask({"op": "go"})
            record.outcome = await asyncio.wait_for(future, timeout)
        except TimeoutError:
            raise TrialError(f"trial {trial} did not finish within {timeout:g} s") from None
        finally:
            self._outcomes.pop(trial, None)
            self._record = None
        return record


@asynccontextmanager
async def open_harness(endpoint: str, graph: str, name: str = "experiment") -> AsyncIterator[Harness]:
    """A :class:`Harness` joined to the stack at ``endpoint``: a replica of W and the world bridge's messages."""
    session = await open_session(connect=[endpoint])
    try:
        async with wm.connect(graph, name=name, connect=[endpoint], session=session) as g:
            harness = Harness(g, session, graph)
            try:
                yield harness
            finally:
                await harness.close()
    finally:
        await close_session(session)


def finite(values: list[float | None]) -> list[float]:
    return [v for v in values if v is not None and math.isfinite(v)]
