"""How robust the oracle's saves are: which saveable trials of recorded runs some move still saves a little later,
at a slightly different gaze, or in a room that differs from the truth by one sigma of the sensors' error.

For every oracle-saveable trial of the runs named (the ``wm experiment`` JSON files
in ``docs/results/``), every move of the oracle's broad set that saves it when
commanded at the moment the run first saw the danger (``oracle.saving_moves``)
is commanded again ``--later`` seconds later (each of them), and with every
person's true gaze ``--gaze`` degrees higher and lower. A trial is *robust* when
one move saves it under all of these. A trial saved only by moves that fail a
few tens of milliseconds later, or at a gaze one degree off, can be saved only
by acting at once on an exact guess of the person's gaze, which no pipeline does.

A robust trial is also *robust to sensing* when one of its robust moves saves it too in each
of the rooms the sensors cannot tell from the truth at that moment (:func:`sensed`): every
object shifted by one sigma of the tracker's error in its position, in each of four
directions; every person likewise; and every object one sigma of the size bias larger and
smaller. A move that saves the truth but not these saves by a margin below what perception
can know, and a search on perception's belief accepts it only by chance.

    python bench/bench_oracle_robustness.py [--later S ...] [--gaze DEG] [--json PATH] [RUN ...]
"""

from __future__ import annotations

from dataclasses import replace

import benchlib
from agents.caregiving.model.scenario import ObjectSpec, Scenario
from bench_move_search import cases
from bridges.experiment.beliefs import sigmas, size_error
from bridges.experiment.oracle import saves, saving_moves, world_at

#: The four directions each one-sigma shift of a position is tried in.
DIRECTIONS = ((1.0, 0.0), (-1.0, 0.0), (0.0, 1.0), (0.0, -1.0))


def gazed(trial: Scenario, degrees: float) -> Scenario:
    """The trial with every person's true gaze ``degrees`` higher."""
    return replace(trial, people=tuple(replace(p, gaze_deg=p.gaze_deg + degrees) for p in trial.people))


def sensed(trial: Scenario, at: float) -> list[Scenario]:
    """The rooms one sigma of the sensors' error at ``at`` s away from ``trial``: objects shifted, people shifted,
    objects larger and smaller (the size bias is uniform within the sensor's bound, so its sigma is bound / sqrt 3)."""
    object_sigma, person_sigma = sigmas(trial.sensors, at)
    size_sigma = size_error(trial.sensors) / 3**0.5

    def moved_objects(dx: float, dy: float) -> Scenario:
        return replace(trial, objects=tuple(replace(o, x=o.x + dx, y=o.y + dy) for o in trial.objects))

    def moved_people(dx: float, dy: float) -> Scenario:
        return replace(trial, people=tuple(replace(p, x=p.x + dx, y=p.y + dy) for p in trial.people))

    def scaled(o: ObjectSpec, f: float) -> ObjectSpec:
        return replace(o, radius=o.radius * f, length=o.length * f, width=o.width * f)

    rooms = [moved_objects(dx * object_sigma, dy * object_sigma) for dx, dy in DIRECTIONS]
    rooms += [moved_people(dx * person_sigma, dy * person_sigma) for dx, dy in DIRECTIONS]
    rooms += [replace(trial, objects=tuple(scaled(o, 1 + f) for o in trial.objects)) for f in (size_sigma, -size_sigma)]
    return rooms


def robustness(runs: list[str], later: list[float], gaze: float) -> list[dict[str, object]]:
    """Per saveable trial: its saving moves, how many still save under every perturbation, and whether it was
    prevented in the run."""
    trials: list[dict[str, object]] = []
    for case in cases(runs):
        if not case.saveable:
            continue
        trial, at, planner = case.trial, case.at, case.planner
        moves = saving_moves(trial, at, planner)
        worlds = [world_at(trial, at + s, planner) for s in later]
        worlds += [world_at(gazed(trial, d), at, planner) for d in (-gaze, gaze)]
        robust = [m for m in moves if all(saves(w, m) for w in worlds)]
        rooms = [world_at(room, at, planner) for room in sensed(trial, at)] if robust else []
        trials.append(
            {
                "trial": f"{case.run}#{case.index}",
                "saving_moves": len(moves),
                "robust_moves": len(robust),
                "robust_to_sensing_moves": sum(all(saves(w, m) for w in rooms) for m in robust),
                "prevented": not case.collided,
            }
        )
    return trials


def summary(trials: list[dict[str, object]]) -> dict[str, int]:
    """How many saveable trials are robust, and how many of them and of the others were prevented."""
    robust = [t for t in trials if t["robust_moves"]]
    sensing = [t for t in robust if t["robust_to_sensing_moves"]]
    return {
        "saveable": len(trials),
        "robust": len(robust),
        "prevented_of_robust": sum(bool(t["prevented"]) for t in robust),
        "prevented_of_the_others": sum(bool(t["prevented"]) for t in trials if not t["robust_moves"]),
        "robust_to_sensing": len(sensing),
        "prevented_of_robust_to_sensing": sum(bool(t["prevented"]) for t in sensing),
    }


def main() -> None:
    p = benchlib.parser("bench_oracle_robustness", __doc__.splitlines()[0])
    p.add_argument("runs", nargs="*", default=["experiment1_doubted"], help="recorded runs (docs/results/RUN.json)")
    p.add_argument("--later", type=float, nargs="+", default=[0.05, 0.1], help="seconds later to command each move")
    p.add_argument("--gaze", type=float, default=1.0, help="degrees to move each person's gaze up and down")
    args = p.parse_args()
    trials = robustness(args.runs, args.later, args.gaze)
    figures = summary(trials)
    benchlib.print_table("Robustness of the oracle's saves", list(figures.items()))
    for t in trials:
        print(
            f"  {t['trial']}: {t['robust_moves']} of {t['saving_moves']} saving moves robust "
            f"({t['robust_to_sensing_moves']} to sensing), prevented {t['prevented']}"
        )
    benchlib.write_json(
        args.json, {"runs": args.runs, "later": args.later, "gaze": args.gaze, **figures, "trials": trials}
    )


if __name__ == "__main__":
    main()
