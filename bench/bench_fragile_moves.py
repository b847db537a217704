"""Fragile moves: does a move chosen on a noisy belief that fails on beliefs near it fail in the truth, and would
searching on for one that does not save more?

For every oracle-saveable trial of the runs named, one belief is drawn at the moment the run first saw the
danger (as ``bench_move_search_noisy.py`` draws it, every error of the sensor model) and searched. The chosen
move is judged again, at the moment it was judged for, on ``--near`` beliefs drawn around that belief (the
same sensor model, the belief taken as the truth): a room perception could hold as well. The move is
*fragile* when one of them refuses it. Every chosen move is commanded in the ground truth as the search
sends it, and the bench counts how many save the person, by how many of the near beliefs refused them.

For each fragile move it then judges the candidates that follow it in the search's order, up to
``--search-on`` more, each one as switching from the fragile move sent when it was found (the robot drives
the fragile move meanwhile), and stops at the first that is safe on the belief and on every near belief
(its check costs ``--near`` judgements more). That move, if any, is commanded in the truth as the switch,
and the bench counts the trials it saves that the fragile move lost and the other way round.

    python bench/bench_fragile_moves.py [--near K] [--search-on N] [--json PATH] [RUN ...]
"""

from __future__ import annotations

from collections import Counter
from dataclasses import replace
from functools import partial
from itertools import islice

import numpy as np

import benchlib
from agents.caregiving.model import move_search
from agents.caregiving.model.candidates import candidates
from agents.caregiving.model.judging import judge_move
from agents.caregiving.model.move_search import DEFAULT_MAX_MOVES
from agents.caregiving.model.scene import Scene
from agents.caregiving.model.search_spec import SearchSpec
from agents.caregiving.model.service import serve_one
from agents.caregiving.model.uncertainty import Uncertainty
from agents.caregiving.model.verdict import Verdict
from bench_move_search import THRESHOLD, Case, every_room
from bench_move_search_noisy import drawn_beliefs
from bridges.experiment.beliefs import Noise, belief
from bridges.experiment.oracle import world_at
from bridges.experiment.perfect_belief import saved_in_truth


class Near:
    """Beliefs drawn around one belief, and whether a move judged on the belief holds on each of them."""

    def __init__(self, case: Case, scene: Scene, spec: SearchSpec, uncertainty: Uncertainty, count: int) -> None:
        rng, origins = np.random.default_rng([case.index, 2]), np.random.default_rng([case.index, 2, 1])
        noise = Noise()
        self.scenes = [belief(scene, case.trial.sensors, case.at, noise, rng, origins) for _ in range(count)]
        self.spec, self.uncertainty, self.robot = spec, uncertainty, scene.robot_name

    def refusing(self, move_verdict: Verdict, delay: float) -> int:
        """How many of the near beliefs refuse the move of ``move_verdict``, judged with the robot starting after ``delay``."""
        spec = replace(self.spec, delay=delay)
        judged = (
            judge_move(spec, move_verdict.move, partial(serve_one, s), self.uncertainty, self.robot)
            for s in self.scenes
        )
        return sum(not v.clear for v in judged)


def fragile_moves(
    runs: list[str], near: int, search_on: int, delay: float, judging: float
) -> dict[str, dict[str, int]]:
    """The counts the module docstring describes."""
    by_refusals: Counter[str] = Counter()
    switched: Counter[str] = Counter()
    for drawn in drawn_beliefs(runs, 1, delay, Noise()):
        case, scene, spec, uncertainty = drawn.case, drawn.scene, drawn.spec, drawn.uncertainty
        if spec is None:
            continue
        found = move_search.search(
            scene, spec, partial(serve_one, scene), uncertainty, THRESHOLD, DEFAULT_MAX_MOVES, judging=judging
        )
        chosen = found.chosen
        if chosen is None or chosen.move is None:
            continue
        saved = saved_in_truth(case.trial, case.at, case.planner, delay, judging, found)
        slot = found.verdicts.index(chosen) + 1
        around = Near(case, scene, spec, uncertainty, near)
        refusals = around.refusing(chosen, delay + judging * slot)
        by_refusals[f"{refusals} {'saved' if saved else 'lost'}"] += 1
        if refusals == 0:
            continue
        # Search on past the fragile move, each candidate judged as a switch from it.
        verdicts: list[Verdict] = []
        generated = candidates(scene, spec.dangers, verdicts, spec.delay, judging)
        under_way = replace(spec, current=chosen.move)
        checks, robust = 1, None
        for k, move in enumerate(islice(generated, slot + search_on), start=1):
            if k <= len(found.verdicts):
                verdicts.append(found.verdicts[k - 1])
                continue
            at = delay + judging * (k + near * checks)
            v = judge_move(replace(under_way, delay=at), move, partial(serve_one, scene), uncertainty, scene.robot_name)
            verdicts.append(v)
            if v.safe(THRESHOLD):
                checks += 1
                if around.refusing(v, at) == 0:
                    robust = v, at
                    break
        if robust is None:
            switched[f"none found, {'saved' if saved else 'lost'}"] += 1
            continue
        world = world_at(case.trial, case.at + delay + judging * found.judged, case.planner)
        world.command_robot(chosen.move)
        world.advance(case.at + robust[1])
        world.command_robot(robust[0].move)
        ok = not world.run(world.time + 30.0).collided
        switched[f"switched: {'saved' if saved else 'lost'} -> {'saved' if ok else 'lost'}"] += 1
    return {"by_refusals": dict(sorted(by_refusals.items())), "fragile_searched_on": dict(sorted(switched.items()))}


def main() -> None:
    p = benchlib.parser("bench_fragile_moves", __doc__.splitlines()[0])
    p.add_argument("runs", nargs="*", help="recorded runs (docs/results/RUN.json; default: one of each room and seed)")
    p.add_argument("--delay", type=float, default=0.05, help="seconds from the danger to the robot's start")
    p.add_argument("--judging", type=float, default=0.008, help="seconds more per candidate judged")
    p.add_argument("--near", type=int, default=3, help="beliefs drawn around the belief a move is judged again on")
    p.add_argument("--search-on", type=int, default=16, help="candidates judged past a fragile move at most")
    args = p.parse_args()
    runs = args.runs or every_room()
    found = fragile_moves(runs, args.near, args.search_on, args.delay, args.judging)
    for title, counts in found.items():
        benchlib.print_table(title, list(counts.items()))
    settings = {
        "runs": runs,
        "near": args.near,
        "search_on": args.search_on,
        "delay": args.delay,
        "judging": args.judging,
    }
    benchlib.write_json(args.json, {**settings, **found})


if __name__ == "__main__":
    main()
