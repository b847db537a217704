"""Malformed bytes on any wm/** key are refused; the replica stays intact and keeps syncing."""

from __future__ import annotations

import asyncio
import os

import msgpack
import zenoh

import wm
from procs import endpoint, free_port
from wm.net import sync_protocol as proto
from wm.net.zenoh_config import build_config


async def wait_for(condition, what: str, timeout: float = 10.0) -> None:
    deadline = asyncio.get_running_loop().time() + timeout
    while not condition():
        assert asyncio.get_running_loop().time() < deadline, f"timed out waiting for {what}"
        await asyncio.sleep(0.02)


def garbage_messages(victim: str) -> list[tuple[str, bytes]]:
    valid_sv = wm.Graph().state_vector()
    return [
        ("wm/g/delta/evil", os.urandom(64)),
        ("wm/g/delta/evil", b""),
        ("wm/g/sv/evil", os.urandom(7)),
        ("wm/g/delta/evil", msgpack.packb({"not": "a message"})),
        (
            "wm/g/delta/evil",
            msgpack.packb([proto.VERSION, 1, "evil", 1, b"\x00\x01garbage", []]),
        ),  # undecodable CRDT update
        ("wm/g/delta/evil", msgpack.packb([proto.VERSION, 1, "mallory", 1, None, []])),  # sender does not match the key
        (
            "wm/g/delta/evil",
            msgpack.packb([proto.VERSION, 1, "evil", 2, None, [["x:1", "a", 1, 1, "evil"]]]),
        ),  # bad owner
        ("wm/g/sv/evil", proto.encode(proto.Heartbeat("evil", 3, b"\xff\xff\xff"))),  # truncated state vector
        ("wm/g/delta/evil", msgpack.packb([99, 1, "evil", 1, None, []])),  # unknown version
        (f"wm/g/delta/{victim}", proto.encode(proto.Delta("evil", 1, None, []))),  # impersonation
        ("wm/g/sv/evil", proto.encode(proto.Heartbeat("evil", 1, valid_sv)) + b"trailing"),
    ]


async def scenario(port: int) -> None:
    async with wm.connect("g", name="victim", listen=[endpoint(port)], heartbeat_period=0.2) as victim:
        victim.insert_node("world", "world", {"description": "intact"})
        before = victim.to_dict()
        attacker = await asyncio.to_thread(
            zenoh.open, build_config(mode="peer", connect=[endpoint(port)], listen=["tcp/127.0.0.1:0"])
        )
        try:
            for key, payload in garbage_messages(victim.replica_id):
                attacker.put(key, payload)
            replies = await asyncio.to_thread(
                lambda: [r for r in attacker.get(f"wm/g/sync/{victim.replica_id}", payload=os.urandom(40), timeout=5.0)]
            )
            assert replies and all(r.ok is None for r in replies), "a garbage sync request must get an error reply"
            stats = victim.network.stats  # type: ignore[union-attr]
            await wait_for(
                lambda: stats.rejected >= len(garbage_messages(victim.replica_id)) + 1,
                "every bad message to be rejected",
            )
            assert victim.to_dict() == before
            async with wm.connect("g", name="honest", connect=[endpoint(port)], heartbeat_period=0.2) as honest:
                assert honest.get_node("world").attrs["description"] == "intact"
                honest.insert_node("person", "alice")
                await wait_for(lambda: victim.find_node("alice") is not None, "a good write after the garbage")
        finally:
            await asyncio.to_thread(attacker.close)


def test_garbage_on_every_key_is_rejected_and_the_replica_keeps_syncing() -> None:
    asyncio.run(scenario(free_port()))


def test_a_write_refused_by_the_ontology_never_reaches_peers() -> None:
    async def run(port: int) -> None:
        async with wm.connect("g", name="a", listen=[endpoint(port)], heartbeat_period=0.2) as a:
            async with wm.connect("g", name="b", connect=[endpoint(port)], heartbeat_period=0.2) as b:
                a.insert_node("world", "world")
                try:
                    a.insert_node("person", "bob", {"radius": "wide"})
                except wm.AttributeTypeError:
                    pass
                else:
                    raise AssertionError("the ontology must refuse a str radius")
                a.insert_node("person", "carol")
                await wait_for(lambda: b.find_node("carol") is not None, "the valid write")
                assert b.find_node("bob") is None and a.find_node("bob") is None
                assert a.network.stats.published == b.network.stats.applied  # type: ignore[union-attr]

    asyncio.run(run(free_port()))
