"""A pydsr-style agent process (examples/dsr_follower.py) and a native cortex-wm agent share one graph."""

from __future__ import annotations

import asyncio
import os
import signal
import sys
from collections.abc import Callable
from pathlib import Path

import pytest

import wm
from procs import REPO, WM, endpoint, free_port

GRAPH = "dsragents"
SCENE = REPO / "tests" / "data" / "dsr" / "autonomyLab_objects.simscene.json"
FOLLOWER = REPO / "examples" / "dsr_follower.py"
WAIT = 30.0


async def until(check: Callable[[], object], what: str) -> None:
    """Let the replica run until ``check()`` holds; fail after a bounded wait."""
    deadline = asyncio.get_running_loop().time() + WAIT
    while not check():
        if asyncio.get_running_loop().time() > deadline:
            pytest.fail(f"never happened: {what}")
        await asyncio.sleep(0.05)


async def remote_writes(stream: wm.EventStream, expected: set[tuple[str, str | None]]) -> None:
    """Read events until every expected (kind, name) has come from another replica."""
    found: set[tuple[str, str | None]] = set()
    async for event in stream:
        if not event.local:
            found.add((event.kind.value, event.name or event.dst_name))
        if expected <= found:
            return


def target_at(g: wm.Graph, x: float, y: float) -> bool:
    edge = g.find_edge("root", "follow_target", "RT")
    return edge is not None and edge.attrs["rt_translation"] == pytest.approx((x, y, 0.0), abs=1e-3)


async def test_a_pydsr_agent_and_a_native_agent_see_each_others_writes_and_signals(spawner, tmp_path: Path) -> None:
    port = free_port()
    serve = spawner(
        [*WM, "serve", "--data", str(tmp_path / "data"), "--graph", GRAPH, "--listen", endpoint(port)], name="serve"
    )
    await asyncio.to_thread(serve.wait_line, "wm serve: ready", 20)
    loaded = await asyncio.create_subprocess_exec(
        *WM, "load", str(SCENE), "--graph", GRAPH, "--connect", endpoint(port), cwd=REPO
    )
    assert await loaded.wait() == 0
    follower = spawner(
        [sys.executable, str(FOLLOWER), "--agent-id", "7", "--robot", "viriato"],
        name="follower",
        env={"WM_CONNECT": endpoint(port), "WM_GRAPH": GRAPH},
    )
    await asyncio.to_thread(follower.wait_line, "follower 7: joined", 30)

    async with wm.connect(GRAPH, connect=[endpoint(port)], name="native") as g:
        await until(lambda: g.find_node("viriato") is not None, "the native agent holds the scene")
        seen = g.events(kind=["node_added", "node_updated", "edge_added", "edge_updated"])
        alice = g.insert_node("person", "alice")
        g.rt.insert_or_assign(g.resolve("root"), alice, (2000.0, 1000.0, 0.0))

        # the pydsr agent's signal handler saw the native write ...
        await asyncio.to_thread(follower.wait_line, "follower: person alice moved", WAIT)
        # ... and the native agent sees the pydsr agent's writes: a target node placed by rt_api, the robot's speeds
        await until(lambda: target_at(g, 2000.0, 1000.0), "the follower's target at alice")
        await until(
            lambda: g.get_node("viriato").get("robot_ref_adv_speed", 0.0) > 0.0, "the follower's speed on the robot"
        )
        assert g.get_node("follow_target").attrs["person_name"] == "alice"
        await asyncio.wait_for(
            remote_writes(seen, {("node_added", "follow_target"), ("node_updated", "viriato")}), WAIT
        )
        seen.close()

        g.update_node(alice, {"person_role": "visitor"})
        await asyncio.to_thread(follower.wait_line, "follower: node", WAIT, f"{alice} changed person_role")
        g.rt.insert_or_assign(g.resolve("root"), alice, (-1000.0, 500.0, 0.0))
        await until(lambda: target_at(g, -1000.0, 500.0), "the target follows alice")

    os.kill(follower.pid, signal.SIGTERM)
    await asyncio.to_thread(follower.wait_line, "follower: stopped", 20)
    assert await asyncio.to_thread(follower.popen.wait, 20) == 0
