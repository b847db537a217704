"""A person's walking speed: the model's until their tracked walk rejects it, then their own."""

import math

import numpy as np

from agents.caregiving.tracking import Tracker
from agents.caregiving.walking_speed import WalkingSpeed

MODEL, RATE, NOISE = 0.5, 15.0, 0.05


def _walk(speed: float, seed: int, seconds: float = 3.0) -> tuple[WalkingSpeed, list[tuple[float, float]]]:
    """Track a person walking a straight line at ``speed`` under sensor noise; the speed and what was written."""
    rng = np.random.default_rng(seed)
    tracker, walking = Tracker(NOISE), WalkingSpeed(MODEL)
    heading, written = math.radians(30), []
    for k in range(int(seconds * RATE)):
        stamp = k / RATE
        x, y = np.array((speed * math.cos(heading) * stamp, speed * math.sin(heading) * stamp)) + rng.normal(
            0, NOISE, 2
        )
        shape = {"type": "circle", "x": float(x), "y": float(y), "r": 0.25}
        det = {"kind": "person", "shape": shape, "heading": heading, "target": False, "height": 1.7}
        for track in tracker.update(stamp, [det]):
            if tracker.confirmed(track) and (pace := walking.observe(track, tracker.window)) is not None:
                written.append((stamp, pace))
    return walking, written


def test_a_person_walking_at_another_pace_than_the_models_is_given_their_own_once_a_window_is_walked() -> None:
    for speed in (0.35, 0.7, 1.0):
        for seed in range(10):
            walking, written = _walk(speed, seed)
            assert written and written[0][0] >= 1.0  # a whole window of walking first
            assert abs(walking.written - speed) < 0.05, (speed, seed, written)


def test_a_person_walking_at_the_models_pace_keeps_it_exactly() -> None:
    for seed in range(20):
        walking, written = _walk(MODEL, seed)
        assert written == [] and walking.written == MODEL


def test_nobody_standing_is_given_a_pace_and_the_speed_changes_only_by_more_than_its_sigma() -> None:
    standing, written = _walk(0.0, 0)
    assert written == [] and standing.measured is None
    walking = WalkingSpeed(MODEL)
    assert walking.update(0.9, math.inf, True) is None  # a line through two detections tells nothing
    assert walking.update(0.7, 0.04, True) == 0.7
    assert walking.update(0.72, 0.04, True) is None  # the mean moved 1 cm/s, less than a sigma
    assert walking.update(0.9, 0.04, False) is None  # a fit of someone not walking is not counted
    assert walking.measured == 0.71
