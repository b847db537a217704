"""Sampled collision risk: vectorised shapes, unseen versus seen obstacles, remembered objects."""

import math
from dataclasses import replace

import numpy as np
import pytest

from agents.caregiving.model.geometry import Box, Circle, signed_distance
from agents.caregiving.model.imagine import Imagination, imagine_person
from agents.caregiving.model.scenario import load_scenario
from agents.caregiving.model.scene import Scene
from agents.caregiving.model.uncertainty import Uncertainty, _clearances, collision_risk

GAZE = math.radians(8)


def test_vectorised_box_clearances_match_signed_distance() -> None:
    rng = np.random.default_rng(3)
    box = Box(0.3, -0.2, 0.4, 0.15, 0.7)
    walkers = rng.uniform(-1, 1, (6, 40, 2))
    offset, scale = rng.normal(0, 0.05, (6, 2)), rng.uniform(0.8, 1.2, 6)
    expected = np.stack(
        [
            signed_distance(
                Box(box.x + offset[i, 0], box.y + offset[i, 1], box.hx * scale[i], box.hy * scale[i], box.theta),
                walkers[i],
            )
            for i in range(6)
        ]
    )
    assert np.allclose(_clearances(box, walkers, offset, scale), expected)


def test_unseen_ball_on_the_way_is_a_near_certain_collision() -> None:
    scene = load_scenario("paper_experiment1").scene()
    im = imagine_person(scene, "person", "couch", GAZE)
    risk = collision_risk(scene, im, Uncertainty(0.2, {"ball": 0.02, "person": 0.03}, samples=128))
    assert risk.probability == pytest.approx(1.0) and risk.obstacle == "ball"
    assert risk.time == pytest.approx(im.collision_time, abs=0.3)


def test_seen_or_remembered_obstacles_are_not_a_risk() -> None:
    scene = load_scenario("person_sees_obstacle").scene()
    im = imagine_person(scene, "person", "couch", GAZE)
    assert "plant" in im.seen and not im.collided
    assert collision_risk(scene, im, Uncertainty(0.2, {"plant": 0.05, "person": 0.05})).probability == 0.0
    looking_up = imagine_person(scene, "person", "couch", math.radians(60), known=["plant"])
    assert "plant" in looking_up.seen and not looking_up.collided


def test_each_sampled_world_is_the_same_whatever_else_is_sampled_beside_it() -> None:
    """Each entity's draws are its own: a plant sampled near the walk, never touched, leaves the ball's worlds as
    they were, so two walks past different things can be compared world by world."""
    scene = load_scenario("paper_experiment1").scene()
    ball = next(o for o in scene.obstacles if o.name == "ball")
    grazed = replace(ball, shape=replace(ball.shape, y=ball.shape.y + 0.38))  # passed by a centimetre
    scene = replace(scene, obstacles=tuple(grazed if o.name == "ball" else o for o in scene.obstacles))
    im = imagine_person(scene, "person", "couch", GAZE)
    u = Uncertainty(0.2, {"ball": 0.05, "person": 0.05, "plant": 0.05}, samples=64)
    alone = collision_risk(scene, im, u)
    assert 0.0 < alone.probability < 1.0 and alone.worlds.bit_count() == round(alone.probability * 64)
    plant = replace(ball, name="plant", shape=Box(0.0, -0.55, 0.1, 0.1, 0.0))  # within reach, 20 cm off the walk
    with_plant = replace(scene, obstacles=(plant, *scene.obstacles))
    assert collision_risk(with_plant, im, u).worlds == alone.worlds


def _ball_next_to_person(gap: float, behind: bool) -> tuple[Scene, Imagination]:
    """The paper's room with the ball moved right behind (or in front of) the person, ``gap`` m clear of them."""
    scene = load_scenario("paper_experiment1").scene()
    im = imagine_person(scene, "person", "couch", GAZE)
    person = scene.person("person")
    (x0, y0), (x1, y1) = im.path[0], im.path[1]
    ahead = np.array([x1 - x0, y1 - y0]) / math.hypot(x1 - x0, y1 - y0)
    ball = next(o for o in scene.obstacles if o.name == "ball")
    assert isinstance(ball.shape, Circle)
    x, y = np.array([person.x, person.y]) + ahead * (person.radius + ball.shape.r + gap) * (-1 if behind else 1)
    moved = replace(ball, shape=replace(ball.shape, x=float(x), y=float(y)))
    scene = replace(scene, obstacles=tuple(moved if o.name == "ball" else o for o in scene.obstacles))
    return scene, imagine_person(scene, "person", "couch", GAZE)


def test_a_sampled_touch_at_the_start_is_no_fall_when_the_person_walks_away_from_it() -> None:
    """Many sampled balls (up to 25 % larger) just behind the person touch them at the start: walking away, no risk."""
    u = Uncertainty(0.2, {"ball": 0.02, "person": 0.02}, samples=128)
    for gap in (0.01, -0.1):  # clear by 1 cm, and overlapping them in every sampled world
        scene, im = _ball_next_to_person(gap, behind=True)
        assert "ball" not in im.seen
        assert collision_risk(scene, im, u).probability == 0.0
    # Walking into it, a touch at the start is a fall at once.
    scene, im = _ball_next_to_person(-0.1, behind=False)
    risk = collision_risk(scene, im, u)
    assert risk.probability == 1.0 and risk.time == 0.0 and risk.obstacle == "ball"
