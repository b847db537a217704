"""Algorithm 2 in a closed loop on noisy beliefs, in process: looking again at a danger saves a person.

Seed 2024's trial 50, from the moment the live run first saw its danger, on one drawn sequence of beliefs:
acting on the first look alone, the robot's move fails in the truth; looking again every half second, as the
action agent does, the response replaces it and the person is saved.
"""

import pytest
from recorded_cases import JUDGING, THRESHOLD

from agents.caregiving.model.planner import GridPlanner
from agents.caregiving.model.scenario import load_scenario
from bridges.experiment.beliefs import Noise
from bridges.experiment.closed_loop import Setup, closed_loop
from bridges.world.bridge import trial_for

SEED, INDEX, AT, DRAW = 2024, 50, 0.6, 1
START_DELAY = 0.1  # seconds from a look to the robot's start, as bench/bench_closed_loop.py's default


@pytest.fixture(scope="module")
def case() -> tuple:
    scenario = load_scenario("paper_experiment1")
    return trial_for(scenario, SEED, INDEX), GridPlanner(scenario.scene().bounds)


def setup(first_look_only: bool) -> Setup:
    return Setup(START_DELAY, JUDGING, 0.5, 0.5, first_look_only, Noise(), THRESHOLD)


def test_acting_on_the_first_look_alone_loses_the_person(case) -> None:
    trial, planner = case
    loop = closed_loop(trial, AT, planner, (INDEX, DRAW), setup(first_look_only=True))
    assert loop.looks == 1 and loop.commands >= 1
    assert [c.person for c in loop.truth.outcome().collisions] == ["person"]


def test_looking_again_replaces_the_move_and_saves_the_person(case) -> None:
    trial, planner = case
    loop = closed_loop(trial, AT, planner, (INDEX, DRAW), setup(first_look_only=False))
    assert loop.looks > 1 and loop.responses.get("send", 0) >= 2
    assert loop.truth.outcome().collisions == ()


def test_the_same_seed_draws_the_same_loop(case) -> None:
    trial, planner = case
    once, again = (closed_loop(trial, AT, planner, (INDEX, DRAW), setup(False)) for _ in range(2))
    assert (once.looks, once.commands, once.judged, once.responses) == (
        again.looks,
        again.commands,
        again.judged,
        again.responses,
    )
