"""Over the real processes: a danger found at one gaze class that no move removes is searched at another.

In the café room (exact sensors, half speed, seed 90210, trial 0) the guest heads for the counter past a
low table. Looking far ahead (the higher of her two gaze classes) she never sees the table and walks into
it; looking nearer she sees it, goes round, and trips on a tray dropped beyond: what she truly does.
Algorithm 1 reports the danger that comes soonest, the table's, and no move saves her from it. The search
then looks for her at the other class: a stand-off by the tray saves her there and leaves her no worse off
at the first, and the robot sends it and saves her.
"""

from __future__ import annotations

from collections.abc import Iterator

import pytest
from stack_helpers import SCENARIOS, recording_stack, run_trial

from agents.caregiving.model.planner import GridPlanner
from agents.caregiving.model.scenario import load_scenario
from agents.caregiving.model.world_model import run_idle
from bridges.experiment.launch import Stack
from bridges.world.bridge import trial_for

SCENARIO = str(SCENARIOS / "cafe_tables_exact.yaml")
SEED, INDEX = 90210, 0


@pytest.fixture(scope="module")
def stack(tmp_path_factory: pytest.TempPathFactory) -> Iterator[Stack]:
    yield from recording_stack(tmp_path_factory, SCENARIO, 0.5)


def test_a_move_found_at_another_gaze_class_saves_the_guest(stack: Stack) -> None:
    trial = trial_for(load_scenario(SCENARIO), SEED, INDEX)
    idle = run_idle(trial, planner=GridPlanner(trial.scene().bounds))
    assert [(c.person, c.obstacle) for c in idle.collisions] == [("guest", "tray")]
    r = run_trial(stack, SCENARIO, SEED, INDEX)
    assert r.risky is not None and r.action is not None
    assert "none at the gaze found first; searched at" in r.action["reason"]
    assert r.outcome["collisions"] == []
