"""A person's walking speed: the robot's model of people, until their own walk shows it wrong.

Perception writes each person's ``speed``, the pace the imaginations walk them at. It starts as the
model's (``--walk-speed``, or the scenario's first person's). People walk at their own pace, though: in a
room of several, a speed right for one is 40 % off for another, and the robot's moves are timed against
the walks it imagines. So each frame's fitted speed, while the person walks, joins a mean weighted by its
inverse variance (the first fits, over a few detections, count little), and when that mean lies more than
:data:`REJECT_SIGMAS` of the newest fit's speed uncertainty from the model's, the measured pace is written
instead. A person whose pace the sensors cannot tell from the model's keeps the model's exactly.
"""

from __future__ import annotations

import math
from dataclasses import dataclass, field

from .model.guesses import WALKING_SPEED
from .tracking import Track

#: How many sigmas of one window's fitted speed the measured pace must lie from the model's to replace it.
REJECT_SIGMAS = 2.0


@dataclass
class WalkingSpeed:
    """One track's walking speed: the model's until the fitted speeds, averaged, reject it."""

    model: float
    written: float = field(init=False)  # the model's, until the person's walk rejects it
    _weighted: float = 0.0
    _weights: float = 0.0

    def __post_init__(self) -> None:
        self.written = self.model

    @property
    def measured(self) -> float | None:
        """The mean fitted speed over the frames the person walked, weighted by inverse variance; None before any."""
        return self._weighted / self._weights if self._weights > 0.0 else None

    def observe(self, track: Track, window: float) -> float | None:
        """Fold in ``track``'s newest fit (its line over ``window`` seconds); returns the speed to write, if it
        changed. Only a fit over a whole window of walking counts: a line over fewer detections fits more noise,
        and the length of a noisy velocity is biased upwards (from half a window on, one person in ten walking at
        the model's pace was measured off it)."""
        fitted = math.hypot(track.vx, track.vy)
        walking = fitted > WALKING_SPEED and track.last - track.first >= window
        return self.update(fitted, track.velocity_sigma, walking)

    def update(self, fitted: float, sigma: float, walking: bool) -> float | None:
        """Fold in one frame's fitted speed (m/s) and its uncertainty; returns the speed to write, if it changed.

        ``walking``: whether the fit is of someone walking (someone standing has no pace to measure). The speed
        written changes only by more than a sigma, so the imaginations' caches are not spoilt by every frame's
        noise.
        """
        if walking and math.isfinite(sigma) and sigma > 0.0:
            self._weighted += fitted / sigma**2
            self._weights += 1.0 / sigma**2
        mean = self.measured
        if mean is None:
            return None
        best = mean if abs(mean - self.model) > REJECT_SIGMAS * sigma else self.model
        if abs(best - self.written) <= sigma:
            return None
        self.written = best
        return best
