"""The agent runtime in one process, on a local graph: handlers, periodic tasks, failures, the agent node."""

from __future__ import annotations

import asyncio
import io
import logging
import os

import pytest

import wm
from agents import logs
from agents.runtime import Agent, every, on
from wm.reaper import reap_absent


class Recorder(Agent):
    """Records what it handles; an object named ``boom*`` makes its handler raise."""

    name = "recorder"
    status_period = 0.05
    crash_loop_failures = 3

    def __init__(self) -> None:
        super().__init__()
        self.seen: list[str] = []
        self.ticks = 0
        self.calls: list[str] = []
        self.ran = asyncio.Event()

    async def setup(self) -> None:
        self.calls.append("setup")

    async def teardown(self) -> None:
        self.calls.append("teardown")

    @on(kind="node_added", type="object")
    async def added(self, event: wm.Event) -> None:
        self.seen.append(event.name or "")
        if (event.name or "").startswith("boom"):
            raise RuntimeError(f"cannot take {event.name}")
        self.ran.set()

    @every(0.01)
    async def tick(self) -> None:
        self.ticks += 1


@pytest.fixture
def log_lines():
    stream = io.StringIO()
    logs.configure("recorder", "INFO", stream)
    yield lambda: stream.getvalue().splitlines()
    logging.getLogger().handlers.clear()


async def started(agent: Agent, g: wm.Graph) -> asyncio.Task[None]:
    task = asyncio.create_task(agent.run(g))
    while g.find_node(agent.name) is None or "setup" not in getattr(agent, "calls", ["setup"]):
        await asyncio.sleep(0.01)
    return task


async def stopped(task: asyncio.Task[None]) -> None:
    task.cancel()
    with pytest.raises(asyncio.CancelledError):
        await task


async def until(condition, what: str, timeout: float = 10.0) -> None:
    deadline = asyncio.get_running_loop().time() + timeout
    while not condition():
        if asyncio.get_running_loop().time() > deadline:
            pytest.fail(f"timed out after {timeout} s waiting for {what}")
        await asyncio.sleep(0.01)


async def test_handlers_see_events_in_order_and_survive_failures(log_lines) -> None:
    g = wm.Graph()
    agent = Recorder()
    task = await started(agent, g)
    for name in ["a", "boom1", "b", "boom2", "boom3", "c"]:
        g.insert_node("object", name)
    await until(lambda: len(agent.seen) == 6, "six events handled")
    assert agent.seen == ["a", "boom1", "b", "boom2", "boom3", "c"]
    assert agent.stats["added"].failures == 3 and agent.stats["added"].runs == 6
    await until(lambda: agent.ticks >= 3, "the periodic task to run")
    await stopped(task)
    lines = log_lines()
    failed = [line for line in lines if " handler failed " in line]
    assert len(failed) == 3
    assert 'event="node_added object boom1 (local)"' in failed[0]
    assert 'error="RuntimeError: cannot take boom1"' in failed[0] and "handler=added" in failed[0]
    assert any(" crash loop handler=added failures=3" in line for line in lines)
    assert all(" agent=recorder " in line for line in lines)


async def test_agent_node_lifecycle_and_world_link() -> None:
    g = wm.Graph()
    agent = Recorder()
    task = await started(agent, g)
    node = g.get_node("recorder")
    assert node.type == "agent"
    assert node.get("pid") == os.getpid() and node.get("replica") == g.replica_id and node.get("host")
    assert node.get("memory") > 0 and node.get("alive_since") > 0
    world = g.insert_node("world", "world")
    await until(lambda: g.find_edge(world, "recorder", "has") is not None, "the has edge from the world")
    g.delete_node("recorder")  # as a partition would: the agent puts it back
    await until(lambda: g.find_node("recorder") is not None, "the agent node to be re-created")
    await stopped(task)
    assert agent.calls == ["setup", "teardown"]
    assert g.find_node("recorder") is None


async def test_member_left_reaps_that_replicas_agent_node() -> None:
    g = wm.Graph()
    task = await started(Recorder(), g)
    g.insert_node("agent", "ghost", {"replica": "deadbeef", "pid": 1})
    g.note_member("deadbeef", "ghost", True)
    g.note_member("deadbeef", "ghost", False)
    await until(lambda: g.find_node("ghost") is None, "the ghost's node to be reaped")
    assert g.find_node("recorder") is not None
    await stopped(task)


def test_reap_absent_keeps_live_replicas() -> None:
    g = wm.Graph()
    g.insert_node("agent", "alive", {"replica": "r1"})
    g.insert_node("agent", "dead", {"replica": "r2"})
    assert reap_absent(g, {"r1"}) == ["dead"]
    assert [n.name for n in g.nodes("agent")] == ["alive"]


async def test_a_slow_handler_drops_oldest_events_and_logs_it(log_lines) -> None:
    release = asyncio.Event()

    class Slow(Agent):
        name = "recorder"

        @on(kind="node_added", maxsize=2)
        async def slow(self, event: wm.Event) -> None:
            await release.wait()

    g = wm.Graph()
    agent = Slow()
    task = await started(agent, g)
    for i in range(6):
        g.insert_node("object", f"o{i}")  # the writer is never blocked
    release.set()
    await until(lambda: agent.stats.get("slow") and agent.stats["slow"].dropped > 0, "drops to be noticed")
    await stopped(task)
    assert any(" events dropped handler=slow " in line for line in log_lines())


def test_declarations_are_checked_when_the_class_is_written() -> None:
    with pytest.raises(TypeError, match="async def"):
        on(kind="node_added")(lambda self, event: None)
    with pytest.raises(ValueError, match="unknown event kind"):
        on(kind="node_moved")
    with pytest.raises(ValueError, match="positive"):
        every(0)

    async def handler(self, event):
        pass

    with pytest.raises(TypeError, match="two @on"):
        on(kind="node_added")(on(kind="node_removed")(handler))


def test_log_values_are_quoted_only_when_needed() -> None:
    assert logs.format_fields({"a": "plain", "b": "two words", "c": 'say "x"', "d": 3}) == (
        'a=plain b="two words" c="say \\"x\\"" d=3'
    )
