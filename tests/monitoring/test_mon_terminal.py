"""``wm monitor``: its screen for a given graph, and a smoke run under tmux that waits for the network."""

from __future__ import annotations

import os
import shutil
import subprocess
from pathlib import Path

import pytest
from mon_helpers import GRAPH, RISKY_SCENE, SCENE_NAMES, run_wm
from rich.console import Console

import wm
from procs import REPO, WM, endpoint, free_port, wait_until
from wm.events import Event, EventKind
from wm.monitoring.monitor import MonitorState, render


def screen(g: wm.Graph, state: MonitorState) -> str:
    console = Console(record=True, width=160, file=open(os.devnull, "w"))
    console.print(render(g, state, "demo"))
    return console.export_text()


def test_screen_shows_members_agents_counts_rates_nodes_and_the_log() -> None:
    g = wm.Graph()
    g.load_json(RISKY_SCENE)
    g.insert_node("agent", "intention-agent", {"replica": "gone-replica", "pid": 42, "cpu": 12.5})
    state = MonitorState()
    for _ in range(10):
        state.on_event(Event(EventKind.EDGE_UPDATED, "RT", "w", False))
    state.on_logged(Event(EventKind.NODE_UPDATED, "person", "w", False, frozenset({"speed"}), id=2, name="alice"))
    text = screen(g, state)
    assert "graph demo" in text
    assert "intention-agent" in text and "gone" in text  # an agent whose replica is not a member
    assert "2.0" in text  # 10 RT updates over the 5 s window
    for name in SCENE_NAMES:
        assert name in text
    assert "-3.00, 0.30" in text  # alice's world position from the RT tree
    assert "node_updated person alice ['speed']" in text


@pytest.fixture
def tmux(tmp_path: Path):
    """A private tmux server (its own socket), killed at teardown."""
    if shutil.which("tmux") is None:
        pytest.skip("tmux is missing: `make system-deps` installs it (needs root)")
    socket = str(tmp_path / "tmux.sock")

    def run(*args: str) -> str:
        return subprocess.run(
            ["tmux", "-S", socket, *args], capture_output=True, text=True, timeout=10, check=True
        ).stdout

    yield run
    subprocess.run(["tmux", "-S", socket, "kill-server"], capture_output=True, timeout=10)


def test_monitor_under_tmux_waits_for_the_network_then_shows_the_graph(tmux, spawner, tmp_path: Path) -> None:
    port = free_port()
    command = " ".join(
        [
            "env",
            "-u",
            "COLUMNS",
            "-u",
            "LINES",
            *WM,
            "monitor",
            "--graph",
            GRAPH,
            "--connect",
            endpoint(port),
            "--type",
            "person",
        ]
    )
    tmux("new-session", "-d", "-s", "mon", "-x", "200", "-y", "100", "-c", str(REPO), command)
    pane = lambda: tmux("capture-pane", "-p", "-t", "mon")  # noqa: E731
    wait_until(lambda: "nothing heard" in pane(), 30, "the monitor to say it hears nothing")
    spawner(
        [*WM, "serve", "--data", str(tmp_path / "data"), "--graph", GRAPH, "--listen", endpoint(port)], name="serve"
    ).wait_line("wm serve: ready", 20)
    run_wm("load", str(RISKY_SCENE), "--connect", endpoint(port))
    wait_until(lambda: all(name in pane() for name in SCENE_NAMES), 30, "the monitor to show the scene")
    run_wm("set", "alice", "speed=0.9", "--connect", endpoint(port))
    wait_until(lambda: "node_updated person alice ['speed']" in pane(), 30, "the filtered event log to show the change")
    assert "live" in pane()
