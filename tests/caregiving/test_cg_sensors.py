"""Sensors: rate, latency, drop-outs, position noise and persistent size error, all seeded."""

from dataclasses import replace

import numpy as np
import pytest
from recorded_cases import HELD_OUT

from agents.caregiving.model.geometry import segment_exits
from agents.caregiving.model.scenario import load_scenario
from agents.caregiving.model.world_model import World
from bridges.world.sensors import LYING_HEIGHT, Sensors

STEPPING_OUT = str(HELD_OUT / "stepping_out.yaml")


def run(sensors: Sensors, world: World, seconds: float) -> list:
    got = []
    while world.time < seconds - 1e-9:
        sensors.observe(world.scene())
        got += sensors.ready(world.time)
        world.step()
    return got


def test_rate_latency_and_content() -> None:
    s = load_scenario("paper_experiment1")
    spec = replace(s.sensors, dropout=0.0)
    sensors = Sensors(spec, np.random.default_rng(0))
    world = World.from_scenario(s)
    dets = run(sensors, world, 2.0)
    stamps = sorted({d.stamp for d in dets})
    # 15 Hz sampled on a 20 Hz world clock: frames every 1 or 2 steps, about 15 per second.
    assert 26 <= len(stamps) <= 31
    assert {d.name for d in dets} == {"couch", "door", "ball", "person"}
    assert all(d.kind != "wall" for d in dets)
    assert stamps[0] == 0.0
    # Nothing is released before the latency has passed.
    fresh = Sensors(spec, np.random.default_rng(0))
    fresh.observe(s.scene())
    assert fresh.ready(0.0) == [] and len(fresh.ready(0.05)) == 4


def test_noise_statistics_and_size_bias() -> None:
    s = load_scenario("paper_experiment1")
    sensors = Sensors(s.sensors, np.random.default_rng(1))
    scene = s.scene()
    errors, radii, frames = [], set(), 600
    for k in range(frames):
        sensors.observe(replace(scene, time=k / 15))
    dets = sensors.ready(1e9)
    ball = [d for d in dets if d.name == "ball"]
    errors = np.array([[d.shape.x - 0.0, d.shape.y - 0.0] for d in ball])
    radii = {round(d.shape.r, 12) for d in ball}
    assert len(dets) / (4 * frames) == pytest.approx(0.95, abs=0.03)
    assert errors.std(axis=0) == pytest.approx([0.05, 0.05], abs=0.01)
    assert len(radii) == 1 and 0.11 * 0.8 <= radii.pop() <= 0.11 * 1.2
    couch = [d for d in dets if d.name == "couch"][0]
    assert couch.target and couch.shape.hx / 0.45 == pytest.approx(couch.shape.hy / 1.0)


def test_seeded_and_disabled() -> None:
    s = load_scenario("paper_experiment1")
    a = Sensors(s.sensors, np.random.default_rng(5))
    b = Sensors(s.sensors, np.random.default_rng(5))
    for sensors in (a, b):
        sensors.observe(s.scene())
    assert a.ready(1.0) == b.ready(1.0)
    exact = Sensors(replace(s.sensors, enabled=False), np.random.default_rng(5))
    exact.observe(s.scene())
    dets = {d.name: d for d in exact.ready(0.0)}
    assert dets["ball"].shape == s.scene().obstacle("ball").shape
    assert dets["person"].heading == 0.0


def test_a_person_who_has_fallen_is_seen_lying() -> None:
    s = load_scenario("paper_experiment1")
    world = World.from_scenario(s)
    exact = Sensors(replace(s.sensors, enabled=False), np.random.default_rng(0))
    while not world.fallen():
        exact.observe(world.scene(), world.fallen())
        world.step()
    standing = exact.ready(world.time)
    exact.observe(replace(world.scene(), time=world.time + 1.0), world.fallen())
    (lying,) = [d for d in exact.ready(world.time + 1.0) if d.kind == "person"]
    assert world.fallen() == {"person"}
    assert {d.height for d in standing if d.kind == "person"} == {s.people[0].eye_height}
    assert lying.height == LYING_HEIGHT


def test_with_occlusion_a_wall_hides_what_lies_behind_it_from_the_robot() -> None:
    """Sensors riding on the robot: someone behind the partition is not detected until they step out past its
    end; the things in the open are, every frame."""
    s = load_scenario(STEPPING_OUT)
    assert s.sensors.occlusion
    world = World.from_scenario(s)
    frames = {}
    for d in run(Sensors(replace(s.sensors, dropout=0.0), np.random.default_rng(0)), world, 4.0):
        frames.setdefault(d.name, []).append(d.stamp)
    assert frames["ann"][0] == 0.0 and frames["ball"][0] == 0.0
    ben = min(frames["ben"])
    assert 0.3 < ben < 4.0, f"Ben seen first at {ben} s"
    walls = [o for o in s.scene().obstacles[4:] if o.kind == "wall"]
    track = World.from_scenario(s)
    while track.time < ben - 0.1 - 1e-9:
        track.step()
    scene = track.scene()
    robot, hidden = scene.robot, scene.person("ben")
    assert robot is not None and any(
        not np.isnan(segment_exits(w.shape, (robot.x, robot.y), [(hidden.x, hidden.y)])[0]) for w in walls
    ), "Ben is behind the partition until then"
    unhidden = replace(s.sensors, occlusion=False)
    assert (
        min(
            d.stamp
            for d in run(Sensors(unhidden, np.random.default_rng(0)), World.from_scenario(s), 1.0)
            if d.name == "ben"
        )
        == 0.0
    )
