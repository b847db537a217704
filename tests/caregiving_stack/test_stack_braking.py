"""A head start braked over the real processes: face to face (held out), seed 3, trial 0, where no move is found.

The first search of a stack is imagined at the untimed estimate of a candidate's cost, well above what one
costs, so it ends long before the moment it judged braking at. Its searches are recorded.
"""

from __future__ import annotations

from collections.abc import Iterator
from pathlib import Path

import pytest
from stack_helpers import recording_stack, run_trial

from agents.caregiving.model.recorded_batch import read_batches
from agents.caregiving.model.rollout import DT
from agents.caregiving.names import MOVE_TO, STOP
from bridges.experiment.launch import Stack

SCENARIO = str(Path(__file__).resolve().parents[2] / "docs" / "results" / "heldout" / "face_to_face.yaml")
SEED, INDEX = 3, 0


@pytest.fixture(scope="module")
def stack(tmp_path_factory: pytest.TempPathFactory) -> Iterator[Stack]:
    yield from recording_stack(tmp_path_factory, SCENARIO, 1.0)


def test_a_head_start_is_braked_no_sooner_than_its_search_judged_braking(stack: Stack) -> None:
    """Braked as soon as its search ended, the robot stopped short of the pose braking was judged harmless at."""
    r = run_trial(stack, SCENARIO, SEED, INDEX)
    commands = [c for c in r.outcome["commands"] if c["accepted"]]
    assert [c["action"] for c in commands[:2]] == [MOVE_TO, STOP], "a head start went out, then braking"
    batch = next(b for b in read_batches(stack.logdir / "searches") if b.reply.search and b.reply.search.halt)
    found = batch.reply.search
    assert found is not None and found.chosen is None and found.sets_off is not None
    # The world acts on a command at its next step, and a hold may end a step early (see agents.caregiving.set_off).
    assert commands[1]["time"] + DT >= batch.scene.time + found.sets_off - 2 * DT - 1e-9
