"""Algorithm 2 in a closed loop on noisy beliefs, on every oracle-saveable trial of recorded runs.

``bench_move_search_noisy.py`` runs the first search of each danger. Live, the action agent looks again each
time Algorithm 1 rewrites the danger while it lasts, and keeps, doubts or replaces the move under way. This
bench runs :func:`bridges.experiment.closed_loop.closed_loop` (where the loop is described) on ``--draws``
draws of every saveable trial, from the moment the run first saw its danger, and counts the draws where nobody
touches anything (``saved``), those where someone walks into the robot once it has been commanded (``into_robot``;
a walk into the robot where the scene parked it, before its first command, happens with it idle too), the looks, the
commands sent to the robot, the candidates judged and the responses by kind, and, by the sampled risk of the
first move a search chose and sent, those draws and how many of them were lost (``first_sent_by_risk``: how
well the imagination's risk foretells the truth), and the lost draws by what the robot did in them
(``lost_by_what_the_robot_did``: never moved, only head starts, a move sent, someone into the robot).
``--belief-noise`` draws the beliefs with one of the sensor model's errors alone (or none), which shows what
each costs. ``--first-look-only`` acts on the first look alone and drives its move on, which shows what
looking again buys. ``--people PATH`` (a ``bench_people_saved.py`` JSON) runs instead every trial of its runs
where some move saves someone, alone or with the others (rooms where two people fall in different places hold
many that no one move saves whole), and counts people: those some move saves and those of them saved. Every
mode counts those who fell only with the robot acting (``tripped``), and lists the draws that lost someone,
those that tripped someone and those where someone walked into the robot. ``--known-gaze`` judges moves at
each endangered person's true gaze alone, as no sensor could, which shows what the gaze classes cost.
``--false-alarms`` has Algorithm 1 look at everyone still walking, as live, so that a person believed to fall
who passes in the truth is a danger too (by default only those who fall with the robot idle are). ``--assist``
sends the robot, once nobody is in danger, to someone lying where they fell, as the assist agent does: what
answering a fall costs the others. ``--safe-trials`` runs instead every trial of every room's runs that the
run flagged and that is safe with the robot idle, with ``--false-alarms``: every fall there is one the robot
caused (``tripped``), the live experiments' ``robot_caused_collisions`` on drawn beliefs. ``--judged-in S``
has each judgement truly take ``S`` seconds while the searches imagine ``--judging``: the action agent's
estimate of a candidate's cost is off (before it has timed a search, it is 30 ms), and moves are held to, or
judged again for, the moments their searches imagined, as live. ``--sooner S`` starts each loop ``S`` seconds
before the run first saw its danger (one frame in at the earliest): what flagging a danger sooner buys, on runs
recorded before it was. The draws are seeded per trial, so two
versions are compared on the same beliefs. The runs are shared between two processes.

    python bench/bench_closed_loop.py [--draws N] [--delay S] [--judging S] [--judged-in S] [--sooner S]
        [--look S] [--retry S] [--first-look-only] [--no-sampled-risk] [--known-gaze] [--false-alarms] [--assist]
        [--belief-noise KIND] [--json PATH] [--every-room | --people PATH | --safe-trials | RUN ...]
"""

from __future__ import annotations

import json
import math
import time
from collections import Counter
from concurrent.futures import ProcessPoolExecutor
from dataclasses import dataclass
from pathlib import Path

import benchlib
from agents.caregiving.model.move_search import DEFAULT_MAX_MOVES
from agents.caregiving.model.rollout import DT
from bench_move_search import RUNS, THRESHOLD, cases, every_room, false_alarm, has_false_alarm, truly_risky
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


#: ``{(run, trial index): the people some move saves}``, from a ``bench_people_saved.py`` JSON.
SaveablePeople = dict[tuple[str, int], frozenset[str]]


def saveable_people(path: Path) -> SaveablePeople:
    """The trials of a ``bench_people_saved.py`` JSON where some move saves someone, and whom."""
    trials = json.loads(path.read_text())["trials"]
    return {(t["run"], t["index"]): frozenset(t["saveable_people"]) for t in trials if t["saveable_people"]}


@dataclass(frozen=True)
class Draw:
    """What came of one draw of one case's closed loop."""

    case: str  # run#index
    saved: bool
    people_saveable: int
    people_saved: int
    tripped: int  # people who fell only with the robot acting
    into_robot: bool  # someone walked into the robot after its first command
    looks: int
    commands: int
    judged: int
    responses: dict[str, int]
    lost: bool  # someone saveable fell (without ``people``: anyone fell)
    first_risk: float | None  # the sampled risk of the first move chosen and sent, if one was


#: Upper bounds of the sampled risks the first moves sent are counted by (:func:`by_risk`).
RISK_BINS = (0.05, 0.1, 0.15, 0.2, 1.0)


def by_risk(found: list[Draw]) -> dict[str, dict[str, int]]:
    """The draws where a move was chosen and sent, by the sampled risk of the first one, each with how many of
    them were lost: how well the imagination's risk foretells the truth."""
    labels = [f"{low:.2f}-{high:.2f}" for low, high in zip((0.0, *RISK_BINS[:-1]), RISK_BINS, strict=True)]
    counts = {label: {"sent": 0, "lost": 0} for label in labels}
    for d in found:
        if d.first_risk is not None:
            label = labels[next((k for k, high in enumerate(RISK_BINS) if d.first_risk < high), len(labels) - 1)]
            counts[label]["sent"] += 1
            counts[label]["lost"] += d.lost
    return counts


def what_the_robot_did(draw: Draw) -> str:
    """What the robot did in a lost draw: someone walked into it, it never moved, only head starts went out (no
    search found a move to send), or a move was sent and someone fell anyway."""
    if draw.into_robot:
        return "into the robot"
    if not draw.commands:
        return "never moved"
    return "a move sent" if draw.responses.get("send") else "head starts only"


@dataclass(frozen=True)
class Job:
    """One run's draws: how many per case, the loop's setup, the people some move saves (``people``), whether
    the cases are the false alarms (``safe``), and how many seconds before the run saw each danger the loops
    start (``sooner``)."""

    run: str
    draws: int
    setup: Setup
    people: SaveablePeople | None
    safe: bool
    sooner: float


def run_draws(job: Job) -> list[Draw]:
    """Every draw of every saveable case of one run (with ``people``: every case where some move saves someone;
    with ``safe``: every false alarm)."""
    run, draws, setup, people, safe = job.run, job.draws, job.setup, job.people, job.safe
    found = []
    for case in cases([run], false_alarm if safe else truly_risky):
        saveable = people.get((case.run, case.index), frozenset()) if people is not None else frozenset()
        if not safe and not (saveable if people is not None else case.saveable):
            continue
        for draw in range(draws):
            at = max(round(case.at - job.sooner, 6), DT)  # one world step in at the earliest
            loop = closed_loop(case.trial, at, case.planner, (case.index, draw), setup)
            collisions = loop.truth.outcome().collisions
            robot = loop.truth.scene().robot_name
            moved_at = loop.commanded[0][0] if loop.commanded else math.inf
            fell = {c.person for c in collisions}
            found.append(
                Draw(
                    f"{case.run}#{case.index}",
                    not collisions,
                    len(saveable),
                    len(saveable - fell),
                    len(fell - loop.idle_fallers),
                    any(c.obstacle == robot and c.time > moved_at for c in collisions),
                    loop.looks,
                    loop.commands,
                    loop.judged,
                    loop.responses,
                    bool(fell & saveable if people is not None else fell),
                    loop.first_risk,
                )
            )
    return found


def closed_loops(
    runs: list[str],
    draws: int,
    setup: Setup,
    people: SaveablePeople | None = None,
    safe: bool = False,
    sooner: float = 0.0,
) -> dict[str, object]:
    """Every draw of every saveable case in a closed loop (with ``people``: of every case where some move saves
    someone; with ``safe``: of every false alarm), the runs shared between two processes; what came of them."""
    started = time.perf_counter()
    with ProcessPoolExecutor(max_workers=2) as pool:
        jobs = [Job(run, draws, setup, people, safe, sooner) for run in runs]
        found = [d for ds in pool.map(run_draws, jobs) for d in ds]
    responses: Counter[str] = Counter()
    for d in found:
        responses.update(d.responses)
    return {
        "draws": len(found),
        "saved": sum(d.saved for d in found),
        **(
            {
                "people_saveable": sum(d.people_saveable for d in found),
                "people_saved": sum(d.people_saved for d in found),
            }
            if people is not None
            else {}
        ),
        "tripped": sum(d.tripped for d in found),
        "into_robot": sum(d.into_robot for d in found),
        "looks": sum(d.looks for d in found),
        "commands": sum(d.commands for d in found),
        "judged": sum(d.judged for d in found),
        "responses": dict(sorted(responses.items())),
        "first_sent_by_risk": by_risk(found),
        "lost_by_what_the_robot_did": dict(Counter(what_the_robot_did(d) for d in found if d.lost).most_common()),
        "seconds": round(time.perf_counter() - started, 1),
        "lost_draws": dict(Counter(d.case for d in found if d.lost)),
        "tripped_draws": dict(Counter(d.case for d in found if d.tripped)),
        "into_robot_draws": dict(Counter(d.case for d in found if d.into_robot)),
    }


def main() -> None:
    p = benchlib.parser("bench_closed_loop", __doc__.splitlines()[0])
    add_belief_arguments(p, RUNS, "saveable trial", 0.1)
    p.add_argument("--look", type=float, default=0.5, help="seconds between looks at a danger (Algorithm 1's refresh)")
    p.add_argument(
        "--retry", type=float, default=0.5, help="seconds before a danger no move removed is looked at again"
    )
    p.add_argument("--first-look-only", action="store_true", help="act on the first look only, and drive its move on")
    p.add_argument(
        "--judged-in",
        type=float,
        help="seconds a judgement truly takes, the search imagining --judging (default: --judging): an estimate "
        "that is off, as the action agent's is before it has timed a search",
    )
    p.add_argument(
        "--sooner",
        type=float,
        default=0.0,
        help="start each loop this many seconds before the run first saw its danger: what flagging it sooner buys",
    )
    p.add_argument("--no-sampled-risk", action="store_true", help="search without sampling uncertainty")
    p.add_argument(
        "--max-moves",
        type=int,
        default=DEFAULT_MAX_MOVES,
        help="moves a search judges at most (default: the action agent's)",
    )
    p.add_argument("--known-gaze", action="store_true", help="judge moves at the people's true gaze alone")
    p.add_argument(
        "--false-alarms",
        action="store_true",
        help="look for dangers in everyone still walking, as live, not only in those who fall with the robot idle",
    )
    p.add_argument(
        "--assist",
        action="store_true",
        help="after a fall, send the robot at rest to the person as the assist agent does, clear of the walkers",
    )
    p.add_argument(
        "--belief-noise",
        choices=sorted(BELIEF_NOISE),
        default="all",
        help="which of the sensor model's errors the beliefs are drawn with (default: all; none: the exact scene)",
    )
    rooms = p.add_mutually_exclusive_group()
    rooms.add_argument(
        "--every-room", action="store_true", help="one recorded run of each room and seed in docs/results (no RUN)"
    )
    rooms.add_argument(
        "--people", type=Path, help="a bench_people_saved.py JSON: its trials where some move saves someone (no RUN)"
    )
    rooms.add_argument(
        "--safe-trials",
        action="store_true",
        help="every room's flagged trials that are safe with the robot idle, with --false-alarms (no RUN)",
    )
    args = p.parse_args()
    people = saveable_people(args.people) if args.people else None
    if args.every_room:
        args.runs = every_room()
    elif people is not None:
        args.runs = sorted({run for run, _ in people})
    elif args.safe_trials:
        args.runs = every_room(has_false_alarm)
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
        false_alarms=args.false_alarms or args.safe_trials,
        max_moves=args.max_moves,
        assist=args.assist,
        judged_in=args.judged_in,
    )
    found = closed_loops(args.runs, args.draws, setup, people, args.safe_trials, args.sooner)
    benchlib.report_draws(
        "Algorithm 2 in a closed loop",
        args.json,
        {
            "runs": args.runs,
            "delay": args.delay,
            "judging": args.judging,
            "judged_in": args.judged_in,
            "sooner": args.sooner,
            "look": args.look,
            "retry": args.retry,
            "first_look_only": args.first_look_only,
            "sampled_risk": noise.sampled_risk,
            "belief_noise": args.belief_noise,
            "known_gaze": args.known_gaze,
            "false_alarms": setup.false_alarms,
            "safe_trials": args.safe_trials,
            "max_moves": args.max_moves,
            "assist": args.assist,
            "people": str(args.people) if args.people else None,
        },
        found,
    )


if __name__ == "__main__":
    main()
