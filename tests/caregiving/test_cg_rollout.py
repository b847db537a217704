"""Rollouts: PyBullet and numpy agree step for step; contacts, clearances and frozen contexts."""

import math

import numpy as np
import pytest

from agents.caregiving.model.geometry import Box, Circle
from agents.caregiving.model.rollout import DT, BulletRollout, NumpyRollout, trajectory
from agents.caregiving.model.scene import Obstacle

BALL = Obstacle("ball", "ball", Circle(0.0, 0.0, 0.11), 0.22)
COUCH = Obstacle("couch", "couch", Box(3.5, 0.0, 0.45, 1.0, 0.2), 0.8)
WALL = Obstacle("wall0", "wall", Box(0.0, 3.05, 4.1, 0.05), 2.5)


@pytest.fixture(scope="module")
def bullet() -> BulletRollout:
    return BulletRollout.shared()


def test_trajectory_steps_at_constant_speed() -> None:
    times, pts = trajectory([[0, 0], [1, 0]], 0.5)
    assert len(times) == 41 and times[-1] == pytest.approx(2.0)
    assert np.diff(times) == pytest.approx(np.full(40, DT))
    assert pts[-1].tolist() == [1.0, 0.0]
    times, pts = trajectory([[0, 0], [0.06, 0]], 0.5)
    assert times.tolist() == pytest.approx([0.0, 0.05, 0.1, 0.12])
    assert trajectory([[1, 1]], 0.5)[0].tolist() == [0.0]


def test_shared_client_is_one_per_process(bullet: BulletRollout) -> None:
    assert BulletRollout.shared() is bullet


@pytest.mark.parametrize("rollout_cls", [NumpyRollout, BulletRollout.shared])
def test_head_on_contact_with_the_ball(rollout_cls) -> None:
    r = rollout_cls().walk([[-2.0, 0.0], [2.0, 0.0]], 0.25, 0.5, [BALL, WALL])
    assert r.collided and r.contact.obstacle == "ball"
    # Touches when the centre is 0.36 m before the ball centre: 1.64 m walked.
    assert r.contact.time == pytest.approx(math.ceil(1.64 / 0.025) * DT)
    assert r.contact.point == pytest.approx((-0.11, 0.0), abs=0.03)
    assert r.min_clearance <= 0.0 and r.closest == "ball"
    assert r.duration == r.contact.time and r.steps == int(round(r.duration / DT)) + 1


@pytest.mark.parametrize("rollout_cls", [NumpyRollout, BulletRollout.shared])
def test_setting_off_away_from_what_one_stands_against_is_no_contact_until_one_comes_back(rollout_cls) -> None:
    rollout = rollout_cls()
    # Standing against the couch (the target just reached), walking off the other way: no fall over it.
    away = rollout.walk([[2.82, 0.0], [0.8, 0.0]], 0.25, 0.7, [COUCH, BALL])
    assert not away.collided and away.min_clearance > 0.0
    # Walking on into it, or away and back to it, is a contact.
    into = rollout.walk([[2.82, 0.0], [3.2, 0.0]], 0.25, 0.7, [COUCH])
    assert into.collided and into.contact.time == 0.0
    back = rollout.walk([[2.82, 0.0], [2.4, 0.0], [2.4, 0.8], [3.3, 0.8]], 0.25, 0.7, [COUCH])
    assert back.collided and back.contact.time > 1.0


@pytest.mark.parametrize("rollout_cls", [NumpyRollout, BulletRollout.shared])
def test_miss_reports_closest_approach(rollout_cls) -> None:
    r = rollout_cls().walk([[-2.0, 0.5], [2.0, 0.5]], 0.25, 0.5, [BALL])
    assert not r.collided and r.contact is None
    assert r.min_clearance == pytest.approx(0.5 - 0.36, abs=1e-5)
    assert r.duration == pytest.approx(8.0)
    empty = rollout_cls().walk([[-2.0, 0.5], [2.0, 0.5]], 0.25, 0.5, [])
    assert not empty.collided and empty.min_clearance == math.inf


def random_case(rng: np.random.Generator) -> tuple[np.ndarray, float, list[Obstacle]]:
    obstacles = []
    for i in range(int(rng.integers(1, 6))):
        x, y = rng.uniform(-3, 3, 2)
        if rng.uniform() < 0.5:
            obstacles.append(Obstacle(f"o{i}", "ball", Circle(x, y, rng.uniform(0.05, 0.5)), rng.uniform(0.1, 2)))
        else:
            obstacles.append(
                Obstacle(f"o{i}", "box", Box(x, y, *rng.uniform(0.05, 0.8, 2), rng.uniform(-3, 3)), rng.uniform(0.1, 2))
            )
    path = rng.uniform(-3.5, 3.5, (int(rng.integers(2, 5)), 2))
    return path, float(rng.uniform(0.1, 0.4)), obstacles


def test_cross_check_clearance_matrices_step_for_step(bullet: BulletRollout) -> None:
    rng = np.random.default_rng(42)
    numpy_rollout = NumpyRollout()
    for _ in range(25):
        path, radius, obstacles = random_case(rng)
        _, pts = trajectory(path, 0.5)
        a = numpy_rollout.clearances(pts, radius, obstacles)
        b = bullet.clearances(pts, radius, obstacles)
        assert a.shape == b.shape
        apart = a > 0.0
        assert np.abs(a[apart] - b[apart]).max() < 1e-5  # 10 micrometres
        assert (b[~apart] <= 1e-5).all()  # touching or penetrating (3D depth may differ)


def test_cross_check_walk_results(bullet: BulletRollout) -> None:
    rng = np.random.default_rng(7)
    numpy_rollout = NumpyRollout()
    collided = 0
    fixed = [
        ([[-2.0, 0.0], [2.0, 0.0]], 0.25, [BALL, COUCH, WALL]),
        ([[0.0, -2.0], [3.0, -0.5], [3.0, 2.8]], 0.3, [COUCH, WALL]),
    ]
    cases = fixed + [random_case(rng) for _ in range(40)]
    for path, radius, obstacles in cases:
        a = numpy_rollout.walk(path, radius, 0.5, obstacles)
        b = bullet.walk(path, radius, 0.5, obstacles)
        assert a.collided == b.collided
        assert a.steps == b.steps and a.duration == pytest.approx(b.duration)
        assert a.min_clearance == pytest.approx(b.min_clearance, abs=1e-5) or a.collided
        if a.collided:
            collided += 1
            assert a.contact.obstacle == b.contact.obstacle
            assert a.contact.point == pytest.approx(b.contact.point, abs=1e-4)
        else:
            assert a.closest == b.closest
    assert 5 <= collided < len(cases)


def test_frozen_context_is_restored(bullet: BulletRollout) -> None:
    context = [BALL, COUCH]
    with bullet.frozen(context):
        moved_ball = Obstacle("ball", "ball", Circle(0.0, 1.0, 0.11), 0.22)
        assert not bullet.walk([[-2.0, 0.0], [2.0, 0.0]], 0.25, 0.5, [moved_ball, COUCH]).collided
    # After the context is thawed, the ball is back where the context had it.
    ball_body = bullet._placed["ball"][1]
    import pybullet as pb

    pos, _ = pb.getBasePositionAndOrientation(ball_body, physicsClientId=bullet._client)
    assert pos[0] == pytest.approx(0.0) and pos[1] == pytest.approx(0.0)
    assert bullet.walk([[-2.0, 0.0], [2.0, 0.0]], 0.25, 0.5, context).collided


def test_bodies_are_reused_not_recreated(bullet: BulletRollout) -> None:
    bullet.walk([[-2.0, 0.0], [2.0, 0.0]], 0.25, 0.5, [BALL, COUCH])
    import pybullet as pb

    count = pb.getNumBodies(physicsClientId=bullet._client)
    for dx in np.linspace(-1, 1, 10):
        moved = Obstacle("ball", "ball", Circle(float(dx), 0.3, 0.11), 0.22)
        bullet.walk([[-2.0, 0.0], [2.0, 0.0]], 0.25, 0.5, [moved, COUCH])
    assert pb.getNumBodies(physicsClientId=bullet._client) == count
