"""Prevention over the real processes: a saveable trial is saved; a move that trips a person is never sent.

Trials of seed 7 of the box-obstacle room, with exact sensors so that the closed loop sees what the oracle
sees. The room runs at half speed: these tests check what the search decides, not how fast the pipeline is
(the experiment measures that), so a loaded machine must not turn a saving decision into a late one. The
saved trial is one whose saving moves stay many for seconds after the danger shows, for the same reason.
"""

from __future__ import annotations

from collections.abc import Iterator
from pathlib import Path

import pytest
from stack_helpers import GRAPH, run_trial

from agents.caregiving.model.planner import GridPlanner
from agents.caregiving.model.scenario import load_scenario
from agents.caregiving.model.world_model import run_idle
from bridges.experiment.launch import Stack
from bridges.experiment.oracle import oracle
from bridges.world.bridge import trial_for

SCENARIO = str(Path(__file__).parent / "scenarios" / "box_obstacle_exact.yaml")
SEED, SAVEABLE, UNSAVEABLE = 7, 25, (5, 42)


@pytest.fixture(scope="module")
def stack(tmp_path_factory: pytest.TempPathFactory) -> Iterator[Stack]:
    with Stack(GRAPH, SCENARIO, tmp_path_factory.mktemp("prevention-logs"), rate=0.5) as s:
        yield s


def test_a_saveable_trial_is_saved(stack: Stack) -> None:
    trial = trial_for(load_scenario(SCENARIO), SEED, SAVEABLE)
    planner = GridPlanner(trial.scene().bounds)
    assert run_idle(trial, planner=planner).collided
    r = run_trial(stack, SCENARIO, SEED, SAVEABLE)
    assert r.risky is not None and r.action is not None
    assert oracle(trial, r.risky["at_time"], planner).saveable
    assert [c for c in r.outcome["commands"] if c["accepted"]]
    assert r.outcome["collisions"] == []


@pytest.mark.parametrize("index", UNSAVEABLE)
def test_where_no_move_saves_nothing_worse_than_idle_happens(stack: Stack, index: int) -> None:
    trial = trial_for(load_scenario(SCENARIO), SEED, index)
    planner = GridPlanner(trial.scene().bounds)
    idle = run_idle(trial, planner=planner)
    r = run_trial(stack, SCENARIO, SEED, index)
    assert r.risky is not None and not oracle(trial, r.risky["at_time"], planner).saveable
    assert {c["obstacle"] for c in r.outcome["collisions"]} <= {c.obstacle for c in idle.collisions}
    assert all(c["obstacle"] != "robot" for c in r.outcome["collisions"])


def test_moves_after_which_a_person_walks_into_the_robot_are_refused(stack: Stack) -> None:
    log = (stack.logdir / "action.log").read_text()
    refusals = [line for line in log.splitlines() if "walks into robot" in line]
    assert refusals, "the search met and refused moves after which the person walks into the robot"
