"""The `wm` commands end to end against a running `wm serve`."""

from __future__ import annotations

import json
import subprocess
from pathlib import Path

from procs import REPO, WM, endpoint, free_port

GRAPH = "cli"


def wm(*args: str) -> subprocess.CompletedProcess[str]:
    result = subprocess.run([*WM, *args, "--graph", GRAPH], capture_output=True, text=True, timeout=60, cwd=REPO)
    assert result.returncode == 0, result.stderr
    return result


def test_load_set_watch_members_rm_and_dump(spawner, tmp_path: Path) -> None:
    port = free_port()
    serve = spawner(
        [*WM, "serve", "--data", str(tmp_path / "data"), "--graph", GRAPH, "--listen", endpoint(port)], name="serve"
    )
    serve.wait_line("wm serve: ready", 20)
    scene = tmp_path / "scene.json"
    scene.write_text(
        json.dumps(
            {
                "format": "cortex-wm",
                "version": 1,
                "edges": [],
                "nodes": [
                    {"id": 1, "type": "world", "name": "world", "attrs": {}},
                    {"id": 2, "type": "person", "name": "alice", "attrs": {"radius": 0.3}},
                ],
            }
        )
    )
    assert "loaded 2 nodes" in wm("load", str(scene), "--connect", endpoint(port)).stdout

    watch = spawner([*WM, "watch", "--graph", GRAPH, "--connect", endpoint(port), "--type", "person"], name="watch")
    watch.wait_line("watching graph", 30)
    members = wm("members", "--connect", endpoint(port)).stdout
    assert " serve" in members and " wm-watch" in members, members
    wm("set", "alice", "radius=0.4", "speed=0.5", "gaze_range=[-0.2,0.1]", "--connect", endpoint(port))
    assert watch.wait_line("node_updated person alice", 20).split("[")[1].startswith("'gaze_range', 'radius', 'speed'")
    wm("rm", "alice", "--connect", endpoint(port))
    watch.wait_line("node_removed person alice", 20)

    dumped = json.loads(wm("dump", "--format", "json", "--connect", endpoint(port)).stdout)
    assert [n["name"] for n in dumped["nodes"]] == ["world"]
    text = wm("dump", "--connect", endpoint(port)).stdout
    assert text.startswith("node 1 world world")


def test_set_refuses_a_value_of_the_wrong_type_in_one_line(spawner, tmp_path: Path) -> None:
    port = free_port()
    spawner(
        [*WM, "serve", "--data", str(tmp_path / "data"), "--graph", GRAPH, "--listen", endpoint(port)], name="serve"
    ).wait_line("wm serve: ready", 20)
    result = subprocess.run(
        [*WM, "set", "world", "radius=wide", "--graph", GRAPH, "--connect", endpoint(port)],
        capture_output=True,
        text=True,
        timeout=60,
        cwd=REPO,
    )
    assert result.returncode == 1 and result.stderr.count("\n") == 1 and "radius" in result.stderr
