"""`wm foxglove`: a WebSocket client speaking the Foxglove protocol sees a pose another process writes; garbage harms nothing."""

from __future__ import annotations

import asyncio
import base64
import json
import struct
import subprocess
import sys
from pathlib import Path
from typing import Any

import websockets
from mon_helpers import GRAPH, dump_json, served_scene

from foxglove_helpers import message_class
from procs import REPO, WM, free_port

PROTOCOL = "foxglove.sdk.v1"
MESSAGE_DATA = 0x01
WAIT = 30.0


def write_pose(where: str, x: float, y: float, yaw: float) -> None:
    """Another process places alice in the world, through the working memory."""
    script = (
        "import asyncio, sys, wm\n"
        "async def main():\n"
        f"    async with wm.connect({GRAPH!r}, connect=[{where!r}], name='mover') as g:\n"
        f"        g.rt.set_pose2d('world', 'alice', {x}, {y}, {yaw})\n"
        "        sys.exit(0 if await g.network.confirm(10) else 1)\n"
        "asyncio.run(main())\n"
    )
    subprocess.run([sys.executable, "-c", script], check=True, timeout=60, cwd=REPO)


async def advertised(ws: Any) -> dict[str, dict[str, Any]]:
    """Read the server's first messages until its channels are advertised; topic -> channel."""
    channels: dict[str, dict[str, Any]] = {}
    while not {"/wm/tf", "/wm/scene", "/wm/changes", "/wm/log"} <= set(channels):
        message = json.loads(await ws.recv())
        if message["op"] == "advertise":
            channels |= {c["topic"]: c for c in message["channels"]}
    return channels


async def transform_of(ws: Any, decode: Any, child: str, translation: tuple[float, float, float]) -> Any:
    """Read messages until a FrameTransforms places ``child`` at ``translation``."""
    while True:
        data = await ws.recv()
        if not isinstance(data, bytes) or data[0] != MESSAGE_DATA:
            continue
        transforms = decode.FromString(data[1 + 4 + 8 :]).transforms
        for t in transforms:
            if t.child_frame_id == child and (t.translation.x, t.translation.y, t.translation.z) == translation:
                return t


async def log_of(ws: Any, decode: Any) -> Any:
    """The first foxglove.Log message received (subscription 8)."""
    while True:
        data = await ws.recv()
        if isinstance(data, bytes) and data[0] == MESSAGE_DATA and struct.unpack("<I", data[1:5])[0] == 8:
            return decode.FromString(data[1 + 4 + 8 :])


async def test_a_foxglove_client_receives_the_pose_another_process_writes_and_cannot_write(
    spawner, tmp_path: Path
) -> None:
    where = served_scene(spawner, tmp_path / "data")
    port = free_port()
    logs = tmp_path / "logs"
    logs.mkdir()
    agent_log = logs / "intention.log"
    agent_log.write_text("2026-01-01T00:00:00.000Z INFO agent=intention written before the view started\n")
    server = spawner(
        [*WM, "foxglove", "--port", str(port), "--graph", GRAPH, "--connect", where, "--logs", str(logs)],
        name="foxglove",
    )
    await asyncio.to_thread(server.wait_line, "wm foxglove: serving", 30)
    before = dump_json(where)

    async with websockets.connect(f"ws://127.0.0.1:{port}", subprotocols=[PROTOCOL]) as ws:
        channels = await asyncio.wait_for(advertised(ws), WAIT)
        tf = channels["/wm/tf"]
        assert (tf["encoding"], tf["schemaName"]) == ("protobuf", "foxglove.FrameTransforms")
        assert channels["/wm/scene"]["schemaName"] == "foxglove.SceneUpdate"
        decode = message_class("foxglove.FrameTransforms", base64.b64decode(tf["schema"]))
        await ws.send(json.dumps({"op": "subscribe", "subscriptions": [{"id": 7, "channelId": tf["id"]}]}))
        await ws.send(
            json.dumps({"op": "subscribe", "subscriptions": [{"id": 8, "channelId": channels["/wm/log"]["id"]}]})
        )
        with agent_log.open("a") as log:
            log.write("2026-11-23T14:25:02.276Z WARNING agent=intention risky path person=alice\n")
        logged = await asyncio.wait_for(
            log_of(ws, message_class("foxglove.Log", base64.b64decode(channels["/wm/log"]["schema"]))), WAIT
        )
        assert (logged.name, logged.message, logged.timestamp.ToNanoseconds()) == (
            "intention",
            "agent=intention risky path person=alice",
            1795443902276000000,
        )
        assert logged.level == 3  # WARNING

        await asyncio.to_thread(write_pose, where, 1.25, -0.5, 0.0)
        placed = await asyncio.wait_for(transform_of(ws, decode, "alice", (1.25, -0.5, 0.0)), WAIT)
        assert placed.parent_frame_id == "world" and placed.rotation.w == 1.0

        # a client that sends garbage, or tries to publish, changes nothing and stops nobody
        async with websockets.connect(f"ws://127.0.0.1:{port}", subprotocols=[PROTOCOL]) as rogue:
            await asyncio.wait_for(advertised(rogue), WAIT)
            for garbage in (
                "not json",
                "{}",
                json.dumps({"op": "subscribe", "subscriptions": "all"}),
                json.dumps(
                    {
                        "op": "advertise",
                        "channels": [
                            {"id": 1, "topic": "/wm/changes", "encoding": "json", "schemaName": "wm.GraphChange"}
                        ],
                    }
                ),
            ):
                await rogue.send(garbage)
            await rogue.send(
                bytes([0x01]) + struct.pack("<I", 1) + json.dumps({"kind": "node_removed", "name": "alice"}).encode()
            )
            await rogue.send(b"\xff\x00\x13")

        await asyncio.to_thread(write_pose, where, -2.0, 0.75, 0.0)
        await asyncio.wait_for(transform_of(ws, decode, "alice", (-2.0, 0.75, 0.0)), WAIT)

    after = dump_json(where)
    assert [n["name"] for n in after["nodes"]] == [n["name"] for n in before["nodes"]]
    assert server.popen.poll() is None
