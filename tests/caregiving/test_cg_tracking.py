"""Tracking people: where a person's walk began, from the first second of their track, and whether they walk."""

import math

import numpy as np

from agents.caregiving.model.guesses import Walking
from agents.caregiving.tracking import Tracker

START, HEADING, SPEED = (1.0, 2.0), math.radians(30), 0.7


def _position(stamp: float) -> tuple[float, float]:
    return START[0] + SPEED * math.cos(HEADING) * stamp, START[1] + SPEED * math.sin(HEADING) * stamp


def _detect(tracker: Tracker, stamps: range, rng: np.random.Generator) -> None:
    for k in stamps:
        stamp = 0.05 * k
        x, y = np.array(_position(stamp)) + rng.normal(0.0, 0.04, 2)
        shape = {"type": "circle", "x": float(x), "y": float(y), "r": 0.25}
        tracker.update(stamp, [{"kind": "person", "shape": shape, "heading": HEADING, "target": False, "height": 1.7}])


def test_the_origin_of_a_walk_is_fitted_back_to_the_first_stamp_and_then_stays() -> None:
    misses = []
    for seed in range(20):
        rng = np.random.default_rng(seed)
        tracker = Tracker(0.04)
        _detect(tracker, range(1, 22), rng)  # the first second from the first stamp
        track = next(iter(tracker.tracks.values()))
        origin = track.origin(tracker.window)
        misses.append(math.dist(origin, _position(0.05)))
        _detect(tracker, range(22, 41), rng)  # a second more leaves it as it was
        assert track.origin(tracker.window) == origin
        assert math.dist((track.x, track.y), _position(2.0)) < 0.1
    # A line fitted over 21 detections of 4 cm error, at its end: about 2 cm, far below one detection's.
    assert float(np.sqrt(np.mean(np.square(misses)))) < 0.03


def test_a_person_is_lower_only_when_each_of_their_newest_detections_is() -> None:
    tracker = Tracker(0.04)

    def detect(stamp: float, height: float) -> None:
        shape = {"type": "circle", "x": 0.0, "y": 0.0, "r": 0.25}
        tracker.update(stamp, [{"kind": "person", "shape": shape, "heading": 0.0, "target": False, "height": height}])

    for k, height in enumerate((1.7, 1.7, 1.7, 0.3, 0.3, 1.7, 0.3, 0.3)):
        detect(0.05 * k, height)
        track = next(iter(tracker.tracks.values()))
        assert not track.lower_than(0.85, 3)  # never three low in a row
    detect(0.4, 0.3)
    assert track.lower_than(0.85, 3) and not track.lower_than(0.85, 4) and not track.lower_than(0.2, 3)


def _track_standing_or_walking(speed: float, detections: int, seed: int) -> tuple[float, float]:
    """The fitted speed and its error after ``detections`` frames of the paper's sensors (15 Hz, 5 cm) of
    someone walking at ``speed`` m/s."""
    rng, tracker = np.random.default_rng(seed), Tracker(0.05)
    for k in range(detections):
        stamp = k / 15.0
        x, y = np.array((speed * stamp, 0.0)) + rng.normal(0.0, 0.05, 2)
        shape = {"type": "circle", "x": float(x), "y": float(y), "r": 0.25}
        tracker.update(stamp, [{"kind": "person", "shape": shape, "heading": 0.0, "target": False, "height": 1.7}])
    track = next(iter(tracker.tracks.values()))
    return math.hypot(track.vx, track.vy), track.velocity_sigma


def test_someone_walking_is_taken_to_walk_from_the_first_fit_and_someone_standing_once_the_track_can_tell() -> None:
    walking = Walking()
    for detections in (3, 4, 5, 8, 15, 30):
        fits = [_track_standing_or_walking(0.5, detections, seed) for seed in range(200)]
        assert all(walking.walks(speed, sigma) for speed, sigma in fits)
    young = [_track_standing_or_walking(0.5, 4, seed) for seed in range(200)]
    assert sum(speed <= walking.speed for speed, _ in young) >= 5  # the fitted speed alone says she stands
    for detections in (15, 30):  # a window of a second
        fits = [_track_standing_or_walking(0.0, detections, seed) for seed in range(200)]
        assert not any(walking.walks(speed, sigma) for speed, sigma in fits)
