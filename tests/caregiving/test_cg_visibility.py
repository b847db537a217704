"""What a person sees: horizontal cone, vertical gaze window, exact gaze classes."""

import math
from dataclasses import replace

import pytest
from hypothesis import assume, given, settings
from hypothesis import strategies as st

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
    sight,
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


_ANGLE = st.floats(-math.pi, math.pi)
_OFFSET = st.floats(-6.0, 6.0)


@st.composite
def _hidden_objects(draw: st.DrawFn) -> tuple[Obstacle, float]:
    """An object (a disc or a turned box, low or tall) somewhere about the person, and a gaze pitch."""
    x, y = draw(_OFFSET), draw(_OFFSET)
    if draw(st.booleans()):
        shape: Circle | Box = Circle(x, y, draw(st.floats(0.05, 0.6)))
    else:
        shape = Box(x, y, draw(st.floats(0.05, 1.0)), draw(st.floats(0.05, 1.0)), draw(_ANGLE))
    height = draw(st.sampled_from([0.09, 0.3, 1.0, 1.8, 2.4]))
    return Obstacle("thing", "thing", shape, height), math.radians(draw(st.floats(-25.0, 15.0)))


@settings(max_examples=300, deadline=None)
@given(_hidden_objects(), st.floats(0.0, 1.0), _ANGLE, st.floats(0.0, 1.0))
def test_an_object_stays_hidden_within_the_bound_sight_gives(
    drawn: tuple[Obstacle, float], share: float, direction: float, turn_share: float
) -> None:
    """Moved less than the bound's distance, in any direction, and turned less than its turn, the person
    still does not see the object."""
    obstacle, gaze = drawn
    hidden = sight(PERSON, obstacle, gaze)
    assume(hidden is not None and hidden.distance > 0.0)
    assert hidden is not None
    step = min(hidden.distance, 20.0) * share * 0.999
    turn = min(hidden.turn, math.pi) * turn_share * 0.999 * (1 if direction > 0 else -1)
    moved = PERSON.moved(PERSON.x + step * math.cos(direction), PERSON.y + step * math.sin(direction), turn)
    assert not can_see(moved, obstacle, gaze)


def test_sight_says_why_an_object_is_hidden() -> None:
    """The ball close by is below the window until the person backs off; the plant behind only needs a turn
    to show, so its bound holds for a turn short of the gap."""
    gaze = math.radians(8)
    assert sight(PERSON, TALL, gaze) is None
    below = sight(PERSON, BALL, gaze)
    assert below is not None and below.turn == math.inf and below.distance > 1.0
    behind = sight(PERSON, replace(TALL, shape=Circle(-2.5, 0.0, 0.25)), gaze)
    assert behind is not None and 0.0 < behind.turn < math.pi / 2 and behind.distance > 0.0
    overhead = sight(PERSON, BALL, math.radians(60))  # a low ball, with the window above the horizon
    assert overhead is not None and overhead.distance == math.inf
