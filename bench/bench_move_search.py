"""Algorithm 2's move search with perfect belief, on every truly risky trial of recorded experiment runs.

For each truly risky trial of the runs named (the ``wm experiment`` JSON files in
``docs/results/``), the ground truth is stepped to the moment the run first saw
the danger (its ``risk_at_time``). The danger is imagined as the intention agent
imagines it (the person's planned walk at their true gaze), and the search runs
on the exact scene: no sensor noise, the robot starting ``--delay`` seconds later
and ``--judging`` seconds later per candidate judged. A chosen move is then
commanded in the ground truth at that time, and the trial counts as saved when
nobody touches anything. This separates what the move set and its order can do
from what perception's noise costs: the live runs lose both.

With several ``--judging`` values, the search runs once per value, and the table gives the trials
saved against the seconds each candidate takes to judge, beside what one takes on this machine:
how much a faster search would prevent.

With ``--every``, every candidate of every danger is judged (not only up to the
first safe one), by kind: the stand-offs straight behind and in front of the
obstacle, the other stand-offs, the path poses and the other objects' stand-offs,
and for the dangers whose first two stand-offs fail, which kinds still hold a safe
move. ``by_way`` splits each kind by whether a straight drive there comes into the
person's way in time (``candidates.crossing_time``) and whether the robot reaches
the pose before the person passes it.

With ``--every-room``, the runs are one recorded run of each room and seed in ``docs/results/`` (shipped and
held out) with a saveable trial.

    python bench/bench_move_search.py [--delay S] [--judging S [S ...]] [--every] [--json PATH]
        [--every-room | RUN ...]
"""

from __future__ import annotations

import json
import time
from collections import Counter
from collections.abc import Callable, Iterator
from dataclasses import dataclass
from functools import partial
from pathlib import Path
from typing import Any

import benchlib
from agents.caregiving.model import candidates, judging, move_search
from agents.caregiving.model.candidates import Danger
from agents.caregiving.model.planner import GridPlanner
from agents.caregiving.model.robot_moves import RobotMove, robot_fits
from agents.caregiving.model.scenario import Scenario, load_scenario
from agents.caregiving.model.scene import Scene
from agents.caregiving.model.search_spec import SearchSpec
from agents.caregiving.model.service import serve_one
from agents.caregiving.model.uncertainty import Uncertainty
from bridges.experiment.perfect_belief import perfect_belief_spec, saved_in_truth
from bridges.world.bridge import trial_for

RECORDED = Path(__file__).resolve().parent.parent / "docs" / "results"
RUNS = (
    "experiment1_same_search_before",
    "scenario_side_wall_diagonal",
    "scenario_box_obstacle",
    "experiment1_seed4242",
    "scenario_doubled_noise",
    "scenario_paper_fast_robot",
    "scenario_paper_fast_robot_seed2718",
    "scenario_two_people_two_obstacles",
)
EXACT = Uncertainty(0.0, {}, 1)
THRESHOLD = 0.2
#: The stand-offs straight behind and straight in front of the obstacle, the search's first two candidates.
FIRST_STANDOFFS = 2


@dataclass(frozen=True)
class Case:
    """One trial of a recorded run that the run flagged, at the moment it saw its danger."""

    run: str
    index: int
    saveable: bool
    collided: bool  # in the recorded run, with the robot acting
    trial: Scenario
    planner: GridPlanner
    at: float


def recorded_scenario(recorded: dict[str, Any]) -> Scenario:
    """The scenario a recorded run ran: its file, or the held-out room of that name when the file was elsewhere."""
    name = Path(str(recorded.get("scenario_file", recorded["scenario"])))
    if name.suffix and not name.exists():
        name = RECORDED / "heldout" / name.name
    return load_scenario(name)


def room_of(recorded: dict[str, Any]) -> str:
    """The room a recorded run ran: its scenario file's stem."""
    return Path(str(recorded.get("scenario_file", recorded.get("scenario")))).stem


def has_saveable(recorded: dict[str, Any]) -> bool:
    """Whether a recorded run holds a trial the oracle found saveable."""
    return any(t.get("saveable") for t in recorded["per_trial"])


def every_room(keep: Callable[[dict[str, Any]], bool] = has_saveable) -> list[str]:
    """One recorded run (the first by name) of each room and seed that ``keep`` keeps (by default: with a saveable
    trial), shipped and held out."""
    runs: dict[tuple[str, int], str] = {}
    for path in sorted([*RECORDED.glob("*.json"), *RECORDED.glob("heldout/*.json")]):
        recorded = json.loads(path.read_text())
        trials = recorded.get("per_trial") if isinstance(recorded, dict) else None
        if not trials or "seed" not in recorded or not keep(recorded):
            continue
        room = room_of(recorded)
        runs.setdefault((room, int(recorded["seed"])), str(path.relative_to(RECORDED).with_suffix("")))
    return [runs[k] for k in sorted(runs)]


def truly_risky(trial: dict[str, Any]) -> bool:
    """Whether a recorded trial collides with the robot idle."""
    return bool(trial["truly_risky"])


def false_alarm(trial: dict[str, Any]) -> bool:
    """Whether a recorded trial, safe with the robot idle, was flagged risky by the run."""
    return not trial["truly_risky"] and trial.get("risk_at_time") is not None


def has_false_alarm(recorded: dict[str, Any]) -> bool:
    """Whether a recorded run holds a :func:`false_alarm`."""
    return any(false_alarm(t) for t in recorded["per_trial"])


def cases(runs: list[str], keep: Callable[[dict[str, Any]], bool] = truly_risky) -> Iterator[Case]:
    """The trials of ``runs`` that ``keep`` keeps (by default the truly risky) and the run flagged, each at the
    moment the run saw its danger."""
    for run in runs:
        recorded = json.loads((RECORDED / f"{run}.json").read_text())
        scenario = recorded_scenario(recorded)
        planner = GridPlanner(scenario.scene().bounds)
        for t in recorded["per_trial"]:
            if keep(t) and t["risk_at_time"] is not None:
                trial = trial_for(scenario, recorded["seed"], t["index"])
                yield Case(run, t["index"], bool(t["saveable"]), t["collided"], trial, planner, t["risk_at_time"])


def search_spec(case: Case, delay: float) -> tuple[Scene, SearchSpec] | None:
    """The exact scene at the case's moment and the spec of its dangers, imagined as Algorithm 1 does."""
    return perfect_belief_spec(case.trial, case.at, case.planner, delay)


def first_safe(runs: list[str], delay: float, judging: float, head_start: bool = False) -> dict[str, object]:
    """Search each case up to its first safe move and check its moves in the ground truth (``saved_in_truth``)."""
    risky = saveable = chosen = saved = saved_of_saveable = judged = judged_when_chosen = leads = 0
    lost: list[str] = []
    spent = 0.0
    for case in cases(runs):
        found = search_spec(case, delay)
        if found is None:
            continue
        scene, spec = found
        started = time.perf_counter()
        result = move_search.search(
            scene,
            spec,
            partial(serve_one, scene),
            EXACT,
            THRESHOLD,
            move_search.DEFAULT_MAX_MOVES,
            judging=judging,
            head_start=(lambda _lead: None) if head_start else None,
        )
        spent += time.perf_counter() - started
        leads += result.lead is not None
        if result.chosen is not None and result.chosen.move is not None:
            chosen += 1
            judged_when_chosen += len(result.verdicts)
        ok = saved_in_truth(case.trial, case.at, case.planner, delay, judging, result)
        risky += 1
        saveable += case.saveable
        judged += len(result.verdicts)
        saved += ok
        saved_of_saveable += ok and case.saveable
        if case.saveable and not ok:
            lost.append(f"{case.run}#{case.index}")
    return {
        "truly_risky": risky,
        "oracle_saveable": saveable,
        "chosen": chosen,
        "saved": saved,
        "saved_of_saveable": saved_of_saveable,
        "judged": judged,
        "judged_when_chosen": judged_when_chosen,
        "head_starts": leads,
        "search_s": round(spent, 3),
        "saveable_lost": lost,
    }


def kinds(scene: Scene, danger: Danger, delay: float) -> list[tuple[str, RobotMove, float, bool]]:
    """Every candidate of one danger, pruned as the search prunes, with its kind, the seconds until the person
    passes it (the collision, for a stand-off) and whether a straight drive there comes into their way in time."""
    route = candidates.route_ahead(scene, danger)

    def reachable(move: RobotMove, until: float) -> bool:
        return candidates.in_reach(scene, move, until - delay) and robot_fits(scene, move)

    def in_the_way(move: RobotMove) -> bool:
        return route is not None and candidates.crossing_time(scene, danger, move, delay, route) is not None

    ttc = danger.time_to_collision
    near = [m for m in candidates.standoffs(scene, danger, danger.obstacle) if reachable(m, ttc)]
    out = [("first stand-offs" if k < FIRST_STANDOFFS else "other stand-offs", m, ttc) for k, m in enumerate(near)]
    out += [("path poses", m, until) for m, until in candidates.path_poses(scene, danger) if reachable(m, until)]
    found = [(kind, m, until, in_the_way(m)) for kind, m, until in out]
    for o in candidates.other_objects(scene, danger):
        for m in candidates.standoffs(scene, danger, o.name):
            crosses = in_the_way(m)
            if robot_fits(scene, m) and (crosses or reachable(m, ttc)):
                found.append(("other objects' stand-offs", m, ttc, crosses))
    return found


def every_candidate(runs: list[str], delay: float) -> dict[str, object]:
    """Judge every candidate of every case's first danger; what each kind saves, alone and after the first two
    fail, and what the candidates whose drive never comes into the person's way in time, or that the robot
    reaches only after the person passes, save."""
    judged, safe, rescues = Counter[str](), Counter[str](), Counter[str]()
    by_way_judged, by_way_safe = Counter[str](), Counter[str]()
    dangers = after_first = still_saveable = 0
    for case in cases(runs):
        found = search_spec(case, delay)
        if found is None:
            continue
        scene, spec = found
        danger = spec.dangers[0]
        alone = spec.alone(danger)
        verdicts = []
        for kind, m, until, in_the_way in kinds(scene, danger, delay):
            ok = judging.judge_move(alone, m, partial(serve_one, scene), EXACT, scene.robot_name).safe(THRESHOLD)
            verdicts.append((kind, ok))
            reached = candidates.drive_time(scene, m.x, m.y) < until - delay
            way = (
                f"{kind}, {'in the way' if in_the_way else 'never in the way'}, "
                f"{'reached in time' if reached else 'reached late'}"
            )
            by_way_judged[way] += 1
            by_way_safe[way] += ok
        dangers += 1
        for kind, ok in verdicts:
            judged[kind] += 1
            safe[kind] += ok
        if not any(ok for kind, ok in verdicts if kind == "first stand-offs"):
            after_first += 1
            still_saveable += any(ok for _, ok in verdicts)
            for kind in {kind for kind, ok in verdicts if ok}:
                rescues[kind] += 1
    return {
        "dangers": dangers,
        "by_kind": {k: {"judged": judged[k], "safe": safe[k]} for k in judged},
        "first_two_stand_offs_fail": after_first,
        "of_those_some_move_safe": still_saveable,
        "of_those_safe_by_kind": dict(rescues),
        "by_way": {k: {"judged": by_way_judged[k], "safe": by_way_safe[k]} for k in sorted(by_way_judged)},
    }


def main() -> None:
    p = benchlib.parser("bench_move_search", __doc__.splitlines()[0])
    p.add_argument("runs", nargs="*", default=list(RUNS), help="recorded runs (docs/results/RUN.json)")
    p.add_argument("--delay", type=float, default=0.15, help="seconds from the danger to the robot's start")
    p.add_argument(
        "--judging",
        type=float,
        nargs="+",
        default=[0.02],
        help="seconds more per candidate judged; several values give prevention against the search's speed",
    )
    p.add_argument("--every", action="store_true", help="judge every candidate of every danger, by kind")
    p.add_argument(
        "--every-room", action="store_true", help="one recorded run of each room and seed in docs/results (no RUN)"
    )
    p.add_argument(
        "--head-start", action="store_true", help="send the first candidate as a head start when it is harmless"
    )
    args = p.parse_args()
    if args.every_room:
        args.runs = every_room()
    found = first_safe(args.runs, args.delay, args.judging[0], args.head_start)
    benchlib.print_table("Move search with perfect belief", list(found.items()))
    figures: dict[str, object] = {
        "runs": args.runs,
        "delay": args.delay,
        "judging": args.judging[0],
        "head_start": args.head_start,
        "first_safe": found,
    }
    if len(args.judging) > 1:
        by_speed = [
            {"judging": j, **(found if k == 0 else first_safe(args.runs, args.delay, j, args.head_start))}
            for k, j in enumerate(args.judging)
        ]
        spent = sum(float(f["search_s"]) for f in by_speed) / max(sum(int(f["judged"]) for f in by_speed), 1)
        benchlib.print_table(
            f"Saved of saveable against seconds per candidate (this machine judges one in {spent * 1e3:.1f} ms)",
            [(f"{f['judging'] * 1e3:g} ms", f"{f['saved_of_saveable']} of {f['oracle_saveable']}") for f in by_speed],
        )
        figures["by_judging"] = by_speed
        figures["seconds_per_candidate_here"] = spent
    if args.every:
        every = every_candidate(args.runs, args.delay)
        benchlib.print_table("Every candidate judged", list(every.items()))
        figures["every_candidate"] = every
    benchlib.write_json(args.json, figures)


if __name__ == "__main__":
    main()
