"""Shared steps of the monitoring tests: a served graph with the risky scene, and ``wm`` runs."""

from __future__ import annotations

import json
import subprocess
from pathlib import Path
from typing import Any

from procs import REPO, WM, Proc, endpoint, free_port

HERE = Path(__file__).resolve().parent
RISKY_SCENE = HERE / "risky_scene.json"
SCENE_NAMES = {n["name"] for n in json.loads(RISKY_SCENE.read_text())["nodes"]}
GRAPH = "mon"


def run_wm(*args: str, graph: str = GRAPH) -> str:
    """Run one ``wm`` command to completion; its stdout (fails with stderr on a non-zero exit)."""
    result = subprocess.run([*WM, *args, "--graph", graph], capture_output=True, text=True, timeout=60, cwd=REPO)
    assert result.returncode == 0, f"wm {' '.join(args)} failed:\n{result.stderr}"
    return result.stdout


def served_scene(spawner, data: Path, *also: str) -> str:
    """Start ``wm serve`` (graph GRAPH plus ``also``), load the risky scene; returns its endpoint."""
    port = free_port()
    extra = [arg for graph in also for arg in ("--also", graph)]
    spawner(
        [*WM, "serve", "--data", str(data), "--graph", GRAPH, "--listen", endpoint(port), *extra], name="serve"
    ).wait_line("wm serve: ready", 20)
    run_wm("load", str(RISKY_SCENE), "--connect", endpoint(port))
    return endpoint(port)


def dump_json(where: str, graph: str = GRAPH) -> dict[str, Any]:
    return json.loads(run_wm("dump", "--format", "json", "--connect", where, graph=graph))


def start_view(spawner, where: str) -> tuple[Proc, str]:
    """Start ``wm view`` on a free port; returns the process and its page URL."""
    proc = spawner([*WM, "view", "--graph", GRAPH, "--connect", where, "--port", "0"], name="view")
    line = proc.wait_line("wm view: serving", 20)
    return proc, line.rsplit(" ", 1)[1]


def node_names(graph: dict[str, Any]) -> set[str]:
    return {n["name"] for n in graph["nodes"]}
