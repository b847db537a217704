"""The first candidate after a head start: its verdict read off the head start's imagination, against judged again.

After a head start is sent, the search's first candidate is the head start's own move driven on, and
its verdict is read off the head start's answers (``judging.driven_on``) instead of imagined
again (``judging.judge_move``). For each truly risky trial of the runs named (the ``wm experiment``
JSON files in ``docs/results/``), at the moment the run first saw the danger, with perfect belief and
the risk sampled as the action agent samples it round the scenario's sensor model, the head start is
judged; where it is harmless, the first candidate is both judged and read off. The bench counts the
verdicts that differ (there should be none) and times the two after the head start's judgement, with
the walks it planned remembered, as in a live search (the baseline is the judgement, in the same run).

    python bench/bench_read_off.py [--delay S] [--judging S] [--json PATH] [RUN ...]
"""

from __future__ import annotations

import time
from collections.abc import Callable
from dataclasses import replace
from functools import partial
from typing import TypeVar

import benchlib
from agents.caregiving.model.candidates import candidates
from agents.caregiving.model.imagine import planner_for
from agents.caregiving.model.judging import driven_on, judge_lead, judge_move
from agents.caregiving.model.move_choice import NoWorse
from agents.caregiving.model.service import serve_one
from bench_move_search import THRESHOLD, cases, search_spec
from bridges.experiment.beliefs import perception_uncertainty

RUNS = (
    "experiment1_knows",
    "heldout/face_to_face_seed3_knows",
    "heldout/three_residents_seed11",
    "heldout/hurried_walker_seed6_knows",
    "heldout/corner_flat_seed3_knows",
    "heldout/ward_footstool_seed11_head_start_first",
)
T = TypeVar("T")


def timed(call: Callable[[], T]) -> tuple[T, float]:
    """``call()`` and its wall time in milliseconds."""
    start = time.perf_counter()
    result = call()
    return result, (time.perf_counter() - start) * 1e3


def compare(runs: list[str], delay: float, judging: float) -> dict[str, object]:
    """Judge and read off the first candidate of every danger whose head start is harmless."""
    dangers = leads = differ = 0
    judged_ms: list[float] = []
    read_ms: list[float] = []
    for case in cases(runs):
        found = search_spec(case, delay)
        if found is None:
            continue
        scene, spec = found
        first = next(candidates(scene, spec.dangers), None)
        if first is None:
            continue
        dangers += 1
        imagine = partial(serve_one, scene)
        u = perception_uncertainty(scene, case.trial.sensors, case.at, case.index)
        lead_spec = replace(spec, delay=spec.delay + judging)
        planner_for(scene.bounds).forget_plans()  # a live search starts with none of its walks planned
        lead, answers = judge_lead(lead_spec, first, imagine, u, scene.robot_name)
        if not NoWorse(spec, imagine, u, THRESHOLD, scene.robot_name).harmless(lead):
            continue
        leads += 1
        driven = replace(lead_spec, lead=first, lead_for=judging)
        read, read_time = timed(partial(driven_on, scene, spec, first, answers, u))
        judged, judge_time = timed(partial(judge_move, driven, first, imagine, u, scene.robot_name))
        differ += read != judged
        judged_ms.append(judge_time)
        read_ms.append(read_time)
    return {
        "dangers": dangers,
        "head_starts": leads,
        "verdicts_differ": differ,
        "judged": benchlib.percentiles(judged_ms),
        "read_off": benchlib.percentiles(read_ms),
        "judged_over_read_off_mean": sum(judged_ms) / max(sum(read_ms), 1e-9),
    }


def main() -> None:
    p = benchlib.parser("bench_read_off", __doc__.splitlines()[0])
    p.add_argument("runs", nargs="*", default=list(RUNS), help="recorded runs (docs/results/RUN.json)")
    p.add_argument("--delay", type=float, default=0.05, help="seconds from the danger to the robot's start")
    p.add_argument("--judging", type=float, default=0.02, help="seconds of the head start's own judgement")
    args = p.parse_args()
    figures = compare(args.runs, args.delay, args.judging)
    benchlib.print_table("The first candidate after a head start: judged, and read off", list(figures.items()))
    benchlib.write_json(args.json, {"runs": args.runs, "delay": args.delay, "judging": args.judging, **figures})


if __name__ == "__main__":
    main()
