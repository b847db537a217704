"""``wm experiment`` end to end on a couple of chosen trials: the table, the JSON keys and the figures."""

from __future__ import annotations

import json
import subprocess
from pathlib import Path

from agents.caregiving.model.recorded_batch import read_batches
from procs import REPO, WM

KEYS = {
    "trials",
    "discarded",
    "accuracy",
    "precision",
    "recall",
    "f1",
    "f2",
    "fp_rate",
    "fn_rate",
    "reaction_ms_mean",
    "reaction_ms_sd",
    "e2e_ms_p50",
    "e2e_ms_p99",
    "action_rate",
    "prevention_rate",
    "action_in_time_rate",
    "action_rate_saveable",
    "action_in_time_rate_saveable",
    "oracle_saveable",
    "oracle_standoff_saveable",
    "prevention_rate_of_saveable",
    "pipeline_delay_ms_p50",
    "oracle_saveable_after_delay",
    "prevention_rate_of_saveable_after_delay",
    "robot_caused_collisions",
    "robot_tripped_people",
    "people_at_risk",
    "people_flagged",
    "person_recall",
    "flag_lead_s_p50",
    "flag_lead_s_min",
    "people_saved",
    "person_prevention_rate",
    "people_saveable",
    "people_saved_saveable",
    "person_prevention_rate_of_saveable",
}


def experiment(*args: str) -> subprocess.CompletedProcess[str]:
    """``wm experiment paper_experiment1 --seed 7 --rate 2 ARGS...``, run to its end."""
    return subprocess.run(
        [*WM, "experiment", "paper_experiment1", "--seed", "7", "--rate", "2", *args],
        check=False,
        capture_output=True,
        text=True,
        timeout=240,
        cwd=REPO,
    )


def test_short_experiment_writes_table_json_and_figures(tmp_path: Path) -> None:
    out, figures, logs = tmp_path / "exp.json", tmp_path / "figures", tmp_path / "logs"
    result = experiment(
        "--only", "1,0", "--json", str(out), "--figures", str(figures), "--logs", str(logs), "--record-searches"
    )
    assert result.returncode == 0, result.stderr[-3000:]
    served = (logs / "simulation.log").read_text().count("served robot moves")
    assert len(read_batches(logs / "searches")) == served  # the simulator recorded every batch of robot moves
    assert "Experiment 1 (Table I)" in result.stdout and "747.0 ms" in result.stdout
    data = json.loads(out.read_text())
    assert KEYS <= data.keys()
    assert data["trials"] == 2 and [t["index"] for t in data["per_trial"]] == [1, 0]
    assert all(isinstance(t["robot_tripped"], list) for t in data["per_trial"])
    # Every fall with the robot idle is scored on its own, its person flagged, if at all, before it.
    falls = [f for t in data["per_trial"] for f in t["falls"]]
    assert [bool(t["falls"]) for t in data["per_trial"]] == [t["truly_risky"] for t in data["per_trial"]]
    assert data["people_at_risk"] == len(falls) and data["people_flagged"] == sum(
        f["flagged_at"] is not None for f in falls
    )
    assert all(f["flagged_at"] <= f["falls_at"] for f in falls if f["flagged_at"] is not None)
    assert data["people_saved"] == sum(not f["fell_acting"] for f in falls)
    assert data["sensor_noise"] is True and data["paper"]["precision"] == 0.61
    assert data["scenario"] == data["scenario_file"] == "paper_experiment1"  # a shipped scenario, by name
    assert (figures / "reaction_times.png").stat().st_size > 0

    # Again into the same log directory: each process's log keeps the last run's lines, ready marker included,
    # and this run must still wait for its own processes to be ready.
    again = experiment("--only", "0", "--logs", str(logs))
    assert again.returncode == 0, again.stderr[-3000:]
    assert (logs / "world.log").read_text().count("launch: starting") == 2


def test_a_stand_off_that_walks_her_into_the_ball_where_the_idle_robot_keeps_her_clear_is_never_sent(
    tmp_path: Path,
) -> None:
    """The paper's room at seed 12011, trial 21, in real time: she passes the ball by 2.2 cm with the robot idle
    and is flagged. The stand-off sent before lowered her sampled risk, but in worlds of its own she walked round
    the robot into the ball, and in the truth she did, in every run. It is refused for those worlds, a move is
    still sent, and nobody falls. Algorithm 1 guesses from 0.3 s into her track, as in the runs the trial was
    found in: guessing from her first frame, no search of hers refuses a move for those worlds."""
    out, logs = tmp_path / "out.json", tmp_path / "logs"
    done = subprocess.run(
        [*WM, "experiment", "paper_experiment1", "--seed", "12011", "--rate", "1", "--only", "21", "--min-track", "0.3"]
        + ["--json", str(out), "--logs", str(logs), "--record-searches"],
        check=False,
        capture_output=True,
        text=True,
        timeout=240,
        cwd=REPO,
    )
    assert done.returncode == 0, done.stderr[-2000:]
    result = json.loads(out.read_text())
    trial = result["per_trial"][0]
    assert trial["index"] == 21 and not trial["truly_risky"] and trial["predicted"] and trial["acted"]
    assert not trial["collided"] and result["robot_caused_collisions"] == 0
    verdicts = [
        v
        for batch in read_batches(logs / "searches")
        for answer in batch.reply.results
        if answer.search is not None
        for v in answer.search.verdicts
    ]
    assert any(v.reason.endswith("sampled worlds where the robot as it is keeps them clear") for v in verdicts)
