"""Robot moves: stand-off poses, trapezoidal travel time (whole and part way), arrival filter."""

import math

import pytest
from hypothesis import given
from hypothesis import strategies as st

from agents.caregiving.model.errors import RequestError
from agents.caregiving.model.geometry import Box, shapes_overlap, signed_distance
from agents.caregiving.model.robot_moves import RobotMove, standoff_moves, time_to_cover, travel_time
from agents.caregiving.model.scenario import load_scenario


def test_travel_time_trapezoid_and_triangle() -> None:
    assert travel_time(0.0, 1.0, 1.0) == 0.0
    # Triangle: 1 m at a = 1 m/s^2 peaks at 1 m/s (capped at vmax = 2): t = 2 s.
    assert travel_time(1.0, 2.0, 1.0) == pytest.approx(2.0)
    # Trapezoid: 0.5 m up, 0.5 m down, 2 m cruise at 1 m/s: 1 + 2 + 1 s.
    assert travel_time(3.0, 1.0, 1.0) == pytest.approx(4.0)
    # Already moving at full speed: no acceleration phase, 2.5 m cruise then 1 s braking.
    assert travel_time(3.0, 1.0, 1.0, v0=1.0) == pytest.approx(3.5)


@given(st.floats(0.01, 20), st.floats(0.1, 3), st.floats(0.1, 3))
def test_travel_time_is_bounded_by_limits(d: float, vmax: float, amax: float) -> None:
    t = travel_time(d, vmax, amax)
    assert t >= d / vmax - 1e-9
    assert t >= 2 * math.sqrt(d / amax) - 1e-9
    assert travel_time(d * 1.5, vmax, amax) > t


def test_time_to_cover_reads_the_trip_part_way() -> None:
    # A 1 m trip at a = 1 m/s^2 peaks at 1 m/s half way, at 1 s.
    assert time_to_cover(1.0, 0.25, 2.0, 1.0) == pytest.approx(math.sqrt(0.5))
    assert time_to_cover(1.0, 0.5, 2.0, 1.0) == pytest.approx(1.0)
    # Braking: 0.25 m from the end the speed is sqrt(2 * 0.25) m/s.
    assert time_to_cover(1.0, 0.75, 2.0, 1.0) == pytest.approx(1.0 + 1.0 - math.sqrt(0.5))
    # Cruising at 1 m/s on a 3 m trapezoid: 1 s up to 0.5 m, then 1 s per metre.
    assert time_to_cover(3.0, 2.0, 1.0, 1.0) == pytest.approx(2.5)
    assert time_to_cover(3.0, 0.0, 1.0, 1.0) == 0.0


@given(st.floats(0.01, 20), st.floats(0.0, 1.0), st.floats(0.0, 1.0), st.floats(0.1, 3), st.floats(0.1, 3))
def test_time_to_cover_ends_at_travel_time_and_beats_stopping_short(
    trip: float, part: float, other: float, vmax: float, amax: float
) -> None:
    assert time_to_cover(trip, trip, vmax, amax) == pytest.approx(travel_time(trip, vmax, amax), abs=1e-6)
    covered = trip * part
    t = time_to_cover(trip, covered, vmax, amax)
    # Passing a point on the way is never slower than having to stop there.
    assert t <= travel_time(covered, vmax, amax) + 1e-9
    assert (
        time_to_cover(trip, trip * min(part, other), vmax, amax)
        <= time_to_cover(trip, trip * max(part, other), vmax, amax) + 1e-9
    )


def test_standoff_moves_surround_the_object_and_fit() -> None:
    scene = load_scenario("paper_experiment1").scene()
    moves = standoff_moves(scene, "ball", gap=0.1, count=8)
    assert len(moves) == 8
    robot = scene.robot
    for m in moves:
        footprint = Box(m.x, m.y, robot.length / 2, robot.width / 2, m.heading)
        assert signed_distance(scene.obstacle("ball").shape, (m.x, m.y))[0] == pytest.approx(0.1 + 0.25, abs=1e-3)
        assert not shapes_overlap(footprint, scene.obstacle("ball").shape)
        # Facing the ball.
        assert math.atan2(-m.y, -m.x) == pytest.approx(m.heading)
    couch = standoff_moves(scene, "couch")
    assert 0 < len(couch) < 8  # the wall side is excluded
    assert all(m.x < 3.05 or abs(m.y) > 1.0 for m in couch)  # beside or in front, never behind


def test_moves_need_a_robot_and_a_known_object() -> None:
    scene = load_scenario("paper_experiment1").scene()
    with pytest.raises(RequestError, match="no robot"):
        standoff_moves(scene.with_robot(None), "ball")
    with pytest.raises(RequestError, match="unknown object 'sofa'"):
        standoff_moves(scene, "sofa")
    with pytest.raises(RequestError, match="move.x: expected a number"):
        RobotMove.from_wire({"target": "ball", "x": None, "y": 0})
