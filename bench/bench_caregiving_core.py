"""Timing and ground-truth figures of the caregiving core on Experiment 1.

Reports grid planning time with cached inflated masks versus a cold cache, a
person rollout in PyBullet versus the numpy fast path (and their ratio),
imagine_person latency and that of the joint imagination in time (robot driving,
person walking, as the world model advances them) beside the same imagination
stepped one 50 ms step at a time (``World.step`` only, the baseline that
``World.advance``'s bulk pass must match), and the ground-truth risky rate
(robot idle, exact geometry) over sampled trials of ``paper_experiment1.yaml``.
Latencies are medians and 95th percentiles of repeated calls in this process;
the planner's remembered walks are forgotten before each call, so no call
simply repeats the one before (its inflated masks stay warm, as they do live).

    python bench/bench_caregiving_core.py [--json PATH] [--trials N] [--seed S] [--repeat N]
"""

from __future__ import annotations

import math
import platform
import statistics
import time
from collections.abc import Callable

import numpy as np

import benchlib
from agents.caregiving.model.imagine import imagine_person
from agents.caregiving.model.joint import HORIZON, imagine_joint
from agents.caregiving.model.planner import GridPlanner
from agents.caregiving.model.robot_moves import standoff_moves
from agents.caregiving.model.rollout import BulletRollout, NumpyRollout
from agents.caregiving.model.scenario import load_scenario, sample_trial
from agents.caregiving.model.world_model import Walk, World, run_idle


def timings(call: Callable[[], object], repeat: int, before: Callable[[], object] = lambda: None) -> dict[str, float]:
    """Median and p95 of ``call()`` in milliseconds, after one warm-up call; ``before()`` runs untimed before each."""
    call()
    samples = []
    for _ in range(repeat):
        before()
        start = time.perf_counter()
        call()
        samples.append((time.perf_counter() - start) * 1e3)
    samples.sort()
    return {"median_ms": statistics.median(samples), "p95_ms": samples[min(len(samples) - 1, int(0.95 * len(samples)))]}


def main() -> None:
    parser = benchlib.parser("bench_caregiving_core", __doc__.split("\n")[0])
    parser.add_argument("--trials", type=int, default=180, help="sampled Experiment 1 trials for the risky rate")
    parser.add_argument("--seed", type=int, default=2024, help="seed of the trial sampler")
    parser.add_argument("--repeat", type=int, default=200, help="timed calls per latency figure")
    args = parser.parse_args()

    scenario = load_scenario("paper_experiment1")
    scene = scenario.scene()
    person = scene.people[0]
    couch = scene.obstacle("couch")
    everything = scene.bodies_around(person.name)
    gaze = math.radians(scenario.people[0].gaze_deg)

    warm = GridPlanner(scene.bounds)
    fresh = warm.forget_plans  # the masks stay warm; no call simply gets the walk the one before planned
    plan_cached = timings(
        lambda: warm.plan_to_object((person.x, person.y), couch, everything, person.radius), args.repeat, fresh
    )

    def cold() -> None:
        warm.clear_cache()
        warm.plan_to_object((person.x, person.y), couch, everything, person.radius)

    plan_cold = timings(cold, args.repeat)

    path = warm.plan_to_object((person.x, person.y), couch, everything, person.radius).path
    walk_obstacles = [o for o in everything if o.name != couch.name]
    numpy_rollout, bullet_rollout = NumpyRollout(), BulletRollout.shared()
    roll_numpy = timings(lambda: numpy_rollout.walk(path, person.radius, person.speed, walk_obstacles), args.repeat)
    roll_bullet = timings(lambda: bullet_rollout.walk(path, person.radius, person.speed, walk_obstacles), args.repeat)
    walked = numpy_rollout.walk(path, person.radius, person.speed, walk_obstacles)

    person_latency = timings(
        lambda: imagine_person(scene, person.name, couch.name, gaze, planner=warm), args.repeat, fresh
    )
    person_bullet = timings(
        lambda: imagine_person(scene, person.name, couch.name, gaze, bullet_rollout, planner=warm), args.repeat, fresh
    )
    move = standoff_moves(scene, "ball")[4]
    walk = [Walk(person.name, couch.name, gaze)]
    joint_latency = timings(lambda: imagine_joint(scene, walk, move, planner=warm), args.repeat, fresh)

    def stepped_joint() -> None:
        world = World(scene, walk, planner=warm)
        world.command_robot(move)
        while not world.done and world.time < scene.time + HORIZON - 1e-9:
            world.step()

    joint_stepped = timings(stepped_joint, args.repeat, fresh)

    rng = np.random.default_rng(args.seed)
    planner = GridPlanner(scene.bounds)
    risky = 0
    start = time.perf_counter()
    for _ in range(args.trials):
        risky += run_idle(sample_trial(scenario, rng), planner=planner).collided
    per_trial = (time.perf_counter() - start) / args.trials * 1e3

    report = {
        "machine": platform.machine(),
        "python": platform.python_version(),
        "planning": {
            "cached_masks": plan_cached,
            "cold_cache": plan_cold,
            "cold_over_cached": plan_cold["median_ms"] / plan_cached["median_ms"],
        },
        "rollout": {
            "steps": walked.steps,
            "numpy": roll_numpy,
            "pybullet": roll_bullet,
            "pybullet_over_numpy": roll_bullet["median_ms"] / roll_numpy["median_ms"],
        },
        "imagine_person": person_latency,
        "imagine_person_pybullet": person_bullet,
        "imagine_joint": joint_latency,
        "imagine_joint_stepped": joint_stepped,
        "joint_stepped_over_advanced": joint_stepped["median_ms"] / joint_latency["median_ms"],
        "ground_truth": {
            "trials": args.trials,
            "seed": args.seed,
            "risky": risky,
            "risky_rate": risky / args.trials,
            "ms_per_trial": per_trial,
        },
    }
    benchlib.write_json(args.json, report)
    print(f"planning (ms, median): cached {plan_cached['median_ms']:.2f}  cold {plan_cold['median_ms']:.2f}")
    print(
        f"rollout {walked.steps} steps (ms, median): numpy {roll_numpy['median_ms']:.3f}  "
        f"pybullet {roll_bullet['median_ms']:.3f}  ratio {report['rollout']['pybullet_over_numpy']:.1f}x"
    )
    print(
        f"imagine_person (ms): median {person_latency['median_ms']:.2f}  p95 {person_latency['p95_ms']:.2f}  "
        f"(pybullet median {person_bullet['median_ms']:.2f})"
    )
    print(
        f"imagine_joint (ms): median {joint_latency['median_ms']:.2f}  p95 {joint_latency['p95_ms']:.2f}  "
        f"(stepped one by one: median {joint_stepped['median_ms']:.2f}, "
        f"{report['joint_stepped_over_advanced']:.1f}x)"
    )
    print(f"ground truth: {risky}/{args.trials} risky ({risky / args.trials:.1%}), {per_trial:.0f} ms per trial")


if __name__ == "__main__":
    main()
