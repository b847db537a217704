"""The intention agent's cache redoes an imagination only when its inputs move beyond tolerance."""

from __future__ import annotations

import math
from dataclasses import replace

from agents.caregiving.imagination_cache import ImaginationCache, footing
from agents.caregiving.model.geometry import Circle
from agents.caregiving.model.imagine import Imagination
from agents.caregiving.model.imagine_reply import Answer
from agents.caregiving.model.scene import Obstacle, PersonState, Scene
from agents.caregiving.model.uncertainty import Risk

PERSON = PersonState("p", -2.0, 0.0, 0.0, 0.5, 0.25, 1.6, 2.0, 0.7, 0.1, 0.2)
COUCH = Obstacle("couch", "couch", Circle(3.0, 0.0, 0.5), 0.8, target=True)
BALL = Obstacle("ball", "ball", Circle(0.0, 0.05, 0.11), 0.22)
FAR = Obstacle("plant", "plant", Circle(0.0, 2.5, 0.2), 1.0)
SCENE = Scene((-4.0, -3.0, 4.0, 3.0), (COUCH, BALL, FAR), (PERSON,), None, time=1.0)
KEY = ("p", "couch", frozenset({"couch"}), None)
WALK = Imagination(
    "p", "couch", 0.1, ("couch",), True, ((-2.0, 0.0), (2.25, 0.0)), False, None, None, None, math.inf, 8.5
)
ANSWER = Answer(imagination=WALK)


def lookup(scene: Scene, sigma: dict[str, float] | None = None, aside: bool = False) -> tuple[Answer, float] | None:
    cache = ImaginationCache(move_tol=0.1, reach=0.6, max_age=1.0)
    cache.store(KEY, footing(SCENE, "p", {}), ANSWER, aside=aside)
    return cache.lookup(KEY, footing(scene, "p", sigma or {}))


def hit(scene: Scene, sigma: dict[str, float] | None = None) -> bool:
    return lookup(scene, sigma) is not None


def moved(obstacle: Obstacle, dx: float, dy: float) -> Obstacle:
    s = obstacle.shape
    assert isinstance(s, Circle)
    return replace(obstacle, shape=Circle(s.x + dx, s.y + dy, s.r))


def with_obstacles(*obstacles: Obstacle, time: float = 1.2) -> Scene:
    return replace(SCENE, obstacles=obstacles, time=time)


def at(x: float, y: float, heading: float = 0.0, time: float = 1.3) -> Scene:
    return replace(SCENE, people=(replace(PERSON, x=x, y=y, heading=heading),), time=time)


def test_a_person_walking_along_the_imagined_path_reuses_it_advanced() -> None:
    got = lookup(at(-1.5, 0.04, heading=0.3))
    assert got is not None and math.isclose(got[1], 1.0, abs_tol=0.11)  # 0.5 m at 0.5 m/s
    walk = got[0].imagination
    assert walk is not None and walk.path == ((-1.5, 0.0), (2.25, 0.0))  # the rest of the walk, from where they are
    standing = lookup(at(-2.0, 0.0, time=1.9))
    assert standing is not None and standing[1] == 0.0


def test_leaving_the_path_or_changing_sigma_or_ageing_redoes_it() -> None:
    assert not hit(at(-1.5, 0.2))
    assert not hit(SCENE, {"p": 0.05})
    assert not hit(replace(SCENE, time=2.5))


def test_a_walk_aside_is_kept_until_the_person_moves_far_or_turns() -> None:
    assert lookup(at(-1.7, 0.3), aside=True) is not None
    assert lookup(at(-1.4, 0.5), aside=True) is None
    assert lookup(at(-2.0, 0.0, heading=0.4), aside=True) is None


def test_only_bodies_near_the_path_or_the_target_matter() -> None:
    assert hit(with_obstacles(COUCH, BALL, moved(FAR, 0.5, 0.0)))  # far from the walk: ignored
    assert not hit(with_obstacles(COUCH, moved(BALL, 0.0, 0.2), FAR))  # on the way: moved
    assert not hit(with_obstacles(COUCH, FAR))  # on the way: vanished
    assert not hit(with_obstacles(COUCH, BALL, moved(FAR, 0.0, -2.3)))  # came onto the way
    assert not hit(with_obstacles(moved(COUCH, 0.0, 1.0), BALL, FAR))  # the target moved
    assert not hit(with_obstacles(COUCH, replace(BALL, shape=Circle(0.0, 0.05, 0.2)), FAR))  # resized


def test_sweep_forgets_what_was_not_looked_up() -> None:
    cache = ImaginationCache()
    cache.store(KEY, footing(SCENE, "p", {}), ANSWER)
    cache.sweep()
    assert cache.lookup(KEY, footing(SCENE, "p", {})) is None
    assert cache.hits == 0 and cache.misses == 1


def test_a_walk_clear_by_less_than_the_tolerance_is_redone_once_things_move_that_far() -> None:
    close = Answer(imagination=replace(WALK, min_clearance=0.03))
    cache = ImaginationCache(move_tol=0.1, reach=0.6, max_age=1.0)
    cache.store(KEY, footing(SCENE, "p", {}), close)
    assert cache.lookup(KEY, footing(at(-1.5, 0.02), "p", {})) is not None
    assert cache.lookup(KEY, footing(at(-1.5, 0.05), "p", {})) is None  # off the path by more than the 3 cm
    assert cache.lookup(KEY, footing(with_obstacles(COUCH, moved(BALL, 0.0, 0.05), FAR), "p", {})) is None
    touching = Answer(imagination=replace(WALK, collided=True, min_clearance=-0.01))
    cache.store(KEY, footing(SCENE, "p", {}), touching)
    assert cache.lookup(KEY, footing(at(-1.5, 0.05), "p", {})) is not None  # risky already: the full tolerance


def test_a_walk_the_person_has_walked_past_the_contact_of_is_imagined_again() -> None:
    touching = replace(WALK, collided=True, collision_time=1.5, collision_point=(-1.1, 0.1), collision_object="ball")
    sampled = Answer(imagination=WALK, risk=Risk(0.3, 1.5, (-1.1, 0.1), "ball"))
    for answer in (Answer(imagination=touching), sampled):
        cache = ImaginationCache(move_tol=0.1, reach=0.6, max_age=3.0)
        cache.store(KEY, footing(SCENE, "p", {}), answer)
        assert cache.lookup(KEY, footing(at(-1.5, 0.0), "p", {})) is not None  # 1 s walked: the touch is ahead
        assert cache.lookup(KEY, footing(at(-1.0, 0.0), "p", {})) is None  # 2 s walked, and no fall
