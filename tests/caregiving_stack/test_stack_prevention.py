"""Prevention over the real processes: a free pose saves where no stand-off can; a tripping move is never sent.

Trial 13 of seed 7 of the box-obstacle room, with exact sensors so that the closed loop sees what the
oracle sees: when the danger shows, no stand-off around any object commanded then saves the person, but a
free pose does; the move search refuses candidates after which the joint imagination has the person walk
into the robot, and the robot saves the person.
"""

from __future__ import annotations

from collections.abc import Iterator
from pathlib import Path

import pytest
from stack_helpers import GRAPH, run_trial

from bridges.world.bridge import trial_for
from caregiving.planner import GridPlanner
from caregiving.scenario import load_scenario
from caregiving.world_model import run_idle
from caregiving_stack.launch import Stack
from caregiving_stack.oracle import oracle

SCENARIO = str(Path(__file__).parent / "scenarios" / "box_obstacle_exact.yaml")
SEED, INDEX = 7, 13


@pytest.fixture(scope="module")
def stack(tmp_path_factory: pytest.TempPathFactory) -> Iterator[Stack]:
    with Stack(GRAPH, SCENARIO, tmp_path_factory.mktemp("prevention-logs"), rate=1.0) as s:
        yield s


def test_a_trial_only_a_free_pose_can_save_is_saved(stack: Stack) -> None:
    trial = trial_for(load_scenario(SCENARIO), SEED, INDEX)
    planner = GridPlanner(trial.scene().bounds)
    assert run_idle(trial, planner=planner).collided
    r = run_trial(stack, SCENARIO, SEED, INDEX)
    assert r.risky is not None and r.action is not None
    verdict = oracle(trial, r.risky["at_time"], planner)
    assert verdict.saveable and not verdict.standoff_saveable
    assert [c for c in r.outcome["commands"] if c["accepted"]]
    assert r.outcome["collisions"] == []


def test_a_move_that_would_trip_the_person_is_never_sent(stack: Stack) -> None:
    r = run_trial(stack, SCENARIO, SEED, INDEX)
    log = (stack.logdir / "action.log").read_text()
    refusals = [line for line in log.splitlines() if "move chosen" in line and "walks into robot" in line]
    assert refusals, "the search met and refused moves after which the person walks into the robot"
    assert r.action is not None and r.outcome["collisions"] == []
    for index in (3, 17):  # no move keeps the person safe: none is sent, and nothing worse than idle happens
        idle = run_idle(trial_for(load_scenario(SCENARIO), SEED, index))
        r = run_trial(stack, SCENARIO, SEED, index)
        assert r.risky is not None
        assert {c["obstacle"] for c in r.outcome["collisions"]} <= {c.obstacle for c in idle.collisions}
        assert all(c["obstacle"] != "robot" for c in r.outcome["collisions"])
