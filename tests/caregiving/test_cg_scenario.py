"""Scenario files: shipped files load, broken ones name the key path, trials are sampled soundly."""

import copy
import math
from pathlib import Path

import numpy as np
import pytest
import yaml
from recorded_cases import HELD_OUT

from agents.caregiving.model.errors import ScenarioError
from agents.caregiving.model.geometry import shapes_overlap
from agents.caregiving.model.scenario import (
    PLACEMENT_MARGIN,
    SHIPPED,
    load_scenario,
    parse_scenario,
    sample_trial,
    shipped_scenarios,
)
from agents.caregiving.model.world_model import World

SHIPPED_NAMES = shipped_scenarios()
#: Every room file: the shipped scenarios and the held-out rooms the results were measured in.
ROOM_FILES = [str(SHIPPED.joinpath(f"{name}.yaml")) for name in SHIPPED_NAMES] + sorted(
    str(p) for p in HELD_OUT.glob("*.yaml")
)


def raw(name: str = "paper_experiment1") -> dict:
    return yaml.safe_load(SHIPPED.joinpath(f"{name}.yaml").read_text())


def test_all_required_scenarios_are_shipped() -> None:
    assert {"paper_experiment1", "safe_walk", "person_sees_obstacle", "two_people", "cluttered_room"} <= set(
        SHIPPED_NAMES
    )


@pytest.mark.parametrize("name", SHIPPED_NAMES)
def test_shipped_scenarios_load(name: str) -> None:
    s = load_scenario(name)
    scene = s.scene()
    assert scene.robot is not None and len(scene.people) >= 1
    assert all(o.kind == "wall" for o in scene.obstacles[:4])


@pytest.mark.parametrize("path", ROOM_FILES, ids=lambda path: Path(path).stem)
def test_every_room_file_gives_trials_where_everyone_can_walk_to_their_target(path: str) -> None:
    """A room whose furniture walls someone in would count their being stuck as a fall in every trial."""
    s = load_scenario(path)
    for seed in range(2):
        world = World.from_scenario(sample_trial(s, np.random.default_rng(seed)))
        world.run()
        assert [p for p in world.people() if world.walker(p).status == "stuck"] == []


def test_paper_experiment1_matches_the_paper_setup() -> None:
    s = load_scenario(str(SHIPPED.joinpath("paper_experiment1.yaml")))
    assert [p.speed for p in s.people] == [0.5]
    assert s.people[0].target == "couch"
    assert {o.name for o in s.objects} >= {"couch", "door", "ball"}
    assert set(s.randomisation.entities) == {"robot", "ball", "person"}
    assert s.randomisation.radius == 1.5 and s.randomisation.trials == 180
    sens = s.sensors
    assert sens.enabled and (sens.position_sigma, sens.size_error, sens.dropout, sens.latency, sens.rate_hz) == (
        0.05,
        0.2,
        0.05,
        0.05,
        15.0,
    )


def test_interior_walls_become_obstacles() -> None:
    s = load_scenario("cluttered_room")
    walls = [o for o in s.scene().obstacles if o.kind == "wall"]
    assert len(walls) == 5
    assert walls[4].shape.hx == pytest.approx(0.9)


@pytest.mark.parametrize(
    ("edit", "message"),
    [
        (lambda d: d["people"][0].update(speed="fast"), "people[0].speed: expected a positive number, got 'fast'"),
        (lambda d: d["people"][0].update(speed=-1), "people[0].speed: expected a positive number"),
        (lambda d: d["people"][0].update(target="fridge"), "people[0].target: 'fridge' is not an object"),
        (lambda d: d["people"][0].update(target="ball"), "people[0].target: 'ball' is not an object"),
        (lambda d: d["people"][0].update(gaze_range_deg=[10, 5]), "people[0].gaze_range_deg: expected -90 < min"),
        (lambda d: d["people"][0].update(gaze_deg=30), "people[0].gaze_deg: expected a value within"),
        (lambda d: d["people"][0].pop("radius"), "people[0].radius: is required"),
        (lambda d: d["objects"][1].update(kind="spaceship"), "objects[1].kind: expected one of"),
        (lambda d: d["objects"][0]["shape"].update(type="blob"), "objects[0].shape.type: expected one of"),
        (lambda d: d["objects"][0]["shape"].update(size=[1, -1]), "objects[0].shape.size: expected two positive"),
        (lambda d: d["objects"][2]["shape"].update(size=[1, 1]), "objects[2].shape.size: unknown key"),
        (lambda d: d["objects"][0].update(pose=[1, 2]), "objects[0].pose: expected a list of 3 numbers"),
        (lambda d: d["objects"][0].update(pose=[9, 0, 0]), "objects[0].pose: footprint leaves the room"),
        (lambda d: d["objects"][0].update(target="yes"), "objects[0].target: expected true or false, got 'yes'"),
        (lambda d: d["objects"][2].update(name="couch"), "objects[2].name: name 'couch' is already used"),
        (lambda d: d["objects"][2].update(name="wall7"), "objects[2].name: names starting with 'wall' are reserved"),
        (lambda d: d["room"].update(size=[0, 3]), "room.size: expected two positive numbers"),
        (lambda d: d["room"].update(walls=[{"start": [0, 0], "end": [0, 0]}]), "room.walls[0].end: must differ"),
        (lambda d: d["room"].update(colour="blue"), "room.colour: unknown key"),
        (lambda d: d["robot"].update(footprint=[0.5, 0]), "robot.footprint: expected two positive numbers"),
        (lambda d: d["robot"].update(max_accel=True), "robot.max_accel: expected a positive number, got True"),
        (lambda d: d["sensors"].update(dropout=1.5), "sensors.dropout: expected at most 0.99"),
        (lambda d: d["sensors"].update(position_sigma=float("nan")), "sensors.position_sigma: expected a non-negative"),
        (lambda d: d["randomisation"].update(entities=["ghost"]), "randomisation.entities[0]: unknown entity 'ghost'"),
        (lambda d: d["randomisation"].update(entities="robot"), "randomisation.entities: expected a list of names"),
        (lambda d: d["randomisation"].update(trials=2.5), "randomisation.trials: expected a whole number"),
        (lambda d: d.update(objects={}), "objects: expected a list"),
        (lambda d: d.update(people=[3]), "people[0]: expected a mapping, got 3"),
        (lambda d: d.update(extra=1), "extra: unknown key"),
    ],
)
def test_broken_scenarios_name_the_key_path(edit, message: str) -> None:
    data = copy.deepcopy(raw())
    edit(data)
    with pytest.raises(ScenarioError) as err:
        parse_scenario(data)
    assert str(err.value).startswith(message)
    assert isinstance(err.value, ValueError)


def test_root_must_be_a_mapping() -> None:
    with pytest.raises(ScenarioError, match="<root>: expected a mapping"):
        parse_scenario([1, 2])


def test_unreadable_and_invalid_files(tmp_path: Path) -> None:
    with pytest.raises(ScenarioError, match="cannot read"):
        load_scenario(tmp_path / "missing.yaml")
    bad = tmp_path / "bad.yaml"
    bad.write_text("room: [unclosed")
    with pytest.raises(ScenarioError, match="not valid YAML"):
        load_scenario(bad)


def test_sample_trial_is_seeded_and_respects_radius_and_spacing() -> None:
    s = load_scenario("paper_experiment1")
    a = sample_trial(s, np.random.default_rng(7))
    b = sample_trial(s, np.random.default_rng(7))
    assert a == b and a != s
    for seed in range(30):
        t = sample_trial(s, np.random.default_rng(seed))
        nominal = {e.name: e for e in (*s.objects, *s.people, s.robot)}
        placed = {e.name: e for e in (*t.objects, *t.people, t.robot)}
        for name in s.randomisation.entities:
            assert math.hypot(placed[name].x - nominal[name].x, placed[name].y - nominal[name].y) <= 1.5 + 1e-9
        for name in ("couch", "door"):
            assert placed[name] == nominal[name]
        for name in s.randomisation.entities:
            for other, entity in placed.items():
                if other != name:
                    assert not shapes_overlap(placed[name].footprint(), entity.footprint(), PLACEMENT_MARGIN - 1e-6)
    assert t.sensors == s.sensors


def test_sample_trial_gives_up_with_a_clear_error() -> None:
    data = raw()
    data["randomisation"]["radius"] = 0.0
    data["objects"][2]["pose"] = [-2.5, 0.0, 0.0]  # ball exactly on the person, cannot move away
    s = parse_scenario(data)
    with pytest.raises(ScenarioError, match="could not place"):
        sample_trial(s, np.random.default_rng(0))
