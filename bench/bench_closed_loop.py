"""Algorithm 2 in a closed loop on noisy beliefs, on every oracle-saveable trial of recorded runs.

``bench_move_search_noisy.py`` runs the first search of each danger. Live, the
action agent looks again each time Algorithm 1 rewrites the danger while it
lasts, and keeps, doubts or replaces the move under way. This bench runs
:func:`bridges.experiment.closed_loop.closed_loop` (where the loop is described)
on ``--draws`` draws of every saveable trial, from the moment the run first saw
its danger, and counts the draws where nobody touches anything (``saved``), those
where someone walks into the robot (``into_robot``), the looks, the commands sent
to the robot, the candidates judged and the responses by kind. ``--belief-noise`` draws the beliefs with one
of the sensor model's errors alone (or none), which shows what each costs. ``--first-look-only``
acts on the first look alone and drives its move on, which shows what looking
again buys. ``--known-gaze`` judges moves at each endangered person's true gaze
alone, as no sensor could, which shows what the gaze classes cost. The draws are
seeded per trial, so two versions are compared on the same beliefs.

    python bench/bench_closed_loop.py [--draws N] [--look S] [--retry S] [--first-look-only]
        [--no-sampled-risk] [--known-gaze] [--belief-noise KIND] [--json PATH] [--every-room | RUN ...]
"""

from __future__ import annotations

import time
from collections import Counter

import benchlib
from agents.caregiving.model.move_search import DEFAULT_MAX_MOVES
from bench_move_search import RUNS, THRESHOLD, cases, every_room
from bench_move_search_noisy import add_belief_arguments
from bridges.experiment.beliefs import Noise
from bridges.experiment.closed_loop import Setup, closed_loop

#: The sensor model's errors a belief can be drawn with: factors of the objects' position sigma, the size error
#: bound, and the people's position and heading sigmas.
BELIEF_NOISE = {
    "all": (1.0, 1.0, 1.0),
    "none": (0.0, 0.0, 0.0),
    "people": (0.0, 0.0, 1.0),
    "object-positions": (1.0, 0.0, 0.0),
    "object-sizes": (0.0, 1.0, 0.0),
}


def closed_loops(runs: list[str], draws: int, setup: Setup) -> dict[str, object]:
    """Every draw of every saveable case in a closed loop; what came of them."""
    loops = saved = into_robot = looks = commands = judged = 0
    responses: Counter[str] = Counter()
    lost: Counter[str] = Counter()
    started = time.perf_counter()
    for case in cases(runs):
        if not case.saveable:
            continue
        for draw in range(draws):
            loop = closed_loop(case.trial, case.at, case.planner, (case.index, draw), setup)
            collisions = loop.truth.outcome().collisions
            loops += 1
            saved += not collisions
            into_robot += any(c.obstacle == loop.truth.scene().robot_name for c in collisions)
            looks += loop.looks
            commands += loop.commands
            judged += loop.judged
            responses.update(loop.responses)
            lost.update([f"{case.run}#{case.index}"] if collisions else [])
    return {
        "draws": loops,
        "saved": saved,
        "into_robot": into_robot,
        "looks": looks,
        "commands": commands,
        "judged": judged,
        "responses": dict(sorted(responses.items())),
        "seconds": round(time.perf_counter() - started, 1),
        "lost_draws": dict(lost),
    }


def main() -> None:
    p = benchlib.parser("bench_closed_loop", __doc__.splitlines()[0])
    add_belief_arguments(p, RUNS, "saveable trial", 0.1)
    p.add_argument("--look", type=float, default=0.5, help="seconds between looks at a danger (Algorithm 1's refresh)")
    p.add_argument(
        "--retry", type=float, default=0.5, help="seconds before a danger no move removed is looked at again"
    )
    p.add_argument("--first-look-only", action="store_true", help="act on the first look only, and drive its move on")
    p.add_argument("--no-sampled-risk", action="store_true", help="search without sampling uncertainty")
    p.add_argument(
        "--max-moves",
        type=int,
        default=DEFAULT_MAX_MOVES,
        help="moves a search judges at most (default: the action agent's)",
    )
    p.add_argument("--known-gaze", action="store_true", help="judge moves at the people's true gaze alone")
    p.add_argument(
        "--belief-noise",
        choices=sorted(BELIEF_NOISE),
        default="all",
        help="which of the sensor model's errors the beliefs are drawn with (default: all; none: the exact scene)",
    )
    p.add_argument(
        "--every-room", action="store_true", help="one recorded run of each room and seed in docs/results (no RUN)"
    )
    args = p.parse_args()
    if args.every_room:
        args.runs = every_room()
    noise = Noise(*BELIEF_NOISE[args.belief_noise], sampled_risk=not args.no_sampled_risk)
    setup = Setup(
        delay=args.delay,
        judging=args.judging,
        look=args.look,
        retry=args.retry,
        first_look_only=args.first_look_only,
        noise=noise,
        threshold=THRESHOLD,
        known_gaze=args.known_gaze,
        max_moves=args.max_moves,
    )
    found = closed_loops(args.runs, args.draws, setup)
    benchlib.report_draws(
        "Algorithm 2 in a closed loop",
        args.json,
        {
            "runs": args.runs,
            "delay": args.delay,
            "judging": args.judging,
            "look": args.look,
            "retry": args.retry,
            "first_look_only": args.first_look_only,
            "sampled_risk": noise.sampled_risk,
            "belief_noise": args.belief_noise,
            "known_gaze": args.known_gaze,
            "max_moves": args.max_moves,
        },
        found,
    )


if __name__ == "__main__":
    main()
