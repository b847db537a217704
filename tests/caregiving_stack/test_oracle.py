"""The physical oracle against an exhaustive search of the same move set, on fixed trials."""

from __future__ import annotations

import pytest

from agents.caregiving.model.planner import GridPlanner
from agents.caregiving.model.scenario import load_scenario
from agents.caregiving.model.world_model import run_idle
from bridges.experiment.oracle import oracle, saving_moves, standoff_moves_all, world_at
from bridges.world.bridge import trial_for

SEED, AT = 48611, 0.5


@pytest.mark.parametrize(
    ("index", "saveable", "by_standoff"),
    [
        (37, True, False),  # only a free pose on the lattice saves the person
        (21, False, False),  # the person starts too close to the ball for any move
    ],
)
def test_oracle_agrees_with_the_exhaustive_search(index: int, saveable: bool, by_standoff: bool) -> None:
    scenario = load_scenario("paper_experiment1")
    trial = trial_for(scenario, SEED, index)
    planner = GridPlanner(scenario.scene().bounds)
    assert run_idle(trial, planner=planner).collided
    verdict = oracle(trial, AT, planner)
    saving = saving_moves(trial, AT, planner)
    standoffs = standoff_moves_all(world_at(trial, AT, planner).scene())
    assert verdict.saveable == bool(saving) == saveable
    assert verdict.standoff_saveable == any(m in standoffs for m in saving) == by_standoff
    assert verdict.move is None or verdict.move in saving
