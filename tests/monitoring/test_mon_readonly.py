"""Monitors never write: the viewer, recorder and terminal monitor only subscribe and ask.

A raw Zenoh session watches every put and liveliness token on the graph's key
space while the three monitors join, catch up and follow a change: everything
on the wire comes from the writers, and every monitor ends up with the
writers' graph.
"""

from __future__ import annotations

import json
import threading
from pathlib import Path

import zenoh
from mon_helpers import GRAPH, SCENE_NAMES, dump_json, run_wm, served_scene, start_view
from websockets.sync.client import connect as ws_connect

from procs import WM, wait_until
from wm.monitoring.recording_file import graph_at
from wm.net.zenoh_config import build_config

MONITORS = {"wm-view", "wm-record", "wm-monitor"}


def view_state(url: str) -> dict:
    """The state a page gets when it connects to ``wm view``."""
    with ws_connect(url.replace("http://", "ws://") + "ws", open_timeout=10) as ws:
        return json.loads(ws.recv(timeout=10))


class Wire:
    """Every put key and liveliness token seen on ``wm/<graph>/**``."""

    def __init__(self, where: str) -> None:
        self.session = zenoh.open(build_config(connect=[where], listen=["tcp/127.0.0.1:0"]))
        self.lock = threading.Lock()
        self.puts: list[str] = []
        self.tokens: dict[str, str] = {}
        self.session.declare_subscriber(f"wm/{GRAPH}/**", self._on_put)
        self.session.liveliness().declare_subscriber(f"wm/{GRAPH}/alive/**", self._on_token, history=True)

    def _on_put(self, sample: zenoh.Sample) -> None:
        with self.lock:
            self.puts.append(str(sample.key_expr))

    def _on_token(self, sample: zenoh.Sample) -> None:
        _, _, _, replica, agent = str(sample.key_expr).split("/")
        with self.lock:
            self.tokens[replica] = agent

    def senders(self) -> set[str]:
        with self.lock:
            return {key.split("/")[3] for key in self.puts}


def test_viewer_recorder_and_monitor_never_write(spawner, tmp_path: Path) -> None:
    where = served_scene(spawner, tmp_path / "data")
    wire = Wire(where)
    try:
        before = dump_json(where)
        _, url = start_view(spawner, where)
        recorder = spawner(
            [*WM, "record", str(tmp_path / "run.mcap"), "--graph", GRAPH, "--connect", where], name="record"
        )
        recorder.wait_line("wm record: recording", 20)
        monitor = spawner(
            [*WM, "monitor", "--graph", GRAPH, "--connect", where], name="monitor", env={"COLUMNS": "160"}
        )
        wait_until(
            lambda: {n["name"] for n in view_state(url)["graph"]["nodes"]} == SCENE_NAMES,
            20,
            "the viewer to show the scene",
        )

        run_wm("set", "alice", "speed=0.9", "--connect", where)
        wait_until(
            lambda: _alice(view_state(url)["graph"])["attrs"]["speed"] == 0.9, 20, "the viewer to follow the change"
        )
        after = dump_json(where)
        assert _alice(after)["attrs"]["speed"] == 0.9 and _alice(before)["attrs"]["speed"] == 0.5
        assert view_state(url)["graph"] == after
        monitor.stop()
        recorder.stop()
        assert graph_at(tmp_path / "run.mcap").to_dict() == after

        with wire.lock:
            tokens = dict(wire.tokens)
        assert not MONITORS & set(tokens.values()), tokens
        writers = {replica for replica, agent in tokens.items() if agent in ("serve", "wm-set", "wm-load", "wm-dump")}
        assert wire.senders() and wire.senders() <= writers, (wire.senders(), tokens)
        assert dump_json(where) == after
    finally:
        wire.session.close()


def _alice(graph: dict) -> dict:
    return next(n for n in graph["nodes"] if n["name"] == "alice")
