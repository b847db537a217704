"""``confirm()`` says which replicas acknowledged a writer's DELTAs, and ``durable=True`` waits for one on disk."""

from __future__ import annotations

import asyncio
import os
import signal
from pathlib import Path

import wm
from procs import PYTHON, REPO, WM, endpoint, free_port
from wm.net.connection import open_session

GRAPH = "confirm"
REPLICA = str(REPO / "tests" / "replica_proc.py")


def start_replica(spawner, port: int, name: str):
    proc = spawner([PYTHON, REPLICA, "--graph", GRAPH, "--name", name, "--connect", endpoint(port)], name=name)
    return proc, proc.wait_line("ready", 20).split()[1]


async def members_named(g: wm.Graph, count: int) -> dict[str, str]:
    for _ in range(100):
        members = await g.network.live_members()  # type: ignore[union-attr]
        if len(members) >= count:
            return members
        await asyncio.sleep(0.1)
    raise AssertionError(f"fewer than {count} members: {members}")


def test_durable_confirmation_names_wm_serve_and_a_stalled_replica_delays_nobody(spawner, tmp_path: Path) -> None:
    port = free_port()
    serve = spawner(
        [*WM, "serve", "--data", str(tmp_path / "data"), "--graph", GRAPH, "--listen", endpoint(port)], name="serve"
    )
    serve.wait_line("wm serve: ready", 20)
    quick, quick_id = start_replica(spawner, port, "quick")
    stalled, stalled_id = start_replica(spawner, port, "stalled")

    async def run() -> None:
        async with wm.connect(GRAPH, name="writer", connect=[endpoint(port)], heartbeat_period=0.3) as g:
            members = await members_named(g, 3)
            durable = next(replica for replica, agent in members.items() if agent == "serve")
            g.insert_node("world", "world")
            first = await g.network.confirm(10.0, durable=True)  # type: ignore[union-attr]
            assert first and durable in first.on_disk and first.on_disk <= first.acked
            os.kill(stalled.pid, signal.SIGSTOP)
            try:
                g.insert_node("person", "alice")
                while True:  # the first round may end before the quick replica has the write; every round is bounded
                    second = await g.network.confirm(10.0)  # type: ignore[union-attr]
                    if {durable, quick_id} <= second.acked:
                        break
                assert second and stalled_id not in second.acked
                on_disk = await g.network.confirm(10.0, durable=True)  # type: ignore[union-attr]
                assert on_disk and on_disk.on_disk == {durable}
            finally:
                os.kill(stalled.pid, signal.SIGCONT)

    asyncio.run(run())
    assert quick.popen.poll() is None


def test_without_a_durable_member_a_durable_confirmation_fails_but_names_who_acknowledged(spawner) -> None:
    port = free_port()
    listener = spawner([PYTHON, REPLICA, "--graph", GRAPH, "--name", "peer", "--listen", endpoint(port)], name="peer")
    peer_id = listener.wait_line("ready", 20).split()[1]

    async def run() -> None:
        async with wm.connect(GRAPH, name="writer", connect=[endpoint(port)]) as g:
            await members_named(g, 1)
            nothing_yet = await g.network.confirm(1.0, durable=True)  # type: ignore[union-attr]
            assert not nothing_yet and nothing_yet.acked == {peer_id}, (
                "a replica without a disk never counts as durable"
            )
            g.insert_node("world", "world")
            plain = await g.network.confirm(10.0)  # type: ignore[union-attr]
            assert plain and plain.acked == {peer_id}
            durable = await g.network.confirm(1.5, durable=True)  # type: ignore[union-attr]
            assert not durable and durable.acked == {peer_id} and not durable.on_disk

    asyncio.run(run())


def test_queries_on_a_session_closed_under_the_replica_find_nobody_instead_of_raising() -> None:
    """An agent that closes its own session while the replica still asks (a repair, a catch-up) gets no answers."""

    async def run() -> None:
        session = await open_session(listen=[endpoint(free_port())])
        async with wm.connect(GRAPH, name="alone", session=session) as g:
            network = g.network
            assert network is not None
            session.close()  # type: ignore[no-untyped-call]
            assert await network.live_members() == {}
            assert await network.sync_from("nobody") is False
            assert not await network.confirm(0.2)

    asyncio.run(run())
