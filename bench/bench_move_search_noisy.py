"""Algorithm 2's move search on a noisy belief, on every oracle-saveable trial of recorded experiment runs.

``bench_move_search.py`` searches the exact scene. Live, the search sees what
perception makes of it, and a move judged on that belief may fail in the truth,
or a move that saves in the truth may be refused on it. This bench draws
``--draws`` beliefs per trial at the moment the run first saw the danger (its
``risk_at_time``), from the scenario's own sensor model, as perception's tracker
would hold them then (``bridges.experiment.beliefs``):

* each object's position off by the sensor's sigma averaged over the frames seen
  so far (the tracker averages a static object's detections), and its size off by
  a factor drawn once within the sensor's ``size_error`` (a bias no averaging removes);
* each person's position off by half the sensor's sigma (what a one-second
  line fit leaves) and their heading by the sensor's heading sigma, and where
  their walk began likewise (the tracker fits their first second back to its
  start), drawn apart so that the other draws stay as they were.

Algorithm 1's danger is imagined on that belief (the first gaze class, nearest
the true gaze, whose walk collides), the search runs with the same uncertainty
as the action agent samples, and the chosen move is commanded in the ground truth
``--delay`` s plus ``--judging`` s per candidate judged later (with ``--head-start``,
the head start first, as the search sends it). A draw counts as saved when nobody
touches anything; ``into_robot`` counts the searches whose moves someone walks into
in the truth. The draws are seeded per trial, so two
versions of the search are compared on the same beliefs.

With ``--object-scale``, ``--size-scale`` and ``--people-scale`` the noise drawn on the objects'
positions, on their sizes and on the people's positions and headings is scaled (0: none), and with
``--no-sampled-risk`` the search judges without sampling the uncertainty, so that the cost of each
part of perception's noise shows apart.

    python bench/bench_move_search_noisy.py [--draws N] [--settle-after-clear N] [--object-scale K]
        [--size-scale K] [--people-scale K] [--no-sampled-risk] [--head-start [--drive-on]] [--json PATH] [RUN ...]
"""

from __future__ import annotations

import argparse
import time
from collections.abc import Iterator, Sequence
from dataclasses import dataclass, replace
from functools import partial

import numpy as np

import benchlib
from agents.caregiving.model import move_choice, move_search
from agents.caregiving.model.scene import Scene
from agents.caregiving.model.search_spec import SearchSpec
from agents.caregiving.model.service import serve_one
from agents.caregiving.model.uncertainty import Uncertainty
from bench_move_search import RUNS, THRESHOLD, Case, cases
from bridges.experiment.beliefs import Noise, belief, search_uncertainty
from bridges.experiment.oracle import idle_run, world_at
from bridges.experiment.perfect_belief import Gazes, outcome_in_truth, spec_on


def add_belief_arguments(p: argparse.ArgumentParser, runs: Sequence[str], drawn_per: str, delay: float) -> None:
    """The arguments of the benches on drawn beliefs: the recorded runs, the beliefs drawn, the robot's delays."""
    p.add_argument("runs", nargs="*", default=list(runs), help="recorded runs (docs/results/RUN.json)")
    p.add_argument("--draws", type=int, default=3, help=f"beliefs drawn per {drawn_per}")
    p.add_argument("--delay", type=float, default=delay, help="seconds from the danger to the robot's start")
    p.add_argument("--judging", type=float, default=0.02, help="seconds more per candidate judged")


@dataclass(frozen=True)
class Drawn:
    """One belief drawn of a saveable case, Algorithm 1's spec on it (``None``: it shows no danger), and the
    uncertainty the search samples round it."""

    case: Case
    scene: Scene
    spec: SearchSpec | None
    uncertainty: Uncertainty


def drawn_beliefs(runs: list[str], draws: int, delay: float, noise: Noise) -> Iterator[Drawn]:
    """``draws`` beliefs of every saveable case of ``runs``, at the moment its run saw the danger, the robot
    starting ``delay`` later; seeded per case and draw, so that every bench and version sees the same beliefs."""
    for case in cases(runs):
        if not case.saveable:
            continue
        idle = idle_run(case.trial, case.planner)
        now = world_at(case.trial, case.at, case.planner)
        rng, origins = np.random.default_rng([case.index, draws]), np.random.default_rng([case.index, draws, 1])
        sensors = case.trial.sensors
        for k in range(draws):
            scene = belief(now.scene(), sensors, case.at, noise, rng, origins)
            spec = spec_on(scene, idle, now, delay, Gazes.ANY_CLASS)
            yield Drawn(case, scene, spec, search_uncertainty(scene, sensors, case.at, k, noise))


def noisy_search(
    runs: list[str],
    draws: int,
    delay: float,
    judging: float,
    settle_after_clear: int,
    noise: Noise,
    head_start: bool = False,
    drive_on: bool = False,
) -> dict[str, object]:
    """Search ``draws`` beliefs of every saveable case; how many searches' moves save in the truth
    (``outcome_in_truth``: the chosen move, or with ``head_start`` the head start and then the chosen move; with
    ``drive_on``, a head start is driven on when no move is chosen, instead of braked)."""
    beliefs = flagged = chosen = saved = judged = into_robot = leads = 0
    lost: dict[str, int] = {}
    spent = 0.0
    for drawn in drawn_beliefs(runs, draws, delay, noise):
        case, scene, spec, uncertainty = drawn.case, drawn.scene, drawn.spec, drawn.uncertainty
        beliefs += 1
        if spec is None:
            continue
        flagged += 1
        started = time.perf_counter()
        result = move_search.search(
            scene,
            spec,
            partial(serve_one, scene),
            uncertainty,
            THRESHOLD,
            24,
            judging=judging,
            settle_after_clear=settle_after_clear,
            head_start=(lambda _lead: None) if head_start else None,
        )
        spent += time.perf_counter() - started
        judged += len(result.verdicts)
        chosen += result.chosen is not None and result.chosen.move is not None
        leads += result.lead is not None
        if drive_on:
            result = replace(result, halt=None)
        outcome = outcome_in_truth(case.trial, case.at, case.planner, delay, judging, result)
        ok = outcome is not None and not outcome.collided
        into_robot += outcome is not None and any(c.obstacle == scene.robot_name for c in outcome.collisions)
        saved += ok
        if not ok:
            name = f"{case.run}#{case.index}"
            lost[name] = lost.get(name, 0) + 1
    return {
        "beliefs": beliefs,
        "flagged": flagged,
        "chosen": chosen,
        "saved": saved,
        "into_robot": into_robot,
        "head_starts": leads,
        "judged": judged,
        "search_s": round(spent, 3),
        "lost_draws": lost,
    }


def main() -> None:
    p = benchlib.parser("bench_move_search_noisy", __doc__.splitlines()[0])
    add_belief_arguments(p, RUNS, "saveable trial", 0.1)
    p.add_argument(
        "--settle-after-clear",
        type=int,
        default=move_choice.SETTLE_AFTER_CLEAR,
        help="candidates judged past the first clear move before settling (default: %(default)s; 24: never)",
    )
    p.add_argument("--object-scale", type=float, default=1.0, help="times the noise drawn on objects' positions")
    p.add_argument("--size-scale", type=float, default=1.0, help="times the size bias drawn")
    p.add_argument("--people-scale", type=float, default=1.0, help="times the people's position and heading noise")
    p.add_argument(
        "--no-sampled-risk", action="store_true", help="search without sampling uncertainty (risk 0 when clear)"
    )
    p.add_argument(
        "--head-start", action="store_true", help="send the first candidate as a head start when it is harmless"
    )
    p.add_argument(
        "--drive-on",
        action="store_true",
        help="drive a head start on when no move is chosen, instead of braking (see bench_head_start_false_alarms.py)",
    )
    args = p.parse_args()
    noise = Noise(args.object_scale, args.size_scale, args.people_scale, not args.no_sampled_risk)
    found = noisy_search(
        args.runs, args.draws, args.delay, args.judging, args.settle_after_clear, noise, args.head_start, args.drive_on
    )
    benchlib.report_draws(
        "Move search on a noisy belief",
        args.json,
        {
            "runs": args.runs,
            "draws": args.draws,
            "delay": args.delay,
            "judging": args.judging,
            "settle_after_clear": args.settle_after_clear,
            "head_start": args.head_start,
            "drive_on": args.drive_on,
            "noise": {
                "object_scale": noise.objects,
                "size_scale": noise.size,
                "people_scale": noise.people,
                "sampled_risk": noise.sampled_risk,
            },
        },
        found,
    )


if __name__ == "__main__":
    main()
