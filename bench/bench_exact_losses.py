"""Why Algorithm 2 loses oracle-saveable trials even on exact beliefs: each trial a closed loop lost, classified.

``bench_closed_loop.py --belief-noise none`` runs the stack's loop on the exact
scene (perception's uncertainty still sampled) and lists the saveable trials it
lost. For each, this bench takes every move of the oracle's broad set that saves
the trial in the truth when commanded ``--delay`` plus two judgements after the
danger showed (the oracle commands at once), judges each as the search would
(:func:`agents.caregiving.model.judging.judge_move`, at most ``--max-moves``, told what
befalls the bystanders with the robot as it is, :func:`~agents.caregiving.model.judging.as_it_is`), and
puts the trial in the first class that fits:

* ``late``: no move saves it commanded that late;
* ``missed``: a saving move is safe in the imagination (so the search would send
  it), but the search did not judge it or the loop sent another;
* ``risky``: saving moves are clear in the imagination, each with a sampled risk at
  or over the threshold;
* ``refused: ...``: every saving move is refused, by the commonest reason among them
  (a pass within the margin round the robot, someone walking into the robot or into
  an obstacle at a gaze class imagined, a bystander's fall or sampled risk, a pose
  the robot cannot reach);
* ``no danger``: the look finds no danger to search for.

    python bench/bench_exact_losses.py CLOSED_LOOP_JSON [--delay S] [--judging S] [--max-moves N] [--json PATH]
"""

from __future__ import annotations

import json
import time
from collections import Counter
from dataclasses import replace
from functools import partial
from pathlib import Path

import benchlib
from agents.caregiving.model.judging import as_it_is, judge_move
from agents.caregiving.model.search_spec import SearchSpec
from agents.caregiving.model.service import serve_one
from agents.caregiving.model.verdict import Verdict
from bench_move_search import THRESHOLD, Case, cases
from bridges.experiment.beliefs import perception_uncertainty
from bridges.experiment.oracle import saving_moves
from bridges.experiment.perfect_belief import Gazes, perfect_belief_spec


def refusal(verdict: Verdict, spec: SearchSpec, robot: str | None) -> str:
    """Why a move that is not clear was refused, by its first fall."""
    if not verdict.falls:
        return "the robot cannot reach it" if "reach" in verdict.reason else "not imagined"
    fall = verdict.falls[0]
    if fall.person not in {d.person for d in spec.dangers}:
        return "a bystander falls or may"
    if fall.close_pass:
        return "passes within the margin round the robot"
    if fall.obstacle == robot:
        return "walks into the robot"
    return "stuck" if fall.obstacle is None else "walks into an obstacle"


def classify(case: Case, delay: float, judging: float, max_moves: int) -> tuple[str, int]:
    """The class of one lost trial (see the module documentation), and how many moves save it commanded late."""
    found = perfect_belief_spec(case.trial, case.at, case.planner, delay, Gazes.ANY_CLASS)
    if found is None:
        return "no danger", 0
    scene, spec = found
    commanded = delay + 2 * judging
    saving = saving_moves(case.trial, case.at + commanded, case.planner)
    if not saving:
        return "late", 0
    uncertainty = perception_uncertainty(scene, case.trial.sensors, case.at, 0)  # as the loop's first look
    imagine = partial(serve_one, scene)
    at = as_it_is(replace(spec, delay=commanded), imagine, scene, uncertainty)  # as a search told it
    verdicts = [judge_move(at, move, imagine, uncertainty, scene.robot_name) for move in saving[:max_moves]]
    if any(v.safe(THRESHOLD) for v in verdicts):
        return "missed", len(saving)
    if any(v.clear for v in verdicts):
        return "risky", len(saving)
    reasons = Counter(refusal(v, spec, scene.robot_name) for v in verdicts)
    return f"refused: {reasons.most_common(1)[0][0]}", len(saving)


def main() -> None:
    p = benchlib.parser("bench_exact_losses", __doc__.splitlines()[0])
    p.add_argument("closed_loop", type=Path, help="a bench_closed_loop.py JSON run with --belief-noise none")
    p.add_argument("--delay", type=float, default=0.05, help="seconds from the danger showing to the first command")
    p.add_argument("--judging", type=float, default=0.008, help="seconds a judgement takes")
    p.add_argument("--max-moves", type=int, default=40, help="saving moves judged at most per trial")
    args = p.parse_args()
    loop = json.loads(args.closed_loop.read_text())
    lost = set(loop["lost_draws"])
    started = time.perf_counter()
    trials: dict[str, dict[str, object]] = {}
    for case in cases(loop["runs"]):
        key = f"{case.run}#{case.index}"
        if case.saveable and key in lost:
            kind, saving = classify(case, args.delay, args.judging, args.max_moves)
            trials[key] = {"class": kind, "saving_moves": saving}
            print(f"{key}: {kind} ({saving} saving moves)", flush=True)
    classes = Counter(str(t["class"]) for t in trials.values())
    print(f"lost with exact beliefs: {len(trials)}")
    for kind, n in classes.most_common():
        print(f"  {kind:<48} {n:>4}")
    settings = {"closed_loop": str(args.closed_loop), "delay": args.delay, "judging": args.judging}
    benchlib.write_json(
        args.json,
        settings
        | {
            "max_moves": args.max_moves,
            "lost": len(trials),
            "classes": dict(classes.most_common()),
            "seconds": round(time.perf_counter() - started, 1),
            "trials": trials,
        },
    )


if __name__ == "__main__":
    main()
