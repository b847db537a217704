"""The intention agent's cache redoes an imagination only when its inputs move beyond tolerance."""

from __future__ import annotations

from dataclasses import replace

from agents.imagination_cache import ImaginationCache, footing
from caregiving.geometry import Circle
from caregiving.scene import Obstacle, PersonState, Scene

PERSON = PersonState("p", -2.0, 0.0, 0.0, 0.5, 0.25, 1.6, 2.0, 0.7, 0.1, 0.2)
COUCH = Obstacle("couch", "couch", Circle(3.0, 0.0, 0.5), 0.8, target=True)
BALL = Obstacle("ball", "ball", Circle(0.0, 0.05, 0.11), 0.22)
FAR = Obstacle("plant", "plant", Circle(0.0, 2.5, 0.2), 1.0)
SCENE = Scene((-4.0, -3.0, 4.0, 3.0), (COUCH, BALL, FAR), (PERSON,), None, time=1.0)
KEY = ("p", "couch", frozenset({"couch"}))
ANSWER = {"ok": True, "result": {"path": [[-2.0, 0.0], [2.25, 0.0]]}, "risk": {}}


def cached(scene: Scene) -> ImaginationCache:
    cache = ImaginationCache(move_tol=0.1, reach=0.6, max_age=1.0)
    cache.store(KEY, footing(SCENE, "p", {}), ANSWER)
    cache.lookup(KEY, footing(scene, "p", {}))
    return cache


def hit(scene: Scene, sigma: dict[str, float] | None = None) -> bool:
    cache = ImaginationCache(move_tol=0.1, reach=0.6, max_age=1.0)
    cache.store(KEY, footing(SCENE, "p", {}), ANSWER)
    return cache.lookup(KEY, footing(scene, "p", sigma or {})) is not None


def moved(obstacle: Obstacle, dx: float, dy: float) -> Obstacle:
    s = obstacle.shape
    assert isinstance(s, Circle)
    return replace(obstacle, shape=Circle(s.x + dx, s.y + dy, s.r))


def with_obstacles(*obstacles: Obstacle, time: float = 1.2) -> Scene:
    return replace(SCENE, obstacles=obstacles, time=time)


def test_small_moves_reuse_and_report_the_age() -> None:
    cache = ImaginationCache(move_tol=0.1)
    cache.store(KEY, footing(SCENE, "p", {}), ANSWER)
    scene = replace(SCENE, people=(replace(PERSON, x=-1.95, heading=0.3),), time=1.3)
    got = cache.lookup(KEY, footing(scene, "p", {}))
    assert got is not None and abs(got["age"] - 0.3) < 1e-9
    assert cache.hits == 1 and cache.misses == 0


def test_person_moving_or_changing_sigma_or_ageing_redoes_it() -> None:
    assert not hit(replace(SCENE, people=(replace(PERSON, x=-1.85),)))
    assert not hit(SCENE, {"p": 0.05})
    assert not hit(replace(SCENE, time=2.5))


def test_only_bodies_near_the_path_or_the_target_matter() -> None:
    assert hit(with_obstacles(COUCH, BALL, moved(FAR, 0.5, 0.0)))  # far from the walk: ignored
    assert not hit(with_obstacles(COUCH, moved(BALL, 0.0, 0.2), FAR))  # on the way: moved
    assert not hit(with_obstacles(COUCH, FAR))  # on the way: vanished
    assert not hit(with_obstacles(COUCH, BALL, moved(FAR, 0.0, -2.3)))  # came onto the way
    assert not hit(with_obstacles(moved(COUCH, 0.0, 1.0), BALL, FAR))  # the target moved
    assert not hit(with_obstacles(COUCH, replace(BALL, shape=Circle(0.0, 0.05, 0.2)), FAR))  # resized


def test_sweep_forgets_what_was_not_looked_up() -> None:
    cache = cached(SCENE)
    cache.sweep()
    cache.sweep()
    assert cache.lookup(KEY, footing(SCENE, "p", {})) is None
