"""The experiment's figures: the action rates over all detections and where the oracle allows a move."""

from __future__ import annotations

from bridges.experiment.experiment import Scored, metrics
from bridges.experiment.trials import TrialRecord


def _trial(index: int, risky: bool, saveable: bool | None, action: dict[str, object] | None) -> Scored:
    record = TrialRecord(index, intentions=1, risky={"probability": 1.0}, action=action)
    return Scored(record, truly_risky=risky, saveable=saveable, standoff_saveable=saveable)


def test_action_rates_over_all_detections_and_over_the_saveable_ones() -> None:
    stamps = {"risk_at": 1.0, "created_at": 1.02, "observed_at": 0.99}
    late, in_time = {**stamps, "in_time": False}, {**stamps, "in_time": True}
    scored = [
        _trial(0, True, True, in_time),
        _trial(1, True, True, late),
        _trial(2, True, True, None),
        _trial(3, True, False, None),  # no move could save it: counts only over all detections
        _trial(4, False, None, None),  # a false positive: not judged by the oracle
        _trial(5, False, None, late),
    ]
    m = metrics(scored)
    assert m["action_rate"] == 3 / 6
    assert m["action_in_time_rate"] == 1 / 6
    assert m["action_rate_saveable"] == 2 / 3
    assert m["action_in_time_rate_saveable"] == 1 / 3
    assert m["oracle_saveable"] == 3


def test_action_rates_are_absent_without_detections() -> None:
    scored = [Scored(TrialRecord(0, intentions=1), truly_risky=False)]
    m = metrics(scored)
    assert m["action_rate"] is None and m["action_rate_saveable"] is None
