"""How robust the oracle's saves are: which saveable trials of recorded runs some move still saves a little later
or at a slightly different gaze.

For every oracle-saveable trial of the runs named (the ``wm experiment`` JSON files
in ``docs/results/``), every move of the oracle's broad set that saves it when
commanded at the moment the run first saw the danger (``oracle.saving_moves``)
is commanded again ``--later`` seconds later (each of them), and with every
person's true gaze ``--gaze`` degrees higher and lower. A trial is *robust* when
one move saves it under all of these. A trial saved only by moves that fail a
few tens of milliseconds later, or at a gaze one degree off, can be saved only
by acting at once on an exact guess of the person's gaze, which no pipeline does.

    python bench/bench_oracle_robustness.py [--later S ...] [--gaze DEG] [--json PATH] RUN ...
"""

from __future__ import annotations

from dataclasses import replace

import benchlib
from agents.caregiving.model.scenario import Scenario
from bench_move_search import cases
from bridges.experiment.oracle import saves, saving_moves, world_at


def gazed(trial: Scenario, degrees: float) -> Scenario:
    """The trial with every person's true gaze ``degrees`` higher."""
    return replace(trial, people=tuple(replace(p, gaze_deg=p.gaze_deg + degrees) for p in trial.people))


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
        trials.append(
            {
                "trial": f"{case.run}#{case.index}",
                "saving_moves": len(moves),
                "robust_moves": len(robust),
                "prevented": not case.collided,
            }
        )
    return trials


def summary(trials: list[dict[str, object]]) -> dict[str, int]:
    """How many saveable trials are robust, and how many of them and of the others were prevented."""
    robust = [t for t in trials if t["robust_moves"]]
    return {
        "saveable": len(trials),
        "robust": len(robust),
        "prevented_of_robust": sum(bool(t["prevented"]) for t in robust),
        "prevented_of_the_others": sum(bool(t["prevented"]) for t in trials if not t["robust_moves"]),
    }


def main() -> None:
    p = benchlib.parser("bench_oracle_robustness", __doc__.splitlines()[0])
    p.add_argument("runs", nargs="+", help="recorded runs (docs/results/RUN.json)")
    p.add_argument("--later", type=float, nargs="+", default=[0.05, 0.1], help="seconds later to command each move")
    p.add_argument("--gaze", type=float, default=1.0, help="degrees to move each person's gaze up and down")
    args = p.parse_args()
    trials = robustness(args.runs, args.later, args.gaze)
    figures = summary(trials)
    benchlib.print_table("Robustness of the oracle's saves", list(figures.items()))
    for t in trials:
        print(
            f"  {t['trial']}: {t['robust_moves']} of {t['saving_moves']} saving moves robust, prevented {t['prevented']}"
        )
    benchlib.write_json(
        args.json, {"runs": args.runs, "later": args.later, "gaze": args.gaze, **figures, "trials": trials}
    )


if __name__ == "__main__":
    main()
