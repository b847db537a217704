"""Planar shapes and distance queries."""

import math
from dataclasses import replace

import numpy as np
import pytest
from hypothesis import given, settings
from hypothesis import strategies as st

from agents.caregiving.model.geometry import (
    Box,
    Circle,
    Polyline,
    aabb,
    as_points,
    bounding_radius,
    closest_boundary_point,
    corners,
    displacement,
    grid_distance,
    moved_more_than,
    point_distance,
    polyline_distance,
    polyline_length,
    resample_by_distance,
    shapes_overlap,
    signed_distance,
    swept_clearance,
)


def test_circle_signed_distance_inside_and_outside() -> None:
    c = Circle(1.0, 2.0, 0.5)
    d = signed_distance(c, [[1.0, 2.0], [2.0, 2.0], [1.0, 2.25]])
    assert d == pytest.approx([-0.5, 0.5, -0.25])


def test_rotated_box_signed_distance() -> None:
    b = Box(0.0, 0.0, 1.0, 0.5, math.pi / 2)  # long axis along y after rotation
    assert signed_distance(b, (0.0, 1.5))[0] == pytest.approx(0.5)
    assert signed_distance(b, (1.0, 0.0))[0] == pytest.approx(0.5)
    assert signed_distance(b, (0.0, 0.0))[0] == pytest.approx(-0.5)
    assert signed_distance(b, (1.5, 2.0))[0] == pytest.approx(math.hypot(1.0, 1.0))


@settings(max_examples=60, deadline=None)
@given(st.floats(-3, 3), st.floats(-3, 3), st.floats(0, math.pi))
def test_closest_boundary_point_lies_on_boundary_at_distance(px: float, py: float, theta: float) -> None:
    for shape in (Box(0.2, -0.1, 0.7, 0.3, theta), Circle(0.2, -0.1, 0.6)):
        q = closest_boundary_point(shape, (px, py))
        assert abs(signed_distance(shape, q)[0]) < 1e-9
        d = signed_distance(shape, (px, py))[0]
        assert np.hypot(*(q[0] - (px, py))) == pytest.approx(abs(d), abs=1e-9)


@settings(max_examples=60, deadline=None)
@given(st.floats(-3, 3), st.floats(-3, 3), st.floats(0, math.pi))
def test_point_distance_matches_signed_distance(px: float, py: float, theta: float) -> None:
    for shape in (Box(0.2, -0.1, 0.7, 0.3, theta), Circle(0.2, -0.1, 0.6)):
        assert point_distance(shape, px, py) == pytest.approx(signed_distance(shape, (px, py))[0], abs=1e-12)


def test_closest_point_of_circle_centre_is_defined() -> None:
    q = closest_boundary_point(Circle(0, 0, 1), (0, 0))
    assert np.hypot(*q[0]) == pytest.approx(1.0)


def test_corners_aabb_and_radius() -> None:
    b = Box(1.0, 1.0, 1.0, 0.5, 0.0)
    assert corners(b).tolist() == [[2.0, 1.5], [0.0, 1.5], [0.0, 0.5], [2.0, 0.5]]
    assert aabb(b) == pytest.approx((0.0, 0.5, 2.0, 1.5))
    assert aabb(Circle(0, 0, 2)) == (-2, -2, 2, 2)
    assert bounding_radius(b) == pytest.approx(math.hypot(1.0, 0.5))
    assert bounding_radius(Circle(0, 0, 2)) == 2


def test_shapes_overlap_all_pairs() -> None:
    assert shapes_overlap(Circle(0, 0, 1), Circle(1.5, 0, 1))
    assert not shapes_overlap(Circle(0, 0, 1), Circle(2.5, 0, 1))
    assert shapes_overlap(Circle(0, 0, 1), Circle(2.5, 0, 1), margin=0.6)
    assert shapes_overlap(Box(0, 0, 1, 1), Circle(1.5, 0, 0.6))
    assert shapes_overlap(Circle(1.5, 0, 0.6), Box(0, 0, 1, 1))
    assert not shapes_overlap(Box(0, 0, 1, 1), Box(3, 0, 1, 1))
    assert shapes_overlap(Box(0, 0, 1, 1), Box(3, 0, 1, 1), margin=1.1)
    # A thin cross: no vertex inside the other, but the edges cross.
    assert shapes_overlap(Box(0, 0, 2, 0.1), Box(0, 0, 0.1, 2))


def test_polyline_length_and_resample() -> None:
    path = [[0, 0], [3, 0], [3, 4]]
    assert polyline_length(path) == 7
    assert polyline_length([[1, 1]]) == 0.0
    pts = resample_by_distance(path, [0, 1.5, 5, 100])
    assert pts.tolist() == [[0, 0], [1.5, 0], [3, 2], [3, 4]]
    assert resample_by_distance([[2, 2]], [0, 1]).tolist() == [[2, 2], [2, 2]]
    assert as_points((1, 2)).shape == (1, 2)


def test_swept_clearance_finds_closest_approach() -> None:
    clear, where = swept_clearance(Circle(2, 0.5, 0.2), [[0, 0], [4, 0]], 0.25, 0.01)
    assert clear == pytest.approx(0.05, abs=1e-6)
    assert where == pytest.approx([2, 0], abs=0.01)


def test_a_box_turning_in_place_is_displaced_by_its_corners() -> None:
    box = Box(1.0, 2.0, 0.25, 0.2, 0.0)
    assert displacement(box, replace(box, theta=math.pi / 2)) == pytest.approx(math.hypot(0.45, 0.05))
    assert displacement(box, replace(box, x=1.1)) == pytest.approx(0.1)
    assert displacement(Circle(0.0, 0.0, 0.3), Circle(0.3, 0.4, 0.3)) == pytest.approx(0.5)


_coord = st.floats(-3, 3)


@settings(max_examples=200, deadline=None)
@given(_coord, _coord, st.floats(0, math.pi), _coord, _coord, st.floats(0, math.pi), st.floats(0, 1))
def test_moved_more_than_agrees_with_displacement(
    x0: float, y0: float, t0: float, x1: float, y1: float, t1: float, d: float
) -> None:
    before, after = Box(x0, y0, 0.3, 0.2, t0), Box(x0 + x1 / 10, y0 + y1 / 10, 0.3, 0.2, t1)
    moved = displacement(before, after)
    if abs(moved - d) > 1e-12:  # the corners' rounding may differ from the centre's at the boundary itself
        assert moved_more_than(before, after, d) == (moved > d)
    assert moved_more_than(Circle(x0, y0, 0.2), Circle(x1, y1, 0.2), d) == (math.hypot(x1 - x0, y1 - y0) > d)


@settings(max_examples=100, deadline=None)
@given(st.lists(st.tuples(_coord, _coord), min_size=1, max_size=5), _coord, _coord)
def test_polyline_distance_is_the_nearest_point_of_the_path(
    points: list[tuple[float, float]], x: float, y: float
) -> None:
    line = Polyline.of(points)
    dense = line.resampled(np.linspace(0.0, line.length, 4001))
    nearest = float(np.hypot(*(dense - (x, y)).T).min())
    got = polyline_distance(line.points, x, y)
    assert got <= nearest + 1e-9  # a lower bound on every sampled point, as the replan test needs
    assert got == pytest.approx(nearest, abs=line.length / 4000 + 1e-9)


@pytest.mark.parametrize("shape", [Box(0.13, -0.4, 0.5, 0.21, 0.7), Circle(-0.2, 0.35, 0.42)])
def test_grid_distance_is_signed_distance_bit_for_bit(shape: Box | Circle) -> None:
    xs, ys = np.linspace(-1.0, 1.0, 41), np.linspace(-0.8, 1.2, 37)
    points = np.stack(np.meshgrid(xs, ys, indexing="ij"), axis=-1).reshape(-1, 2)
    assert np.array_equal(grid_distance(shape, xs, ys), signed_distance(shape, points).reshape(41, 37))


@settings(max_examples=100, deadline=None)
@given(st.lists(st.tuples(_coord, _coord), min_size=1, max_size=5), st.floats(-1, 12))
def test_point_at_is_resampled_bit_for_bit_on_each_segment(points: list[tuple[float, float]], distance: float) -> None:
    line = Polyline.of(points)
    cum, pts = line.cumulative, line.points
    if len(pts) == 1 or distance <= 0.0 or distance >= cum[-1]:
        end = pts[0] if len(pts) == 1 or distance <= 0.0 else pts[-1]
        assert line.point_at(distance) == (end[0], end[1])
        return
    k = int(np.searchsorted(cum, distance, side="right")) - 1
    t = (distance - cum[k]) / (cum[k + 1] - cum[k])
    assert line.point_at(distance) == (
        pts[k, 0] + t * (pts[k + 1, 0] - pts[k, 0]),
        pts[k, 1] + t * (pts[k + 1, 1] - pts[k, 1]),
    )
