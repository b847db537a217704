"""Truly risky trials of recorded runs, set up as ``bench/bench_move_search.py`` sets them up.

Perfect belief at the moment a live run first saw the danger, the robot starting one world step
later and 20 ms later per candidate judged.
"""

from pathlib import Path

from agents.caregiving.model.planner import GridPlanner
from agents.caregiving.model.scenario import Scenario, load_scenario
from agents.caregiving.model.scene import Scene
from agents.caregiving.model.search_spec import SearchSpec
from agents.caregiving.model.uncertainty import Uncertainty
from bridges.experiment.perfect_belief import perfect_belief_spec
from bridges.world.bridge import trial_for

EXACT = Uncertainty(0.0, {}, 1)
DELAY, JUDGING, THRESHOLD = 0.05, 0.02, 0.2
HELD_OUT = Path(__file__).resolve().parents[2] / "docs" / "results" / "heldout"
#: The scenario files of the multi-process stack tests.
STACK_SCENARIOS = Path(__file__).resolve().parents[1] / "caregiving_stack" / "scenarios"


def recorded_case(
    scenario: str | Path, seed: int, index: int, at: float
) -> tuple[Scenario, GridPlanner, Scene, SearchSpec]:
    """The trial, its planner, and the exact scene and search spec at ``at``."""
    s = load_scenario(scenario)
    trial, planner = trial_for(s, seed, index), GridPlanner(s.scene().bounds)
    found = perfect_belief_spec(trial, at, planner, DELAY)
    assert found is not None
    return trial, planner, *found
