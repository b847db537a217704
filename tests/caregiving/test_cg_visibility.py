"""What a person sees: horizontal cone, vertical gaze window, exact gaze classes."""

import math
from dataclasses import replace

import pytest

from agents.caregiving.model.geometry import Box, Circle
from agents.caregiving.model.scenario import load_scenario
from agents.caregiving.model.scene import Obstacle, PersonState
from agents.caregiving.model.visibility import (
    can_see,
    candidate_targets,
    elevation_span,
    gaze_classes,
    gaze_interval,
    in_horizontal_fov,
    visible,
)

PERSON = PersonState(
    "p", 0.0, 0.0, 0.0, 0.5, 0.25, 1.6, math.radians(120), math.radians(40), math.radians(6), math.radians(10)
)
BALL = Obstacle("ball", "ball", Circle(2.5, 0.0, 0.11), 0.22)
TALL = Obstacle("plant", "plant", Circle(2.5, 0.0, 0.25), 1.7)


def test_horizontal_cone() -> None:
    assert in_horizontal_fov(PERSON, TALL)
    behind = replace(TALL, shape=Circle(-2.5, 0.0, 0.25))
    assert not in_horizontal_fov(PERSON, behind)
    edge = replace(TALL, shape=Circle(2.0, 3.6, 0.25))  # centre at 61 deg, disc pokes into the 60 deg cone
    assert in_horizontal_fov(PERSON, edge)
    wide = Obstacle("couch", "couch", Box(0.5, -3.0, 2.0, 0.4), 0.8)  # centre outside the cone, corner inside
    assert in_horizontal_fov(PERSON, wide)
    touching = replace(TALL, shape=Circle(-0.2, 0.0, 0.25))  # the eyes are inside it
    assert in_horizontal_fov(PERSON, touching)


def test_low_ball_is_below_the_gaze_window_but_a_tall_plant_is_not() -> None:
    for gaze in (math.radians(6), math.radians(8), math.radians(10)):
        assert not can_see(PERSON, BALL, gaze)
        assert can_see(PERSON, TALL, gaze)
    assert can_see(PERSON, BALL, math.radians(-20))  # looking down, the ball shows up


def test_elevation_span_and_interval() -> None:
    low, high = elevation_span(PERSON, BALL)
    assert low == pytest.approx(math.atan2(-1.6, 2.39))
    assert high == pytest.approx(math.atan2(0.22 - 1.6, 2.61))
    lo, hi = gaze_interval(PERSON, BALL)
    assert (lo, hi) == pytest.approx((low - PERSON.vfov / 2, high + PERSON.vfov / 2))
    assert gaze_interval(PERSON, replace(BALL, shape=Circle(-3, 0, 0.1))) is None


def test_walls_are_always_known_and_visible_filters() -> None:
    wall = Obstacle("wall0", "wall", Box(-5.0, 0.0, 0.05, 3.0), 2.5)
    seen = visible(PERSON, [wall, BALL, TALL], math.radians(8))
    assert [o.name for o in seen] == ["wall0", "plant"]


def test_candidate_targets_are_targets_in_the_cone() -> None:
    couch = Obstacle("couch", "couch", Box(3.0, 0.0, 0.4, 1.0), 0.8, target=True)
    door = Obstacle("door", "door", Box(-3.0, 0.0, 0.05, 0.5), 2.0, target=True)
    assert candidate_targets(PERSON, [couch, door, TALL]) == (couch,)


def test_gaze_classes_partition_the_gaze_range_exactly() -> None:
    person = replace(PERSON, gaze_min=math.radians(-40), gaze_max=math.radians(10))
    classes = gaze_classes(person, [BALL, TALL])
    assert classes[0].low == person.gaze_min and classes[-1].high == person.gaze_max
    for a, b in zip(classes, classes[1:], strict=False):
        assert a.high == b.low and a.visible != b.visible
    ball_lo, ball_hi = gaze_interval(person, BALL)
    for c in classes:
        assert ("ball" in c.visible) == (ball_lo <= c.gaze <= ball_hi)
        assert {o.name for o in visible(person, [BALL, TALL], c.gaze)} == c.visible
    point = replace(PERSON, gaze_min=0.1, gaze_max=0.1)
    (only,) = gaze_classes(point, [BALL, TALL])
    assert only.visible == {"plant"} and only.gaze == 0.1


def test_paper_scenario_person_does_not_see_the_ball_at_any_gaze() -> None:
    scene = load_scenario("paper_experiment1").scene()
    person = scene.people[0]
    for c in gaze_classes(person, scene.bodies_around(person.name)):
        assert "ball" not in c.visible and "robot" in c.visible
