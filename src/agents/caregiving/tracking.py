"""Multi-object tracking of identity-less detections, so that W ids persist.

Detections are associated to tracks of the same kind greedily, nearest first,
within a gate around each track's predicted position. Static objects average
every position they were seen at (their size estimate keeps the sensor's bias,
which no averaging removes); people are fitted with a constant-velocity line
over a short window, which gives position, velocity and the uncertainty of both.
A track is confirmed after a few detections and forgotten when unseen for a while.
"""

from __future__ import annotations

import math
from collections import deque
from dataclasses import dataclass, field
from itertools import count, islice
from typing import Any

import numpy as np

PERSON = "person"


@dataclass
class Track:
    """One tracked entity; ``x, y, heading`` and ``vx, vy`` are the current estimates."""

    id: int
    kind: str
    shape: str
    target: bool
    first: float
    last: float
    samples: deque[tuple[float, float, float, float]] = field(default_factory=lambda: deque(maxlen=240))
    sizes: deque[tuple[float, float, float]] = field(default_factory=lambda: deque(maxlen=240))
    x: float = 0.0
    y: float = 0.0
    heading: float = 0.0
    vx: float = 0.0
    vy: float = 0.0
    sigma: float = 0.0
    # A person's velocity uncertainty per axis (m/s): infinite until three detections fit a line.
    velocity_sigma: float = math.inf

    @property
    def hits(self) -> int:
        return len(self.samples)

    def size(self) -> tuple[float, float, float]:
        """Mean footprint extent along x, y and mean height."""
        sx, sy, h = np.mean(np.asarray(self.sizes), axis=0)
        return float(sx), float(sy), float(h)

    def origin(self, window: float) -> tuple[float, float]:
        """Where the track began: a constant-velocity line over its first ``window`` seconds, at its first stamp."""
        data = np.asarray(self.samples)
        data = data[data[:, 0] <= self.first + window]
        if len(data) < 3:
            return float(data[0, 1]), float(data[0, 2])
        coef = _line(data, self.first)
        return float(coef[0, 0]), float(coef[0, 1])

    def lower_than(self, height: float, frames: int) -> bool:
        """Whether each of the newest ``frames`` detections (and at least that many) was lower than ``height``."""
        recent = list(islice(reversed(self.sizes), frames))
        return len(recent) == frames and all(h < height for *_, h in recent)

    def predict(self, stamp: float) -> tuple[float, float]:
        dt = stamp - self.last
        return self.x + self.vx * dt, self.y + self.vy * dt


class Tracker:
    """Associates frames of detections to tracks."""

    def __init__(
        self, sensor_sigma: float, gate: float = 0.6, confirm: int = 3, forget: float = 1.0, window: float = 1.0
    ) -> None:
        self.sensor_sigma = sensor_sigma
        self.gate = gate
        self.confirm = confirm
        self.forget = forget
        self.window = window
        self.tracks: dict[int, Track] = {}
        self._ids = count(1)

    def reset(self) -> None:
        self.tracks.clear()

    def update(self, stamp: float, detections: list[dict[str, Any]]) -> list[Track]:
        """Fold in one frame; returns the tracks it touched."""
        touched = []
        pairs = []
        for i, d in enumerate(detections):
            s = d["shape"]
            for t in self.tracks.values():
                if t.kind == d["kind"] and t.last < stamp:
                    px, py = t.predict(stamp)
                    dist = math.hypot(s["x"] - px, s["y"] - py)
                    if dist <= self.gate:
                        pairs.append((dist, i, t.id))
        used_d: set[int] = set()
        used_t: set[int] = set()
        for _, i, tid in sorted(pairs):
            if i in used_d or tid in used_t:
                continue
            used_d.add(i)
            used_t.add(tid)
            touched.append(self._fold(self.tracks[tid], stamp, detections[i]))
        for i, d in enumerate(detections):
            if i not in used_d:
                t = Track(next(self._ids), d["kind"], d["shape"]["type"], bool(d["target"]), stamp, stamp)
                self.tracks[t.id] = t
                touched.append(self._fold(t, stamp, d))
        return touched

    def prune(self, now: float) -> list[Track]:
        """Forget the tracks unseen for ``forget`` seconds; returns them."""
        gone = [t for t in self.tracks.values() if now - t.last > self.forget]
        for t in gone:
            del self.tracks[t.id]
        return gone

    def confirmed(self, t: Track) -> bool:
        return t.hits >= self.confirm

    def _fold(self, t: Track, stamp: float, d: dict[str, Any]) -> Track:
        s = d["shape"]
        t.samples.append((stamp, s["x"], s["y"], float(d["heading"])))
        if s["type"] == "circle":
            t.sizes.append((2 * s["r"], 2 * s["r"], float(d["height"])))
        else:
            t.sizes.append((2 * s["hx"], 2 * s["hy"], float(d["height"])))
        t.last = stamp
        data = np.asarray(t.samples)
        if t.kind == PERSON:
            self._fit_moving(t, data[data[:, 0] >= stamp - self.window])
        else:
            t.x, t.y = float(data[:, 1].mean()), float(data[:, 2].mean())
            t.heading = float(np.arctan2(np.sin(data[:, 3]).mean(), np.cos(data[:, 3]).mean()))
            t.sigma = self.sensor_sigma / math.sqrt(len(data))
        return t

    def _fit_moving(self, t: Track, data: np.ndarray) -> None:
        """Constant-velocity least squares over the window, evaluated at the newest stamp."""
        n = len(data)
        recent = data[-5:, 3]
        t.heading = float(np.arctan2(np.sin(recent).mean(), np.cos(recent).mean()))
        if n < 3:
            t.x, t.y, t.vx, t.vy = float(data[-1, 1]), float(data[-1, 2]), 0.0, 0.0
            t.sigma, t.velocity_sigma = self.sensor_sigma, math.inf
            return
        time = data[:, 0] - data[-1, 0]
        coef = _line(data, data[-1, 0])
        t.x, t.y = float(coef[0, 0]), float(coef[0, 1])
        t.vx, t.vy = float(coef[1, 0]), float(coef[1, 1])
        # Variance of a least-squares line at its end point: sigma^2 (1/n + tbar^2 / Sxx); of its slope: sigma^2 / Sxx.
        sxx = max(float(((time - time.mean()) ** 2).sum()), 1e-9)
        t.sigma = self.sensor_sigma * math.sqrt(1 / n + time.mean() ** 2 / sxx)
        t.velocity_sigma = self.sensor_sigma / math.sqrt(sxx)


def _line(data: np.ndarray, at: float) -> np.ndarray:
    """A constant-velocity least-squares line through rows (stamp, x, y, ...): position (row 0) and velocity
    (row 1) at stamp ``at``."""
    design = np.stack([np.ones(len(data)), data[:, 0] - at], axis=1)
    coef, *_ = np.linalg.lstsq(design, data[:, 1:3], rcond=None)
    return coef
