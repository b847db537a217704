"""The whole stack, closed loop, over real processes and real Zenoh: risky, safe and seen obstacles."""

from __future__ import annotations

import math

import pytest
from stack_helpers import SCENARIOS, run_trial, stack  # noqa: F401 - the fixture

from agents.caregiving.model.scenario import load_scenario
from bridges.world.bridge import trial_for

#: Trial 6 of seed 7: the ball is on the person's way, below their gaze, and the robot can get there in time.
RISKY = ("paper_experiment1", 7, 6)


def test_risky_walk_gets_flagged_the_robot_acts_and_nobody_collides(stack) -> None:  # noqa: F811
    scenario, seed, index = RISKY
    r = run_trial(stack, scenario, seed, index)
    assert r.risky is not None and r.risky["risky"] is True
    assert r.risky["time_to_collision"] > 0.0 and len(r.risky["path"]) >= 4
    assert r.action is not None and r.action["action"] == "move_to"
    assert r.reaction_ms is not None and r.reaction_ms > 0.0
    assert [c for c in r.outcome["commands"] if c["accepted"]], "the executor drove the robot through the world"
    assert r.outcome["collisions"] == []
    # The person saw the robot from the start (it stands in their one gaze class) and remembers it, and
    # perception knows where their walk began.
    assert r.snapshot is not None
    (person,) = r.snapshot.scene["people"]
    assert "robot" in r.snapshot.knows[person["name"]]
    robot = r.snapshot.scene["robot"]  # at rest until it decided: remembered where it stands
    assert r.snapshot.robot_at[person["name"]] == pytest.approx([robot["x"], robot["y"], robot["heading"]])
    spec = load_scenario(scenario)
    start = trial_for(spec, seed, index).people[0]
    # Decided from the first frames, the origin is a line through three or four detections, fitted back to the
    # first: within about 0.9 of a detection's sigma per axis, three sigmas in 99.6 % of draws.
    assert math.dist(person["origin"], (start.x, start.y)) < 3 * spec.sensors.position_sigma


def test_safe_walk_gives_no_risky_intention_and_no_action(stack) -> None:  # noqa: F811
    r = run_trial(stack, "safe_walk")
    assert r.intentions > 0, "the person's intentions were guessed"
    assert r.risky is None and r.action is None
    assert r.outcome["commands"] == [] and r.outcome["collisions"] == []


def test_person_who_sees_the_obstacle_is_not_flagged(stack) -> None:  # noqa: F811
    r = run_trial(stack, "person_sees_obstacle")
    assert r.intentions > 0
    assert r.risky is None and r.action is None
    assert r.outcome["collisions"] == []


def test_robot_too_far_to_help_sends_nothing_and_makes_nothing_worse(stack) -> None:  # noqa: F811
    r = run_trial(stack, "robot_too_far")
    assert r.risky is not None and r.risky["risky"] is True
    assert r.action is None and r.outcome["commands"] == []
    assert [c["obstacle"] for c in r.outcome["collisions"]] == ["ball"]


def test_someone_behind_a_wardrobe_comes_into_w_only_as_they_step_out_and_is_flagged_after(stack) -> None:  # noqa: F811
    """The sensors ride on the robot: the resident, hidden behind a tall wardrobe at first, is written into W
    from the first frame she is in the robot's line of sight, and her danger is flagged after that."""
    scenario = str(SCENARIOS / "behind_the_wardrobe.yaml")
    r = run_trial(stack, scenario)
    assert r.person_seen_at is not None and r.person_seen_at > 1.0, f"seen at {r.person_seen_at}"
    assert r.risky is not None and r.risky["at_time"] >= r.person_seen_at
    assert [c["obstacle"] for c in r.outcome["collisions"]] == ["footstool"]
