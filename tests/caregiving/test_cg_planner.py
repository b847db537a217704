"""Grid planning: optimal paths, goals at the target boundary, fast unreachability, mask cache."""

import math

import numpy as np
import pytest
import tcod.path
from hypothesis import given, settings
from hypothesis import strategies as st

from agents.caregiving.model.geometry import Box, Circle, polyline_length, signed_distance
from agents.caregiving.model.planner import GridPlanner, _AStar
from agents.caregiving.model.scenario import load_scenario
from agents.caregiving.model.scene import Obstacle

BOUNDS = (-4.0, -3.0, 4.0, 3.0)
COUCH = Obstacle("couch", "couch", Box(3.5, 0.0, 0.45, 1.0), 0.8, target=True)
BALL = Obstacle("ball", "ball", Circle(0.0, 0.0, 0.11), 0.22)


def walls() -> list[Obstacle]:
    return list(load_scenario("paper_experiment1").room.wall_obstacles())


def test_straight_walk_to_the_couch_boundary() -> None:
    planner = GridPlanner(BOUNDS)
    plan = planner.plan_to_object((-2.5, 0.0), COUCH, walls(), 0.25)
    assert plan.reachable
    assert plan.path[0].tolist() == [-2.5, 0.0]
    assert len(plan.path) == 2  # open floor: one straight segment after string pulling
    end_gap = signed_distance(COUCH.shape, plan.path[-1])[0]
    assert 0.25 + planner.margin <= end_gap <= 0.25 + planner.margin + 2 * planner.resolution
    assert plan.length == pytest.approx(polyline_length(plan.path))


def test_path_avoids_known_obstacles_with_clearance() -> None:
    planner = GridPlanner(BOUNDS)
    plan = planner.plan_to_object((-2.5, 0.0), COUCH, [*walls(), BALL], 0.25)
    assert plan.reachable and len(plan.path) >= 3
    fine = np.concatenate([np.linspace(a, b, 200) for a, b in zip(plan.path[:-1], plan.path[1:], strict=False)])
    assert signed_distance(BALL.shape, fine).min() > 0.25
    # Close to optimal: the detour around the inflated ball is short.
    assert plan.length < math.hypot(5.3, 0.0) + 0.2


def test_plan_ignores_obstacles_it_is_not_given() -> None:
    planner = GridPlanner(BOUNDS)
    assert len(planner.plan_to_object((-2.5, 0.0), COUCH, walls(), 0.25).path) == 2


def test_unreachable_target_is_reported() -> None:
    planner = GridPlanner(BOUNDS)
    fence = Obstacle("fence", "wall", Box(1.0, 0.0, 0.05, 3.0), 2.0)
    assert not planner.plan_to_object((-2.5, 0.0), COUCH, [*walls(), fence], 0.25).reachable
    assert not planner.plan_to_point((-2.5, 0.0), (3.0, 0.0), [*walls(), fence], 0.25).reachable


def test_start_inside_an_obstacle_is_unreachable_but_grazing_is_snapped() -> None:
    planner = GridPlanner(BOUNDS)
    big = Obstacle("table", "table", Box(-2.5, 0.0, 0.5, 0.5), 0.7)
    assert not planner.plan_to_object((-2.5, 0.0), COUCH, [big], 0.25).reachable
    near = Obstacle("ball", "ball", Circle(-2.5, 0.35, 0.05), 0.1)  # within radius+margin of the start
    plan = planner.plan_to_object((-2.5, 0.0), COUCH, [near], 0.25)
    assert plan.reachable and plan.path[0].tolist() == [-2.5, 0.0]


def test_plan_to_point_ends_exactly_at_the_goal() -> None:
    planner = GridPlanner(BOUNDS)
    plan = planner.plan_to_point((-2.0, -2.0), (2.0, 1.0), [*walls(), BALL], 0.2)
    assert plan.reachable
    assert plan.path[-1].tolist() == [2.0, 1.0]
    assert plan.length == pytest.approx(5.0, abs=0.1)


def test_inflated_masks_are_cached_per_obstacle_and_radius() -> None:
    planner = GridPlanner(BOUNDS, cache_size=8)
    obstacles = [*walls(), BALL]
    planner.plan_to_object((-2.5, 0.0), COUCH, obstacles, 0.25)
    misses = planner.cache_misses
    planner.plan_to_object((-2.0, 0.5), COUCH, obstacles, 0.25)
    assert planner.cache_misses == misses and planner.cache_hits >= len(obstacles)
    planner.plan_to_object((-2.5, 0.0), COUCH, obstacles, 0.3)
    assert planner.cache_misses > misses
    assert len(planner._cache) <= 8
    planner.clear_cache()
    assert not planner._cache


def test_blocked_grid_and_cells() -> None:
    planner = GridPlanner(BOUNDS)
    assert planner.shape == (160, 120)
    grid = planner.blocked([BALL], 0.25)
    assert grid[planner.cell_of(0.0, 0.0)] and not grid[planner.cell_of(1.0, 0.0)]
    assert planner.cell_of(-10, 10) == (0, 119)
    assert planner.centres(np.array([[0, 0]])).tolist() == [[-3.975, -2.975]]


def test_a_plan_does_not_depend_on_what_was_planned_before() -> None:
    used = GridPlanner(BOUNDS)
    starts = [(-2.5, 0.0), (-2.4, 0.3), (-1.0, -1.5), (-0.4, 0.05), (3.6, 1.4), (-2.4, 0.3)]
    for start in starts:  # the world and the imagination plan alike whatever each planned before
        got = used.plan_to_object(start, COUCH, [*walls(), BALL], 0.25)
        fresh = GridPlanner(BOUNDS).plan_to_object(start, COUCH, [*walls(), BALL], 0.25)
        assert got.reachable == fresh.reachable
        assert np.array_equal(got.path, fresh.path)
    boxed = [*walls(), Obstacle("pen", "box", Box(3.5, 0.0, 0.9, 1.5), 1.0)]
    for _ in range(2):
        assert not used.plan_to_object((-2.5, 0.0), COUCH, boxed, 0.25).reachable


def test_a_repeated_walk_is_remembered_read_only_and_any_other_input_plans_anew() -> None:
    planner = GridPlanner(BOUNDS)
    first = planner.plan_to_object((-2.5, 0.0), COUCH, [*walls(), BALL], 0.25)
    assert planner.plan_to_object((-2.5, 0.0), COUCH, [*walls(), BALL], 0.25) is first
    with pytest.raises(ValueError, match="read-only"):
        first.path[0, 0] = 9.0
    moved = Obstacle("ball", "ball", Circle(-1.0, 0.0, 0.11), 0.22)
    around = planner.plan_to_object((-2.5, 0.0), COUCH, [*walls(), moved], 0.25)
    assert around is not first and not np.array_equal(around.path, first.path)
    assert planner.plan_to_object((-2.5, 0.0), COUCH, [*walls(), BALL], 0.3) is not first
    planner.clear_cache()
    assert planner.plan_to_object((-2.5, 0.0), COUCH, [*walls(), BALL], 0.25) is not first


def test_a_point_goal_in_line_of_sight_gets_the_path_the_search_would_return() -> None:
    planner = GridPlanner(BOUNDS)
    obstacles = [*walls(), BALL, COUCH]
    rng = np.random.default_rng(3)
    straight = searched = 0
    for _ in range(60):
        start, goal = (tuple(rng.uniform((-3.5, -2.5), (3.5, 2.5))) for _ in range(2))
        plan = planner.plan_to_point(start, goal, obstacles, 0.2)
        searcher = GridPlanner(BOUNDS)
        reference = searcher._search(start, searcher.blocked(obstacles, 0.2), np.array([searcher.cell_of(*goal)]))
        assert plan.reachable == reference.reachable
        if not plan.reachable:
            continue
        assert plan.path[0].tolist() == list(start) and plan.path[-1].tolist() == list(goal)
        if len(reference.path) == 2:
            straight += 1
            assert len(plan.path) == 2
        else:
            searched += 1
            assert plan.length == pytest.approx(polyline_length(np.vstack((reference.path[:-1], [goal]))))
    assert straight and searched  # both branches were exercised


@settings(max_examples=150, deadline=None)
@given(st.integers(0, 2**32 - 1), st.integers(1, 40))
def test_the_reused_search_returns_path2d_s_path_among_equally_short_ones(seed: int, goal_count: int) -> None:
    rng = np.random.default_rng(seed)
    grid = np.zeros((48, 36), dtype=bool)
    for _ in range(int(rng.integers(1, 8))):
        i, j, r = rng.integers(0, 48), rng.integers(0, 36), rng.integers(1, 9)
        grid[max(i - r, 0) : i + r, max(j - r, 0) : j + r] = True
    free = np.argwhere(~grid)
    start = tuple(int(v) for v in free[rng.integers(len(free))])
    goals = free[np.sort(rng.choice(len(free), size=min(goal_count, len(free)), replace=False))]  # row-major
    search = _AStar(grid.shape)
    search.path(~grid, goals[:1], start)  # whatever it searched before must not matter
    got = search.path(grid, goals, start)
    reference = tcod.path.path2d(
        (~grid).astype(np.int8),
        start_points=[tuple(g) for g in goals.tolist()],
        end_points=[start],
        cardinal=70,
        diagonal=99,
    )
    if len(reference) == 0:
        assert got is None
    else:
        assert got is not None and np.array_equal(got, reference[::-1][1:])


def test_a_walk_begun_elsewhere_follows_the_rest_of_the_route_planned_at_its_origin() -> None:
    planner = GridPlanner(BOUNDS)
    shelf = Obstacle("shelf", "cabinet", Box(0.0, 0.6, 0.3, 0.9), 1.8)
    origin = (-3.0, 2.0)
    route = planner.plan_to_object(origin, COUCH, [*walls(), shelf], 0.25)
    assert len(route.path) >= 3  # the route turns round the shelf
    a, b = route.path[0], route.path[1]
    midway = (float(a[0] + 0.4 * (b[0] - a[0])), float(a[1] + 0.4 * (b[1] - a[1]) + 0.03))
    walk = planner.plan_walk(midway, origin, COUCH, [*walls(), shelf], 0.25)
    assert walk.path[0].tolist() == list(midway)
    assert walk.path[1:].tolist() == route.path[1:].tolist()
    assert walk.length == pytest.approx(polyline_length(walk.path))
    # Unknown origin, or a walker who has left its route: planned from where they stand.
    for start, known_origin in ((midway, None), ((midway[0], midway[1] - 0.3), origin)):
        fresh = planner.plan_to_object(start, COUCH, [*walls(), shelf], 0.25)
        assert (
            planner.plan_walk(start, known_origin, COUCH, [*walls(), shelf], 0.25).path.tolist() == fresh.path.tolist()
        )
    # At the origin itself the walk is the route.
    assert planner.plan_walk(origin, origin, COUCH, [*walls(), shelf], 0.25).path.tolist() == route.path.tolist()
