"""The assist agent over the real processes, in a room where someone walks on across the robot's way to a fall.

Two people heading for two obstacles, seed 31337, trial 4: the visitor falls into the shoe, and the robot is
sent to her while the other person walks on across its way. Its searches are recorded.
"""

from __future__ import annotations

from collections.abc import Iterator

import pytest
from stack_helpers import recording_stack, run_trial

from agents.caregiving.model.recorded_batch import RecordedBatch, read_batches
from agents.caregiving.model.rollout import DT
from agents.caregiving.names import GO_TO
from bridges.experiment.launch import Stack

SCENARIO, SEED, INDEX = "two_people_two_obstacles", 31337, 4


@pytest.fixture(scope="module")
def stack(tmp_path_factory: pytest.TempPathFactory) -> Iterator[Stack]:
    yield from recording_stack(tmp_path_factory, SCENARIO, 1.0)


def test_a_move_to_someone_fallen_sets_off_no_sooner_than_its_search_imagined(stack: Stack) -> None:
    """The search of the poses beside her imagines each one setting off a judgement later than the one before.
    Sent as soon as the search ended, the move reached the world before the moment it was judged for, and the
    person walked into the robot. It is held until then, as the action agent holds its moves."""
    r = run_trial(stack, SCENARIO, SEED, INDEX)
    sent = [c for c in r.outcome["commands"] if c["action"] == GO_TO and c["accepted"]]
    assert sent, "the robot was sent to the visitor"
    pose = (sent[0]["move"]["x"], sent[0]["move"]["y"])
    batch = next(b for b in reversed(read_batches(stack.logdir / "searches")) if chose(b, pose))
    found = batch.reply.search
    assert found is not None and found.sets_off is not None
    # The world acts on a command at its next step, and a hold may end a step early (see agents.caregiving.set_off).
    assert sent[0]["time"] + DT >= batch.scene.time + found.sets_off - 2 * DT - 1e-9


def chose(batch: RecordedBatch, pose: tuple[float, float]) -> bool:
    """Whether ``batch`` is a search for no danger (poses beside someone fallen) that chose the move to ``pose``."""
    found = batch.reply.search
    return (
        found is not None
        and not batch.items[0]["spec"]["dangers"]
        and found.chosen is not None
        and found.chosen.move is not None
        and (found.chosen.move.x, found.chosen.move.y) == pytest.approx(pose)
    )
