"""People saved, person by person, in recorded runs of rooms with several people: who fell with the robot idle,
whom some move could have saved, alone or with the others, and whom the robot saved.

A trial counts as prevented only when nobody falls, and as saveable only when one move saves everyone in
it. Where two people fall in different places that may be more than one robot can do, while each of them
may still be saved alone. For every truly risky trial of the runs named, this runs the oracle again at the
moment the run first saw a danger (``oracle.oracle``'s ``saveable_people``: the people some move saves
without tripping anyone who would not fall anyway), and counts, from the run's own record, who fell with
the robot acting. Runs written before ``wm experiment`` reported people (``person_prevention_rate``) are
scored here the same way. With no run named, it takes one recorded run of each room and seed with two
people or more and a truly risky trial (48 runs, 725 trials: about 18 minutes on two cores).

    python bench/bench_people_saved.py [--json PATH] [RUN ...]
"""

from __future__ import annotations

import json
from concurrent.futures import ProcessPoolExecutor
from typing import Any

import benchlib
from agents.caregiving.model.planner import GridPlanner
from bench_move_search import RECORDED, every_room, recorded_scenario
from bridges.experiment.oracle import idle_run, oracle
from bridges.world.bridge import trial_for


def several_people(recorded: dict[str, Any]) -> bool:
    """Whether a recorded run is of a room with two people or more and holds a truly risky trial."""
    return len(recorded_scenario(recorded).people) >= 2 and any(t["truly_risky"] for t in recorded["per_trial"])


def scored_trial(job: tuple[str, int]) -> dict[str, Any]:
    """One truly risky trial of a run: who fell idle, whom some move saves, who fell with the robot acting."""
    run, index = job
    recorded = json.loads((RECORDED / f"{run}.json").read_text())
    t = next(t for t in recorded["per_trial"] if t["index"] == index)
    scenario = recorded_scenario(recorded)
    trial = trial_for(scenario, recorded["seed"], index)
    planner = GridPlanner(scenario.scene().bounds)
    fallers = {c.person for c in idle_run(trial, planner).outcome().collisions}
    verdict = oracle(trial, t["risk_at_time"], planner)
    fell = {c["person"] for c in t["collisions"]}
    return {
        "run": run,
        "index": index,
        "fallers": sorted(fallers),
        "saveable_people": sorted(verdict.saveable_people),
        "saved": sorted(fallers - fell),
        "trial_saveable": verdict.saveable,
        "trial_prevented": not fell,
    }


def summary(trials: list[dict[str, Any]]) -> dict[str, int]:
    """Trials and people: at risk, saveable, saved, and saved of the saveable."""
    saved_of_saveable = sum(len(set(t["saved"]) & set(t["saveable_people"])) for t in trials)
    return {
        "trials_truly_risky": len(trials),
        "trials_saveable": sum(t["trial_saveable"] for t in trials),
        "trials_prevented_of_saveable": sum(t["trial_saveable"] and t["trial_prevented"] for t in trials),
        "people_at_risk": sum(len(t["fallers"]) for t in trials),
        "people_saveable": sum(len(t["saveable_people"]) for t in trials),
        "people_saved": sum(len(t["saved"]) for t in trials),
        "people_saved_saveable": saved_of_saveable,
    }


def main() -> None:
    p = benchlib.parser("bench_people_saved", __doc__.splitlines()[0])
    p.add_argument(
        "runs", nargs="*", help="recorded runs (docs/results/RUN.json); default: every room of several people"
    )
    args = p.parse_args()
    runs = args.runs or every_room(several_people)
    jobs = [
        (run, t["index"])
        for run in runs
        for t in json.loads((RECORDED / f"{run}.json").read_text())["per_trial"]
        if t["truly_risky"] and t["risk_at_time"] is not None
    ]
    with ProcessPoolExecutor(max_workers=2) as pool:
        trials = list(pool.map(scored_trial, jobs))
    figures = summary(trials)
    benchlib.print_table("People saved, person by person", list(figures.items()))
    for run in runs:
        mine = summary([t for t in trials if t["run"] == run])
        print(
            f"  {run}: trials {mine['trials_prevented_of_saveable']} of {mine['trials_saveable']} saveable; people "
            f"{mine['people_saved_saveable']} of {mine['people_saveable']} saveable "
            f"({mine['people_saved']} of {mine['people_at_risk']} at risk)"
        )
    benchlib.write_json(args.json, {"runs": runs, **figures, "trials": trials})


if __name__ == "__main__":
    main()
