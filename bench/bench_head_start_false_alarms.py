"""What a head start does in a false alarm: in the ground truth of recorded runs' false alarms, does it trip anyone?

A head start is judged harmless *given* the fall the danger foresees; in a false alarm that fall never
comes, and a robot driving a head start may send a person who would have passed the obstacle round
itself and into it. This bench takes every false alarm of the recorded runs (a trial flagged risky
that collides in no truth with the robot idle) at even odds or more, as the action agent asks for a
head start (``HEAD_START_RISK``, the run's own Algorithm 1 probability at the flag; ``--all-odds``
takes them all), draws ``--draws`` beliefs at the flag's moment as ``bench_move_search_noisy.py``
does, imagines Algorithm 1's danger on each for every person walking, and runs the search with a head
start. The search's moves are then commanded in the ground truth as the search sends them, two ways:
as the action agent does (a head start ends with braking when no move is chosen, if braking is
harmless) and driving the head start on instead. Any collision there is one the robot caused.

    python bench/bench_head_start_false_alarms.py [--draws N] [--all-odds] [--json PATH] [RUN ...]
"""

from __future__ import annotations

import json
from dataclasses import replace
from functools import partial

import numpy as np

import benchlib
from agents.caregiving.model import move_search
from agents.caregiving.model.planner import GridPlanner
from agents.caregiving.model.scenario import Scenario, load_scenario
from agents.caregiving.model.service import serve_one
from agents.caregiving.model.verdict import SearchResult
from bench_move_search import RECORDED, THRESHOLD
from bench_move_search_noisy import add_belief_arguments
from bridges.experiment.beliefs import Noise, belief, perception_uncertainty
from bridges.experiment.oracle import idle_run, world_at
from bridges.experiment.perfect_belief import Gazes, outcome_in_truth, spec_on
from bridges.world.bridge import trial_for

RUNS = (
    "experiment1_head_start_first",
    "experiment1_seed73019_head_start_first",
    "experiment1_head_start",
    "experiment1_knows",
    "experiment1_seed48611_head_start",
    "experiment1_seed90210_head_start",
    "scenario_doubled_noise_seed11_head_start_first",
    "heldout/hurried_walker_seed6_head_start_first",
    "heldout/face_to_face_seed3_head_start_first",
    "heldout/three_residents_seed11_head_start_first",
    "heldout/bathroom_basket_seed11",
    "heldout/large_lounge_seed11_head_start",
)


def false_alarms(runs: list[str], draws: int, delay: float, judging: float, all_odds: bool) -> dict[str, object]:
    """Search ``draws`` beliefs of every false alarm with a head start; the collisions its moves cause in the truth."""
    alarms = beliefs = flagged = leads = chosen = 0
    caused_braking = caused_driving_on = 0
    causing: dict[str, list[str]] = {"braking": [], "driving_on": []}
    for run in runs:
        recorded = json.loads((RECORDED / f"{run}.json").read_text())
        scenario = load_scenario(recorded.get("scenario_file", recorded["scenario"]))
        planner = GridPlanner(scenario.scene().bounds)
        for t in recorded["per_trial"]:
            odds = t.get("risk_probability") or 0.0
            if not t["predicted"] or t["truly_risky"] or t["discarded"] or t["risk_at_time"] is None:
                continue
            if odds < move_search.HEAD_START_RISK and not all_odds:
                continue
            alarms += 1
            trial, at = trial_for(scenario, recorded["seed"], t["index"]), t["risk_at_time"]
            idle = idle_run(trial, planner)
            now = world_at(trial, at, planner)
            walking = list(now.walking())
            rng, origins = np.random.default_rng([t["index"], draws]), np.random.default_rng([t["index"], draws, 1])
            for k in range(draws):
                beliefs += 1
                scene = belief(now.scene(), trial.sensors, at, Noise(), rng, origins)
                spec = spec_on(scene, idle, now, delay, Gazes.ANY_CLASS, people=walking)
                if spec is None:
                    continue
                flagged += 1
                result = move_search.search(
                    scene,
                    spec,
                    partial(serve_one, scene),
                    perception_uncertainty(scene, trial.sensors, at, k),
                    THRESHOLD,
                    24,
                    judging=judging,
                    head_start=lambda _lead: None,
                )
                leads += result.lead is not None
                chosen += result.chosen is not None
                name = f"{run}#{t['index']}/{k}"
                if _collides(trial, at, planner, delay, judging, result):
                    caused_braking += 1
                    causing["braking"].append(name)
                if _collides(trial, at, planner, delay, judging, replace(result, halt=None)):
                    caused_driving_on += 1
                    causing["driving_on"].append(name)
    return {
        "false_alarms": alarms,
        "beliefs": beliefs,
        "flagged": flagged,
        "head_starts": leads,
        "chosen": chosen,
        "caused_braking": caused_braking,
        "caused_driving_on": caused_driving_on,
        "causing": causing,
    }


def _collides(
    trial: Scenario, at: float, planner: GridPlanner, delay: float, judging: float, result: SearchResult
) -> bool:
    outcome = outcome_in_truth(trial, at, planner, delay, judging, result)
    return outcome is not None and outcome.collided


def main() -> None:
    p = benchlib.parser("bench_head_start_false_alarms", __doc__.splitlines()[0])
    add_belief_arguments(p, RUNS, "false alarm", 0.05)
    p.add_argument("--all-odds", action="store_true", help="false alarms below even odds too (no head start live)")
    args = p.parse_args()
    found = false_alarms(args.runs, args.draws, args.delay, args.judging, args.all_odds)
    benchlib.print_table("Head starts in false alarms", [(k, v) for k, v in found.items() if k != "causing"])
    print("causing:", found["causing"])
    benchlib.write_json(
        args.json,
        {"runs": args.runs, "draws": args.draws, "delay": args.delay, "judging": args.judging, **found},
    )


if __name__ == "__main__":
    main()
