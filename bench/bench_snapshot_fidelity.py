"""How well an imagination started from the exact scene foretells the truth, with the robot idle, in rooms of several
people.

Everything the robot imagines starts from a snapshot: where each person stands and heads, what they have seen,
where they remember the robot. The world's people carry more than that: the route they planned and where they
last saw each other, which sets when they next re-plan round someone. For every trial of the runs named that the
run flagged, this starts the world model from the exact scene at the moment the run first saw a danger, each
person walking to their true target at their true gaze, knowing the objects and the robot they have truly seen
and the robot where they remember it (as :func:`bridges.experiment.perfect_belief.walks_on` gives them: all a
perfect perception could tell), runs it with the robot idle and compares who walks into what with the truth's
own continuation. A disagreement is an outcome no belief, however exact, foretells from a snapshot. With no run
named, it takes one recorded run of each room and seed with two people or more.

    python bench/bench_snapshot_fidelity.py [--json PATH] [RUN ...]
"""

from __future__ import annotations

import time
from collections import Counter
from concurrent.futures import ProcessPoolExecutor
from typing import Any

import benchlib
from agents.caregiving.model.world_model import World
from bench_move_search import cases, every_room, recorded_scenario
from bridges.experiment.oracle import world_at
from bridges.experiment.perfect_belief import walks_on

#: Seconds the truth and the imagination run on past the danger's moment.
HORIZON = 30.0


def several_people(recorded: dict[str, Any]) -> bool:
    """Whether a recorded run's room holds two people or more, and the run flagged a trial."""
    flagged = any(t.get("risk_at_time") is not None for t in recorded["per_trial"])
    return flagged and len(recorded_scenario(recorded).people) > 1


def falls(world: World) -> list[tuple[str, str]]:
    """Who walked into what in ``world``, run to its end."""
    return sorted((c.person, c.obstacle) for c in world.outcome().collisions)


def compare_run(run: str) -> list[dict[str, Any]]:
    """Every flagged trial of ``run``: the truth's falls and those imagined from the exact snapshot."""
    found = []
    for case in cases([run], lambda t: True):
        now = world_at(case.trial, case.at, case.planner)
        scene = now.scene()
        imagined = World(scene, walks_on(scene, now, now.walking()), planner=case.planner)
        truth = now.fork()
        truth.run(truth.time + HORIZON)
        imagined.run(imagined.time + HORIZON)
        found.append({"case": f"{run}#{case.index}", "truth": falls(truth), "imagined": falls(imagined)})
    return found


def room_of(case: str) -> str:
    """The room of a trial named ``run#index``, its run's name up to the seed."""
    return case.split("#")[0].split("_seed")[0]


def main() -> None:
    p = benchlib.parser("bench_snapshot_fidelity", __doc__.splitlines()[0])
    p.add_argument("runs", nargs="*", help="recorded runs (docs/results/RUN.json); default: every room of several")
    args = p.parse_args()
    runs = args.runs or every_room(several_people)
    started = time.perf_counter()
    with ProcessPoolExecutor(max_workers=2) as pool:
        trials = [t for ts in pool.map(compare_run, runs) for t in ts]
    differ = [t for t in trials if t["truth"] != t["imagined"]]
    by_room = Counter(room_of(t["case"]) for t in trials)
    differ_by_room = Counter(room_of(t["case"]) for t in differ)
    rows = [(room, f"{differ_by_room[room]} of {n} differ") for room, n in sorted(by_room.items())]
    benchlib.print_table(f"Idle outcome from the exact snapshot against the truth ({len(runs)} runs)", rows)
    for t in differ:
        print(f"  {t['case']}: truth {t['truth']}, imagined {t['imagined']}")
    benchlib.write_json(
        args.json,
        {
            "runs": runs,
            "trials": len(trials),
            "differ": len(differ),
            "by_room": {room: {"trials": n, "differ": differ_by_room[room]} for room, n in sorted(by_room.items())},
            "differing": differ,
            "seconds": round(time.perf_counter() - started, 1),
        },
    )


if __name__ == "__main__":
    main()
