"""Reaction time of the multi-process caregiving stack as people and objects grow, up to 5 x 20.

For each size it writes a scenario with that many people (the first walks to
the couch, the others to the door) and that many objects strewn about (one ball
on the first person's way, below their gaze, where the robot can get in time), runs a few trials on one live stack (world bridge, perception,
simulation, intention, action, executor; sensor noise on) and reports, from the
stamps the agents write into W, the paper's reaction time (risky intention ->
robot action) and the end-to-end time (perception write -> robot action), with
how many risky trials got an action.

    python bench/bench_reaction_scaling.py [--json PATH] [--trials N] [--rate R]
"""

from __future__ import annotations

import asyncio
import math
import platform
import statistics
import tempfile
from pathlib import Path
from typing import Any

import numpy as np
import yaml
from rich.console import Console

import benchlib
from agents.caregiving.model.scenario import load_scenario
from bridges.experiment.experiment import run_trials
from bridges.experiment.launch import Stack
from bridges.experiment.trials import finite

SIZES = [(1, 5), (2, 10), (3, 15), (5, 20)]
#: A 10 x 7 m room: 20 objects fit with the first walker's way, and room for a detour beside the ball, kept clear.
ROOM = (10.0, 7.0)
CLUTTER = [
    ("box", "box", (0.4, 0.3), 0.4),
    ("toy", "circle", 0.08, 0.15),
    ("plant", "circle", 0.2, 1.0),
    ("chair", "box", (0.5, 0.5), 0.9),
    ("shoe", "box", (0.3, 0.12), 0.12),
    ("backpack", "box", (0.35, 0.25), 0.4),
]


def in_first_way(x: float, y: float) -> bool:
    """Whether (x, y) is on the first walker's way to the couch, or beside the ball where a detour goes."""
    return x < 2.6 and (abs(y) < 0.7 or -0.6 < x < 2.2 and abs(y) < 1.3)


def scenario_dict(people: int, objects: int, seed: int) -> dict[str, Any]:
    """A room of ``people`` walkers and ``objects`` objects (couch, door and a ball included)."""
    rng = np.random.default_rng(seed)
    objs: list[dict[str, Any]] = [
        {
            "name": "couch",
            "kind": "couch",
            "shape": {"type": "box", "size": [0.9, 2.0]},
            "height": 0.8,
            "pose": [3.5, 0.0, 0.0],
            "target": True,
        },
        {
            "name": "door",
            "kind": "door",
            "shape": {"type": "box", "size": [1.0, 0.1]},
            "height": 2.0,
            "pose": [1.5, ROOM[1] / 2 - 0.05, 0.0],
            "target": True,
        },
        {
            "name": "ball",
            "kind": "ball",
            "shape": {"type": "circle", "radius": 0.11},
            "height": 0.22,
            "pose": [0.8, 0.0, 0.0],
        },
    ]
    placed = [(3.5, 0.0, 1.2), (1.5, ROOM[1] / 2 - 0.05, 0.6), (0.8, 0.0, 0.5)]
    ys = np.linspace(-2.2, 2.2, people) if people > 1 else np.array([0.0])
    walkers = []
    for i, y in enumerate(ys):
        x = -2.5 if i == 0 else -3.3
        y = 0.0 if i == 0 else float(y)
        placed.append((x, y, 0.5))
        walkers.append(
            {
                "name": f"p{i}",
                "pose": [x, y, 0.0],
                "target": "couch" if i == 0 else "door",
                "speed": 0.5,
                "radius": 0.25,
                "eye_height": 1.6,
                "hfov_deg": 120.0,
                "vfov_deg": 40.0,
                "gaze_range_deg": [6.0, 10.0],
                "gaze_deg": 8.0,
            }
        )
    placed.append((1.2, -1.5, 0.6))
    k = 0
    while len(objs) < objects:
        kind, shape, size, height = CLUTTER[k % len(CLUTTER)]
        x, y = float(rng.uniform(-2.6, 3.0)), float(rng.uniform(-ROOM[1] / 2 + 0.5, ROOM[1] / 2 - 0.5))
        if any(math.hypot(x - px, y - py) < r + 0.5 for px, py, r in placed) or in_first_way(x, y):
            continue  # keep the first person's way clear but for the ball
        shape_spec = {"type": "circle", "radius": size} if shape == "circle" else {"type": "box", "size": list(size)}
        objs.append(
            {
                "name": f"{kind}{k}",
                "kind": kind,
                "shape": shape_spec,
                "height": height,
                "pose": [x, y, float(rng.uniform(0, 90))],
                "target": kind == "chair",
            }
        )
        placed.append((x, y, 0.4))
        k += 1
    return {
        "name": f"scale_{people}x{objects}",
        "description": "scaling benchmark",
        "room": {"size": list(ROOM)},
        "objects": objs,
        "people": walkers,
        "robot": {
            "name": "robot",
            "pose": [1.2, -1.5, 90.0],
            "footprint": [0.5, 0.4],
            "height": 1.5,
            "max_speed": 0.8,
            "max_accel": 0.6,
        },
        "sensors": {
            "enabled": True,
            "rate_hz": 15.0,
            "position_sigma": 0.05,
            "heading_sigma_deg": 5.0,
            "size_error": 0.2,
            "dropout": 0.05,
            "latency": 0.05,
        },
        "randomisation": {"entities": ["ball"], "radius": 0.3, "trials": 1},
    }


def summary(values: list[float]) -> dict[str, float | None]:
    if not values:
        return {"mean": None, "p50": None, "p99": None, "max": None}
    return {
        "mean": statistics.fmean(values),
        "p50": float(np.percentile(values, 50)),
        "p99": float(np.percentile(values, 99)),
        "max": max(values),
    }


def main() -> None:
    parser = benchlib.parser("bench_reaction_scaling", __doc__.split("\n")[0])
    parser.add_argument("--trials", type=int, default=3, help="trials per size")
    parser.add_argument("--rate", type=float, default=2.0, help="simulated seconds per wall second")
    args = parser.parse_args()
    console = Console()
    work = Path(tempfile.mkdtemp(prefix="wm-scaling-"))
    files = []
    for people, objects in SIZES:
        path = work / f"scale_{people}x{objects}.yaml"
        path.write_text(yaml.safe_dump(scenario_dict(people, objects, seed=people * 100 + objects)))
        load_scenario(path)  # validate before starting anything
        files.append(path)
    results = []
    with Stack("scaling", str(files[0]), work / "logs", rate=args.rate) as stack:
        for (people, objects), path in zip(SIZES, files, strict=True):
            scored = asyncio.run(
                run_trials(
                    load_scenario(path), stack, 1, list(range(args.trials)), console, "scaling", scenario_file=str(path)
                )
            )
            reaction = finite([s.record.reaction_ms for s in scored])
            e2e = finite([s.record.e2e_ms for s in scored])
            row = {
                "people": people,
                "objects": objects,
                "trials": len(scored),
                "risky": sum(s.predicted for s in scored),
                "acted": sum(s.record.action is not None for s in scored),
                "collided": sum(s.record.collided for s in scored),
                "reaction_ms": summary(reaction),
                "e2e_ms": summary(e2e),
            }
            results.append(row)
            console.print(
                f"{people} people x {objects} objects: reaction mean "
                f"{row['reaction_ms']['mean'] or float('nan'):.1f} ms, e2e p50 "
                f"{row['e2e_ms']['p50'] or float('nan'):.1f} ms, acted {row['acted']}/{row['risky']}"
            )
    report = {
        "machine": platform.machine(),
        "python": platform.python_version(),
        "rate": args.rate,
        "goal_ms": 100.0,
        "sizes": results,
    }
    benchlib.write_json(args.json, report)


if __name__ == "__main__":
    main()
