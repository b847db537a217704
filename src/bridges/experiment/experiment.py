"""``wm experiment``: Experiment 1 of the paper over the full multi-process stack.

For each trial the world bridge samples positions from ``--seed``, the stack
runs closed-loop (the robot acts on what it guesses), and the harness records
what W showed. Ground truth is the world model's exact-geometry outcome of the
same trial with the robot idle (:func:`bridges.experiment.oracle.idle_run`).

Per trial: *predicted risky* = some ``has_intention`` was marked risky;
*discarded* = no intention arose at all (as in the paper). Over the valid
trials: accuracy, precision, recall, F1, F2 and the false-positive and
false-negative rates (shares of valid trials, as the paper's Table I). A trial
of several people can be predicted for a false alarm about one person while
another falls unflagged, so each fall with the robot idle is also scored on its
own (:mod:`bridges.experiment.fallers`), in every trial, a discarded one too
(``discarded_truly_risky`` counts those: a person the sensors saw too late for
any intention is a fall never flagged): ``people_at_risk`` counts them,
``person_recall`` is the share whose own risky intention was written at or
before their fall, and ``flag_lead_s_p50`` and ``_min`` say how long before it;
``people_saved`` and ``person_prevention_rate`` count those who did not fall with
the robot acting (two people falling in different places may be more than one
move can save, and saving one of them counts here); ``people_saveable`` counts
those the oracle finds some move saves, alone or with the others, without
tripping anyone else, and ``person_prevention_rate_of_saveable`` is the share of
them saved.
``action_rate`` is the share of predicted-risky trials in which Algorithm 2
wrote a move its joint imagination says removes the danger (the paper's
definition), ``action_in_time_rate`` the share whose move was also imagined to
be in place before the predicted collision, and ``action_rate_saveable`` and
``action_in_time_rate_saveable`` the same shares where the oracle allows a move
(over the predicted-risky trials it finds saveable); ``prevention_rate`` the share of
truly risky trials in which nobody collided in the closed loop. Since some
trials cannot be saved by any move of a robot with these limits (the person
starts next to the ball), the physical oracle (:mod:`bridges.experiment.oracle`)
searches each truly risky trial's ground truth for a move that saves it,
commanded when the danger first became observable: ``oracle_saveable`` counts
those trials (``oracle_standoff_saveable`` with stand-offs only) and
``prevention_rate_of_saveable`` is the prevention rate over them. No pipeline
can act at that very moment: ``pipeline_delay_ms_p50`` is the run's median time
from the context that first showed a danger to the robot's first command against a
danger in the world (simulated time: Algorithm 1 and the search after the context was read,
the command, and the wait for the world's next step), and
``oracle_saveable_after_delay`` counts the truly risky trials that some move of
the same broad set saves when commanded that much later;
``prevention_rate_of_saveable_after_delay`` is the prevention rate over those.
``robot_caused_collisions`` counts trials that were safe with the robot idle and
collided with it acting; ``robot_tripped_people`` counts, over every trial, the people who collided with
the robot acting but not with it idle (in a room with several people, a trial in which somebody falls
anyway can hide someone the robot tripped). ``falls_acting`` counts the falls of the trials as run,
``falls_seeable`` those a second or more before their trial ended, ``falls_seen`` those of them
perception marked ``fallen`` (:mod:`bridges.experiment.falls_seen`),
``fall_seen_after_s_p50`` and ``_max`` how long after the fall, and ``false_fall_marks`` the marks
of no fall. ``fall_marks`` counts the people marked fallen, ``falls_alerted`` those the robot raised an
alert about (``alert_after_mark_s_max``: how long after the mark, at the most) and ``fallen_gone_to`` those
it was sent to (the assist agent's answer to a fall). ``head_starts`` counts trials in which the robot set off on a head start
while the search judged on (an intention with ``head_start`` set: the robot's first command, but not
a move found to remove the danger, so not an action; ``head_start_ms_p50`` is its median time
from the risky intention, and ``first_response_ms_mean`` and ``_p50`` time the robot's first intention of
either kind). Reaction times are wall-clock differences
of stamps written into W by the writers (same host): the paper's definition
(risky ``has_intention`` -> the robot ``intention`` it set off on its action with) and end to end (the
perception write behind the risky guess -> that ``intention``). The robot sets off on its action with
the action itself, or with the head start it drives on with when the search ends by choosing that
same move; ``decision_ms_mean`` times the action itself, written when its search ended.
"""

from __future__ import annotations

import asyncio
import json
import statistics
import tempfile
import time
from concurrent.futures import ProcessPoolExecutor
from dataclasses import dataclass, replace
from functools import cached_property
from pathlib import Path
from typing import Any

import numpy as np
from rich.console import Console
from rich.progress import (
    BarColumn,
    MofNCompleteColumn,
    Progress,
    TextColumn,
    TimeElapsedColumn,
)
from rich.table import Table

from agents.caregiving.model.planner import GridPlanner
from agents.caregiving.model.scenario import Scenario, load_scenario
from agents.caregiving.names import ALERT, GO_TO, MOVE_TO, PREVENTING
from bridges.world.bridge import trial_for

from .fallers import Faller, fallers
from .falls_seen import FallsSeen, falls_seen
from .launch import Stack
from .oracle import OracleVerdict, idle_run, oracle
from .trials import TrialRecord, finite, open_harness

#: When no risky intention arose, the oracle acts at the time the pipeline typically does (simulated seconds).
ORACLE_AT = 0.5
PAPER = {
    "trials": 180,
    "discarded": 13,
    "valid": 167,
    "accuracy": 0.7964,
    "fp_rate": 0.2035,
    "fn_rate": 0.0,
    "precision": 0.61,
    "recall": 1.0,
    "f1": 0.76,
    "f2": 0.89,
    "reaction_ms_mean": 747.0,
    "reaction_ms_sd": 310.0,
    "action_rate": 0.8518,
}


@dataclass(frozen=True)
class Scored:
    """One trial with its ground truth (and, for truly risky trials, whether any move could save it)."""

    record: TrialRecord
    idle_fallers: frozenset[str]  # who collides with the robot idle
    idle_clearance: float = float("inf")
    saveable: bool | None = None
    standoff_saveable: bool | None = None
    saveable_after_delay: bool | None = None  # by a move commanded the pipeline's median delay later
    falls: tuple[Faller, ...] = ()  # each fall with the robot idle, and when its person was first flagged
    saveable_people: frozenset[str] = frozenset()  # of those who fall, the ones some move saves (the oracle's)

    @property
    def truly_risky(self) -> bool:
        """Whether somebody collides with the robot idle."""
        return bool(self.idle_fallers)

    @property
    def robot_tripped(self) -> list[str]:
        """The people who collided with the robot acting but not with it idle."""
        return sorted({c["person"] for c in self.record.outcome.get("collisions", [])} - self.idle_fallers)

    @cached_property
    def seen(self) -> FallsSeen:
        """Whether perception marked each fall of the trial as run, and how soon."""
        outcome = self.record.outcome
        return falls_seen(outcome.get("collisions", []), self.record.fall_marks.values(), outcome.get("duration", 0.0))

    def answers(self, action: str) -> dict[int, float]:
        """The people perception marked fallen whom the robot answered with ``action`` (an alert, or going to them),
        by node: the simulated time of its first such intention."""
        firsts = self.record.answers.get(action, {})
        return {node: firsts[node] for node in self.record.fall_marks if node in firsts}

    @property
    def discarded(self) -> bool:
        return self.record.intentions == 0

    @property
    def predicted(self) -> bool:
        return self.record.risky is not None


def _ratio(a: float, b: float) -> float | None:
    return a / b if b else None


def percentile(values: list[float], q: float) -> float | None:
    return float(np.percentile(values, q)) if values else None


def action_rate(detected: list[Scored], in_time: bool = False) -> float | None:
    """The share of ``detected`` trials with a move written (``in_time``: one imagined in place in time)."""
    acted = [s.record.action for s in detected if s.record.action is not None]
    return _ratio(sum(a.get("in_time", True) for a in acted) if in_time else len(acted), len(detected))


def pipeline_delay(scored: list[Scored]) -> float | None:
    """The run's median delay (simulated s) from the context that first showed a danger to the robot's first command
    against a danger (a move to someone who has fallen is not one)."""
    delays = [
        max(first[0]["time"] - s.record.risky["at_time"], 0.0)
        for s in scored
        if s.record.risky is not None
        and (first := [c for c in s.record.outcome.get("commands", []) if c.get("action", MOVE_TO) in PREVENTING])
    ]
    return statistics.median(delays) if delays else None


def metrics(scored: list[Scored]) -> dict[str, Any]:
    """The figures of Table I, plus ours (see the module documentation)."""
    valid = [s for s in scored if not s.discarded]
    tp = sum(s.predicted and s.truly_risky for s in valid)
    fp = sum(s.predicted and not s.truly_risky for s in valid)
    fn = sum(not s.predicted and s.truly_risky for s in valid)
    tn = len(valid) - tp - fp - fn
    precision, recall = _ratio(tp, tp + fp), _ratio(tp, tp + fn)
    f1 = f2 = None
    if precision is not None and recall is not None and precision + recall > 0:
        f1 = 2 * precision * recall / (precision + recall)
        f2 = 5 * precision * recall / (4 * precision + recall)
    reactions = finite([s.record.reaction_ms for s in scored])
    decisions = finite([s.record.decision_ms for s in scored])
    responses = finite([s.record.first_response_ms for s in scored])
    e2e = finite([s.record.e2e_ms for s in scored])
    detected = [s for s in scored if s.predicted]
    saveable_detected = [s for s in detected if s.saveable]
    risky = [s for s in scored if s.truly_risky]
    delay = pipeline_delay(scored)
    late = [s for s in risky if s.saveable_after_delay]
    saved_late = sum(not s.record.collided for s in late)
    # Every fall counts here, a trial discarded for want of any intention included: it is a fall never flagged.
    falls = [f for s in scored for f in s.falls]
    leads = finite([f.lead for f in falls])
    saved = sum(not f.fell_acting for f in falls)
    saveable_falls = [f for s in scored for f in s.falls if f.person in s.saveable_people]
    saved_saveable = sum(not f.fell_acting for f in saveable_falls)
    seen = [s.seen for s in scored]
    alerted = answered(scored, ALERT)
    seen_after = [d for x in seen for d in x.seen]
    return {
        "trials": len(scored),
        "discarded": len(scored) - len(valid),
        "discarded_truly_risky": sum(s.truly_risky for s in scored if s.discarded),
        "valid": len(valid),
        "tp": tp,
        "fp": fp,
        "tn": tn,
        "fn": fn,
        "accuracy": _ratio(tp + tn, len(valid)),
        "precision": precision,
        "recall": recall,
        "f1": f1,
        "f2": f2,
        "fp_rate": _ratio(fp, len(valid)),
        "fn_rate": _ratio(fn, len(valid)),
        "reaction_ms_mean": statistics.fmean(reactions) if reactions else None,
        "reaction_ms_sd": statistics.stdev(reactions) if len(reactions) > 1 else None,
        "reaction_ms_p50": percentile(reactions, 50),
        "reaction_ms_p99": percentile(reactions, 99),
        "decision_ms_mean": statistics.fmean(decisions) if decisions else None,
        "first_response_ms_mean": statistics.fmean(responses) if responses else None,
        "first_response_ms_p50": percentile(responses, 50),
        "e2e_ms_p50": percentile(e2e, 50),
        "e2e_ms_p99": percentile(e2e, 99),
        "e2e_ms_mean": statistics.fmean(e2e) if e2e else None,
        "action_rate": action_rate(detected),
        "action_in_time_rate": action_rate(detected, in_time=True),
        "action_rate_saveable": action_rate(saveable_detected),
        "action_in_time_rate_saveable": action_rate(saveable_detected, in_time=True),
        "prevention_rate": _ratio(sum(not s.record.collided for s in risky), len(risky)),
        "prevented": sum(not s.record.collided for s in risky),
        "prevented_saveable": sum(not s.record.collided for s in risky if s.saveable),
        "oracle_saveable": sum(bool(s.saveable) for s in risky) if any(s.saveable is not None for s in risky) else None,
        "oracle_standoff_saveable": sum(bool(s.standoff_saveable) for s in risky),
        "prevention_rate_of_saveable": _ratio(
            sum(not s.record.collided for s in risky if s.saveable), sum(bool(s.saveable) for s in risky)
        ),
        "pipeline_delay_ms_p50": delay * 1e3 if delay is not None else None,
        "oracle_saveable_after_delay": len(late) if delay is not None else None,
        "prevented_saveable_after_delay": saved_late,
        "prevention_rate_of_saveable_after_delay": _ratio(saved_late, len(late)),
        "robot_caused_collisions": sum(s.record.collided and not s.truly_risky for s in scored),
        "robot_tripped_people": sum(len(s.robot_tripped) for s in scored),
        "head_starts": sum(s.record.head_start is not None for s in scored),
        "head_start_ms_p50": percentile(finite([s.record.head_start_ms for s in scored]), 50),
        "truly_risky": len(risky),
        "closed_loop_collisions": sum(s.record.collided for s in scored),
        "people_at_risk": len(falls),
        "people_flagged": len(leads),
        "person_recall": _ratio(len(leads), len(falls)),
        "flag_lead_s_p50": percentile(leads, 50),
        "flag_lead_s_min": min(leads, default=None),
        "people_saved": saved,
        "person_prevention_rate": _ratio(saved, len(falls)),
        "people_saveable": len(saveable_falls),
        "people_saved_saveable": saved_saveable,
        "person_prevention_rate_of_saveable": _ratio(saved_saveable, len(saveable_falls)),
        "falls_acting": sum(len(x.delays) for x in seen),
        "falls_seeable": sum(sum(x.seeable) for x in seen),
        "falls_seen": len(seen_after),
        "fall_seen_after_s_p50": percentile(seen_after, 50),
        "fall_seen_after_s_max": max(seen_after, default=None),
        "false_fall_marks": sum(x.unmatched for x in seen),
        "fall_marks": sum(len(s.record.fall_marks) for s in scored),
        "falls_alerted": len(alerted),
        "alert_after_mark_s_max": max(alerted, default=None),
        "fallen_gone_to": len(answered(scored, GO_TO)),
    }


def answered(scored: list[Scored], action: str) -> list[float]:
    """For each person perception marked fallen whom the robot answered with ``action``, the simulated seconds
    from the mark to the first such intention."""
    return [at - s.record.fall_marks[node].at_time for s in scored for node, at in s.answers(action).items()]


def _fmt(key: str, value: Any) -> str:
    if value is None:
        return "-"
    if "_ms_" in key:
        return f"{value:.1f} ms"
    if "_s_" in key:
        return f"{value:.2f} s"
    if key in (
        "accuracy",
        "fp_rate",
        "fn_rate",
        "action_rate",
        "action_in_time_rate",
        "action_rate_saveable",
        "action_in_time_rate_saveable",
        "prevention_rate",
        "prevention_rate_of_saveable",
        "prevention_rate_of_saveable_after_delay",
        "person_prevention_rate",
        "person_prevention_rate_of_saveable",
    ):
        return f"{100 * value:.2f} %"
    if isinstance(value, float):
        return f"{value:.3f}"
    return str(value)


ROWS = [
    ("Total experiments", "trials"),
    ("Experiments discarded", "discarded"),
    ("... of them truly risky (a fall never flagged)", "discarded_truly_risky"),
    ("Valid experiments", "valid"),
    ("Accuracy rate", "accuracy"),
    ("False positives", "fp_rate"),
    ("False negatives", "fn_rate"),
    ("Precision", "precision"),
    ("Recall", "recall"),
    ("People who fell with the robot idle", "people_at_risk"),
    ("... each flagged before their fall (recall by person)", "person_recall"),
    ("... flagged this long before it (p50)", "flag_lead_s_p50"),
    ("... at the least", "flag_lead_s_min"),
    ("... saved by the robot", "person_prevention_rate"),
    ("... some move could save, alone or with the others (oracle)", "people_saveable"),
    ("... saved by the robot, of those", "person_prevention_rate_of_saveable"),
    ("F-1 score", "f1"),
    ("F-2 score", "f2"),
    ("Reaction time (mean)", "reaction_ms_mean"),
    ("Reaction time (deviation)", "reaction_ms_sd"),
    ("... to the move chosen, once its search ended (mean)", "decision_ms_mean"),
    ("Robot's first response, head start or move (mean)", "first_response_ms_mean"),
    ("Trials with a head start", "head_starts"),
    ("Detected collision and action generated", "action_rate"),
    ("... with a move imagined in place in time", "action_in_time_rate"),
    ("Action generated where the oracle allows a move", "action_rate_saveable"),
    ("... with a move imagined in place in time", "action_in_time_rate_saveable"),
    ("Truly risky trials", "truly_risky"),
    ("Prevented (truly risky trials)", "prevention_rate"),
    ("Truly risky trials some move could save (oracle)", "oracle_saveable"),
    ("... with stand-off moves only", "oracle_standoff_saveable"),
    ("Prevented (of those some move could save)", "prevention_rate_of_saveable"),
    ("Pipeline delay, danger shown -> first command (p50)", "pipeline_delay_ms_p50"),
    ("Truly risky trials some move could save, commanded that late", "oracle_saveable_after_delay"),
    ("Prevented (of those)", "prevention_rate_of_saveable_after_delay"),
    ("Collisions the robot caused", "robot_caused_collisions"),
    ("People who fell only with the robot acting", "robot_tripped_people"),
    ("People who fell, with the robot acting", "falls_acting"),
    ("... a second or more before the trial ended", "falls_seeable"),
    ("... seen lying by perception, of those", "falls_seen"),
    ("... this long after the fall (p50)", "fall_seen_after_s_p50"),
    ("... at the most", "fall_seen_after_s_max"),
    ("Falls seen where nobody fell", "false_fall_marks"),
    ("People marked fallen", "fall_marks"),
    ("... with an alert raised about them", "falls_alerted"),
    ("... the alert this long after the mark (at the most)", "alert_after_mark_s_max"),
    ("... the robot sent to them", "fallen_gone_to"),
    ("End to end p50", "e2e_ms_p50"),
    ("End to end p99", "e2e_ms_p99"),
]


def prevention_line(result: dict[str, Any]) -> str:
    """One line: the truly risky trials prevented, out of those some move could save and out of all."""
    late = ""
    if result.get("oracle_saveable_after_delay") is not None:
        late = (
            f" ({result['prevented_saveable_after_delay']} of the {result['oracle_saveable_after_delay']} "
            f"still saveable {result['pipeline_delay_ms_p50']:.0f} ms later, when the robot is commanded)"
        )
    return (
        f"prevented {result['prevented_saveable']} of the {result['oracle_saveable'] or 0} truly risky trials "
        f"some move could save{late}, {result['prevented']} of {result['truly_risky']} truly risky in all; "
        f"the robot caused {result['robot_caused_collisions']} collision(s)"
    )


def table(result: dict[str, Any]) -> Table:
    """Table I of the paper beside ours."""
    t = Table(title="Experiment 1 (Table I)")
    t.add_column("Metric")
    t.add_column("Ours", justify="right")
    t.add_column("Paper", justify="right")
    for label, key in ROWS:
        t.add_row(label, _fmt(key, result.get(key)), _fmt(key, PAPER.get(key)))
    return t


async def run_trials(
    scenario: Scenario,
    stack: Stack,
    seed: int,
    indices: list[int | None],
    console: Console,
    graph: str,
    scenario_file: str | None = None,
) -> list[Scored]:
    """Run the trials on a started stack, with a progress bar; returns them scored.

    ``scenario_file`` switches the world bridge to that file (``scenario`` is its loaded form).
    """
    planner = GridPlanner(scenario.scene().bounds)
    timeout = 30.0 / stack.rate + 20.0
    scored: list[Scored] = []
    async with open_harness(stack.endpoint, graph) as harness:
        columns = (TextColumn("{task.description}"), BarColumn(), MofNCompleteColumn(), TimeElapsedColumn())
        with Progress(*columns, console=console, transient=True) as progress:
            task = progress.add_task("trials", total=len(indices))
            for index in indices:
                stack.check()
                record = await harness.run(seed, index, timeout, scenario_file)
                idle = idle_run(trial_for(scenario, seed, index), planner)
                truth = idle.outcome()
                scored.append(
                    Scored(
                        record,
                        frozenset(c.person for c in truth.collisions),
                        min(truth.min_clearance.values(), default=float("inf")),
                        falls=fallers(
                            idle, record.flags.values(), {c["person"] for c in record.outcome.get("collisions", [])}
                        ),
                    )
                )
                progress.update(
                    task, advance=1, description=f"trials ({sum(s.record.collided for s in scored)} collided)"
                )
    return scored


def _judge_trial(job: tuple[Scenario, int, int | None, float]) -> OracleVerdict:
    scenario, seed, index, at = job
    return oracle(trial_for(scenario, seed, index), at, GridPlanner(scenario.scene().bounds))


def with_oracle(scenario: Scenario, seed: int, scored: list[Scored], console: Console) -> list[Scored]:
    """Add the physical oracle's verdicts to the truly risky trials, at the danger and after the pipeline's delay.

    Two processes at a time.
    """
    risky = [s for s in scored if s.truly_risky]
    delay = pipeline_delay(scored)
    moments = [(s, (s.record.risky or {}).get("at_time", ORACLE_AT)) for s in risky]
    jobs = [(scenario, seed, s.record.index, at) for s, at in moments]
    if delay is not None:
        jobs += [(scenario, seed, s.record.index, at + delay) for s, at in moments]
    with console.status(f"oracle: could any move have saved the {len(risky)} truly risky trials?"):
        with ProcessPoolExecutor(max_workers=2) as pool:
            verdicts = list(pool.map(_judge_trial, jobs))
    now = verdicts[: len(risky)]
    late: list[OracleVerdict | None] = [*verdicts[len(risky) :]] or [None] * len(risky)
    judged = {
        id(s): replace(
            s,
            saveable=v.saveable,
            standoff_saveable=v.standoff_saveable,
            saveable_after_delay=w.saveable if w is not None else None,
            saveable_people=v.saveable_people,
        )
        for s, v, w in zip(risky, now, late, strict=True)
    }
    return [judged.get(id(s), s) for s in scored]


def trial_json(s: Scored) -> dict[str, Any]:
    r = s.record
    return {
        "index": r.index,
        "truly_risky": s.truly_risky,
        "discarded": s.discarded,
        "predicted": s.predicted,
        "acted": r.action is not None,
        "in_time": (r.action or {}).get("in_time"),
        "collided": r.collided,
        "saveable": s.saveable,
        "standoff_saveable": s.standoff_saveable,
        "saveable_after_delay": s.saveable_after_delay,
        "robot_caused": r.collided and not s.truly_risky,
        "robot_tripped": s.robot_tripped,
        "reason": (r.action or {}).get("reason"),
        "head_start_ms": r.head_start_ms,
        "idle_min_clearance": s.idle_clearance,
        "risk_probability": (r.risky or {}).get("probability"),
        "person_seen_at": r.person_seen_at,
        "risk_at_time": (r.risky or {}).get("at_time"),
        "time_to_collision": (r.risky or {}).get("time_to_collision"),
        "reaction_ms": r.reaction_ms,
        "decision_ms": r.decision_ms,
        "e2e_ms": r.e2e_ms,
        "collisions": r.outcome.get("collisions", []),
        "duration": r.outcome.get("duration"),
        "fall_seen_after_s": list(s.seen.delays),
        "fall_marks": [{"at_time": m.at_time, "at": list(m.at)} for m in r.fall_marks.values()],
        "fall_answers": {action: list(s.answers(action).values()) for action in r.answers},
        "falls": [
            {
                "person": f.person,
                "falls_at": f.falls_at,
                "flagged_at": f.flagged_at,
                "fell_acting": f.fell_acting,
                "saveable": f.person in s.saveable_people if s.saveable is not None else None,
            }
            for f in s.falls
        ],
    }


def experiment(
    scenario_path: str,
    trials: int,
    seed: int,
    *,
    rate: float = 4.0,
    json_out: Path | None = None,
    figures: Path | None = None,
    console: Console | None = None,
    logdir: Path | None = None,
    nominal: bool = False,
    compare: Path | None = None,
    only: list[int] | None = None,
    record_searches: bool = False,
    min_track: float = 0.0,
) -> dict[str, Any]:
    """Start the stack, run the trials, print Table I, write the JSON and figures; returns the results.

    ``only`` runs those trials of the seed's sequence instead of the first ``trials``. With
    ``record_searches`` the simulator records its batches of robot moves under ``<logs>/searches``. ``min_track``
    is how long a person is in W before Algorithm 1 guesses their walks.
    """
    from . import figures as figs

    console = console or Console()
    scenario = load_scenario(scenario_path)
    graph = f"exp{int(time.time() * 1000) % 10_000_000}"
    logs = logdir or Path(tempfile.mkdtemp(prefix="wm-experiment-"))
    indices: list[int | None] = [None] if nominal else list(only if only is not None else range(trials))
    started = time.monotonic()
    record = logs / "searches" if record_searches else None
    with Stack(graph, scenario_path, logs, rate=rate, record=record, min_track=min_track) as stack:
        console.print(
            f"stack up: {len(stack.names)} processes on {stack.endpoint}, simulated clock x{rate:g}, logs in {logs}"
        )
        scored = asyncio.run(run_trials(scenario, stack, seed, indices, console, graph))
    scored = with_oracle(scenario, seed, scored, console)
    result = metrics(scored)
    result.update(
        scenario=scenario.name,
        # A scenario file of the user's own is recorded by path, so that the run can be replayed offline.
        scenario_file=str(Path(scenario_path).resolve()) if Path(scenario_path).is_file() else scenario_path,
        seed=seed,
        rate=rate,
        sensor_noise=scenario.sensors.enabled,
        wall_s=time.monotonic() - started,
        min_track=min_track,
        paper=PAPER,
    )
    console.print(table(result))
    console.print(prevention_line(result))
    if figures is not None:
        lost = {t["index"] for t in json.loads(compare.read_text())["per_trial"] if t["collided"]} if compare else set()
        result["figures"] = [str(p) for p in figs.write_all(scored, figures, lost)]
    if json_out is not None:
        json_out.parent.mkdir(parents=True, exist_ok=True)
        json_out.write_text(json.dumps({**result, "per_trial": [trial_json(s) for s in scored]}, indent=2))
    result["_scored"] = scored
    return result
