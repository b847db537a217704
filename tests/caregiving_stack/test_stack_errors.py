"""Bad scenario files and malformed requests get clear errors; the processes carry on."""

from __future__ import annotations

import asyncio
import re
import subprocess
from pathlib import Path

import pytest

from agents.caregiving import keys
from agents.messaging import Messaging, NoReply, RemoteError
from procs import PYTHON, REPO, WM, Proc, endpoint, free_port
from wm.net.connection import close_session, open_session

BROKEN = """name: broken
room: {size: [8.0, 6.0]}
objects:
  - {name: couch, kind: couch, shape: {type: box, size: [0.9, 2.0]}, height: 0.8, pose: [3.5, 0.0, 0.0], target: true}
people:
  - {name: p, pose: [-2.5, 0, 0], target: couch, speed: fast, radius: 0.25, eye_height: 1.6, hfov_deg: 120,
     vfov_deg: 40, gaze_range_deg: [6, 10]}
robot: {pose: [0, -2, 90], footprint: [0.5, 0.4], height: 1.5, max_speed: 0.8, max_accel: 0.6}
sensors: {rate_hz: 15, position_sigma: 0.05, size_error: 0.2, dropout: 0.05, latency: 0.05}
randomisation: {}
"""


def wm_experiment(*args: str) -> subprocess.CompletedProcess[str]:
    return subprocess.run([*WM, "experiment", *args], check=False, capture_output=True, text=True, timeout=60, cwd=REPO)


def test_experiment_with_a_bad_scenario_file_fails_clearly(tmp_path: Path) -> None:
    bad = tmp_path / "broken.yaml"
    bad.write_text(BROKEN)
    result = wm_experiment(str(bad), "--trials", "1")
    assert result.returncode == 1
    assert "wm experiment: error: people[0].speed" in result.stderr


def test_experiment_with_bad_trial_numbers_fails_clearly() -> None:
    result = wm_experiment("paper_experiment1", "--only", "3,x")
    assert result.returncode == 2
    assert "--only: expected trial numbers separated by commas, got '3,x'" in result.stderr


def test_world_bridge_refuses_a_bad_scenario(tmp_path: Path) -> None:
    result = subprocess.run(
        [PYTHON, "-m", "bridges.world", "--scenario", str(tmp_path / "missing.yaml")],
        check=False,
        capture_output=True,
        text=True,
        timeout=60,
        cwd=REPO,
    )
    assert result.returncode == 1 and "world: error: <file>: cannot read" in result.stderr


def test_world_bridge_answers_malformed_requests_with_errors_and_keeps_running() -> None:
    port = free_port()
    world = Proc(
        [
            PYTHON,
            "-m",
            "bridges.world",
            "--graph",
            "errs",
            "--scenario",
            "paper_experiment1",
            "--listen",
            endpoint(port),
        ],
        "world",
    )
    try:
        world.wait_line("world: ready", 30)

        async def go() -> None:
            session = await open_session(connect=[endpoint(port)])
            try:
                control, cmd = keys.world_control("errs"), keys.robot_cmd("errs")
                ask = Messaging(session).ask
                with pytest.raises(RemoteError, match="control.op"):
                    await ask(control, {"op": "explode"})
                with pytest.raises(RemoteError, match="no trial is prepared"):
                    await ask(control, {"op": "go"})
                with pytest.raises(RemoteError, match="is not running"):
                    await ask(cmd, {"trial": 1, "move": {"target": "ball", "x": 0, "y": 0}})
                with pytest.raises(RemoteError, match="people\\[0\\].speed|cannot read"):
                    await ask(control, {"op": "prepare", "seed": 1, "scenario": "no_such_scenario"})
                with pytest.raises(NoReply, match=f"nobody answers on {re.escape(keys.imagine('errs'))}"):
                    await ask(keys.imagine("errs"), {"items": []}, timeout=10.0)  # no simulator runs
                ok = await ask(control, {"op": "prepare", "seed": 1, "index": 3})
                assert ok["trial"] == 1 and ok["running"] is False
            finally:
                await close_session(session)

        asyncio.run(go())
        assert world.popen.poll() is None
    finally:
        world.stop()
