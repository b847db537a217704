"""Draw docs/img/wm-foxglove.png: what a Foxglove client receives from ``wm foxglove``, seen from above.

    python docs/img/capture_foxglove.py [--out docs/img/wm-foxglove.png]

1. Starts ``wm serve`` on a free loopback port and loads the risky test scene
   (``tests/monitoring/risky_scene.json``: a person whose path to the couch is risky).
2. Starts ``wm foxglove`` on another free port and connects to it with the Foxglove
   WebSocket protocol; subscribes to ``/wm/tf`` and ``/wm/scene`` and decodes the first
   message of each with the protobuf schemas the server advertises.
3. Draws them as Foxglove's 3D panel would from above: each frame's x (red) and y
   (green) axes, named, and the scene's boxes, cylinders, lines, triangle fans,
   spheres and labels.
4. Stops both processes by PID.
"""

from __future__ import annotations

import argparse
import asyncio
import base64
import json
import math
import socket
import subprocess
import sys
import tempfile
from pathlib import Path
from typing import Any

import matplotlib

matplotlib.use("Agg")
import matplotlib.pyplot as plt
import websockets
from google.protobuf import descriptor_pb2, descriptor_pool, message_factory
from matplotlib.patches import Circle, Polygon, Rectangle

REPO = Path(__file__).resolve().parents[2]
OUT = Path(__file__).resolve().parent / "wm-foxglove.png"
SCENE = REPO / "tests" / "monitoring" / "risky_scene.json"
WM = [sys.executable, "-m", "wm.cli"]
GRAPH = "foxglove-doc"


def free_port() -> int:
    with socket.socket() as s:
        s.bind(("127.0.0.1", 0))
        return int(s.getsockname()[1])


def start(argv: list[str], ready: str) -> subprocess.Popen[str]:
    proc = subprocess.Popen(argv, stdout=subprocess.PIPE, stderr=subprocess.STDOUT, text=True, cwd=REPO)
    assert proc.stdout is not None
    for line in proc.stdout:
        if line.startswith(ready):
            return proc
    raise RuntimeError(f"{argv[3]} exited before {ready!r}")


def decoder(channel: dict[str, Any]) -> Any:
    files = descriptor_pb2.FileDescriptorSet.FromString(base64.b64decode(channel["schema"]))
    pool = descriptor_pool.DescriptorPool()
    for proto in files.file:
        pool.Add(proto)
    return message_factory.GetMessageClass(pool.FindMessageTypeByName(channel["schemaName"]))


async def receive(port: int) -> dict[str, Any]:
    """The first /wm/tf and /wm/scene messages, decoded."""
    async with websockets.connect(f"ws://127.0.0.1:{port}", subprotocols=["foxglove.sdk.v1"]) as ws:
        channels: dict[str, dict[str, Any]] = {}
        while not {"/wm/tf", "/wm/scene"} <= set(channels):
            message = json.loads(await ws.recv())
            if message["op"] == "advertise":
                channels |= {c["topic"]: c for c in message["channels"]}
        topics = {1: "/wm/tf", 2: "/wm/scene"}
        await ws.send(
            json.dumps(
                {
                    "op": "subscribe",
                    "subscriptions": [{"id": sub, "channelId": channels[topic]["id"]} for sub, topic in topics.items()],
                }
            )
        )
        decoded: dict[str, Any] = {}
        while len(decoded) < len(topics):
            data = await ws.recv()
            if isinstance(data, bytes) and data[0] == 1:
                topic = topics[int.from_bytes(data[1:5], "little")]
                decoded[topic] = decoder(channels[topic]).FromString(data[13:])
        return decoded


def yaw(q: Any) -> float:
    return math.atan2(2 * (q.w * q.z + q.x * q.y), 1 - 2 * (q.y * q.y + q.z * q.z))


def world_poses(transforms: Any, root: str) -> dict[str, tuple[float, float, float]]:
    """Each frame's planar pose in ``root``'s frame, chaining the transforms."""
    parent = {t.child_frame_id: t for t in transforms.transforms}
    poses: dict[str, tuple[float, float, float]] = {root: (0.0, 0.0, 0.0)}

    def pose(frame: str) -> tuple[float, float, float]:
        if frame not in poses:
            t = parent[frame]
            px, py, pa = pose(t.parent_frame_id)
            x, y = t.translation.x, t.translation.y
            poses[frame] = (
                px + x * math.cos(pa) - y * math.sin(pa),
                py + x * math.sin(pa) + y * math.cos(pa),
                pa + yaw(t.rotation),
            )
        return poses[frame]

    for frame in parent:
        pose(frame)
    return poses


def rgba(c: Any) -> tuple[float, float, float, float]:
    return (c.r, c.g, c.b, c.a)


def draw(decoded: dict[str, Any], out: Path) -> None:
    scene, transforms = decoded["/wm/scene"], decoded["/wm/tf"]
    fig, ax = plt.subplots(figsize=(8, 6.5), dpi=120)
    ax.set_facecolor("#2b2b33")
    for entity in scene.entities:
        for cube in entity.cubes:
            p, a = cube.pose.position, yaw(cube.pose.orientation)
            corner = (p.x - cube.size.x / 2, p.y - cube.size.y / 2)
            ax.add_patch(
                Rectangle(
                    corner,
                    cube.size.x,
                    cube.size.y,
                    angle=math.degrees(a),
                    rotation_point="center",
                    color=rgba(cube.color),
                )
            )
        for cylinder in entity.cylinders:
            p = cylinder.pose.position
            ax.add_patch(Circle((p.x, p.y), cylinder.size.x / 2, color=rgba(cylinder.color)))
        for fan in entity.triangles:
            for i in range(0, len(fan.points) - 2, 3):
                ax.add_patch(Polygon([(q.x, q.y) for q in fan.points[i : i + 3]], color=rgba(fan.color), lw=0))
        for line in entity.lines:
            ax.plot([q.x for q in line.points], [q.y for q in line.points], color=rgba(line.color), lw=2.5)
        for sphere in entity.spheres:
            p = sphere.pose.position
            ax.add_patch(Circle((p.x, p.y), sphere.size.x / 2, color=rgba(sphere.color)))
        for text in entity.texts:
            ax.annotate(
                text.text,
                (text.pose.position.x, text.pose.position.y),
                color="white",
                fontsize=9,
                ha="center",
                xytext=(0, 12),
                textcoords="offset points",
            )
    root = scene.entities[0].frame_id if scene.entities else "world"
    for frame, (x, y, a) in world_poses(transforms, root).items():
        for angle, color in ((a, "#ff4040"), (a + math.pi / 2, "#40ff40")):
            ax.arrow(
                x,
                y,
                0.35 * math.cos(angle),
                0.35 * math.sin(angle),
                width=0.015,
                color=color,
                length_includes_head=True,
            )
        ax.annotate(frame, (x, y), color="#bbbbbb", fontsize=7, xytext=(4, -10), textcoords="offset points")
    ax.set_aspect("equal")
    ax.autoscale_view()
    ax.margins(0.08)
    ax.grid(color="#44444f", lw=0.5)
    ax.set_title(
        f"wm foxglove: /wm/tf ({len(transforms.transforms)} frames) and /wm/scene ({len(scene.entities)} entities)"
    )
    fig.tight_layout()
    fig.savefig(out)


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--out", type=Path, default=OUT)
    args = parser.parse_args()
    wm_port, fox_port = free_port(), free_port()
    where = f"tcp/127.0.0.1:{wm_port}"
    procs = []
    try:
        with tempfile.TemporaryDirectory() as data:
            procs.append(start([*WM, "serve", "--data", data, "--graph", GRAPH, "--listen", where], "wm serve: ready"))
            subprocess.run([*WM, "load", str(SCENE), "--graph", GRAPH, "--connect", where], check=True, cwd=REPO)
            procs.append(
                start(
                    [*WM, "foxglove", "--port", str(fox_port), "--graph", GRAPH, "--connect", where],
                    "wm foxglove: serving",
                )
            )
            draw(asyncio.run(asyncio.wait_for(receive(fox_port), 60)), args.out)
            print(f"wrote {args.out}")
    finally:
        for proc in reversed(procs):
            proc.terminate()
            proc.wait(timeout=20)


if __name__ == "__main__":
    main()
