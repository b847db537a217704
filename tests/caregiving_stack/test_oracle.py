"""The physical oracle against an exhaustive search of the same move set, on fixed trials."""

from __future__ import annotations

from pathlib import Path

import pytest

from agents.caregiving.model.planner import GridPlanner
from agents.caregiving.model.scenario import load_scenario
from agents.caregiving.model.world_model import run_idle
from bridges.experiment.oracle import (
    fell_after,
    idle_from,
    lattice_moves,
    oracle,
    saving_moves,
    standoff_moves_all,
    world_at,
)
from bridges.world.bridge import trial_for

SEED, AT = 48611, 0.5
HELD_OUT = Path(__file__).resolve().parents[2] / "docs" / "results" / "heldout"


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
    assert verdict.saveable_people == ({"person"} if saveable else set())  # one person: saveable with the trial


def test_a_person_one_move_saves_alone_is_saveable_where_the_trial_is_not() -> None:
    """Day room, seed 8123, trial 2: Tom trips on the handbag at 3.95 s and Rosa on the cushion at 7.05 s; no move
    saves both, and some saves Rosa alone without tripping anyone else. The exhaustive search agrees."""
    scenario = load_scenario(str(HELD_OUT / "dayroom_two_walkers.yaml"))
    trial = trial_for(scenario, 8123, 2)
    planner = GridPlanner(scenario.scene().bounds)
    assert {c.person for c in run_idle(trial, planner=planner).collisions} == {"tom", "rosa"}
    verdict = oracle(trial, 0.65, planner)
    world = world_at(trial, 0.65, planner)
    fallers = frozenset({"tom", "rosa"})
    alone = set()
    for move in [*standoff_moves_all(world.scene()), *lattice_moves(world, idle_from(world))]:
        fell = fell_after(world, move)
        if fell is not None and fell <= fallers:
            alone |= fallers - fell
    assert not verdict.saveable and not saving_moves(trial, 0.65, planner)
    assert verdict.saveable_people == alone == {"rosa"}
