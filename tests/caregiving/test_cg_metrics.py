"""The experiment's figures: the action rates over all detections and where the oracle allows a move."""

from __future__ import annotations

import pytest
from outcomes import fall

from bridges.experiment.experiment import Scored, metrics, pipeline_delay, prevention_line
from bridges.experiment.fallers import Faller, Mark
from bridges.experiment.falls_seen import falls_seen
from bridges.experiment.trials import TrialRecord

#: Who collides with the robot idle: somebody (a truly risky trial), or nobody.
FELL, NOBODY = frozenset({"p"}), frozenset[str]()


def _trial(index: int, risky: bool, saveable: bool | None, action: dict[str, object] | None) -> Scored:
    record = TrialRecord(index, intentions=1, risky={"probability": 1.0}, action=action)
    return Scored(record, FELL if risky else NOBODY, saveable=saveable, standoff_saveable=saveable)


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
    scored = [Scored(TrialRecord(0, intentions=1), NOBODY)]
    m = metrics(scored)
    assert m["action_rate"] is None and m["action_rate_saveable"] is None


def _commanded(index: int, at: float, command: float | None, saveable: bool, late: bool, collided: bool) -> Scored:
    outcome: dict[str, object] = {"collisions": [fall("p")] if collided else []}
    if command is not None:
        outcome["commands"] = [{"time": command, "move": None, "accepted": True}]
    record = TrialRecord(index, intentions=1, risky={"probability": 1.0, "at_time": at}, outcome=outcome)
    return Scored(record, FELL, saveable=saveable, standoff_saveable=saveable, saveable_after_delay=late)


def test_the_pipeline_delay_and_the_trials_still_saveable_that_late() -> None:
    scored = [
        _commanded(0, 0.5, 0.6, True, True, False),  # 0.1 s: saved, and still saveable that late
        _commanded(1, 0.5, 0.75, True, False, True),  # 0.25 s: only a move at once could have saved it
        _commanded(2, 0.6, 0.8, True, True, True),  # 0.2 s: lost though a move that late could save it
        _commanded(3, 0.6, None, False, False, True),  # never commanded: no delay of its own
    ]
    assert pipeline_delay(scored) == pytest.approx(0.2)
    m = metrics(scored)
    assert m["pipeline_delay_ms_p50"] == pytest.approx(200.0)
    assert m["oracle_saveable"] == 3 and m["oracle_saveable_after_delay"] == 2
    assert m["prevented_saveable_after_delay"] == 1 and m["prevention_rate_of_saveable_after_delay"] == 0.5
    assert "1 of the 2 still saveable 200 ms later" in prevention_line(m)


def test_no_command_means_no_delay_and_no_late_oracle() -> None:
    m = metrics([_commanded(0, 0.5, None, True, False, True)])
    assert m["pipeline_delay_ms_p50"] is None and m["oracle_saveable_after_delay"] is None
    assert "later" not in prevention_line(m)


def test_a_head_start_is_neither_an_action_nor_a_reaction_but_the_robots_first_response() -> None:
    head = {"risk_at": 1.0, "created_at": 1.03, "head_start": True}
    move = {"risk_at": 1.0, "created_at": 1.09, "observed_at": 0.99, "in_time": True}
    led = Scored(TrialRecord(0, intentions=1, risky={"probability": 1.0}, action=move, head_start=head), FELL)
    only_head = Scored(TrialRecord(1, intentions=1, risky={"probability": 1.0}, head_start=head), FELL)
    m = metrics([led, only_head, _trial(2, True, True, move)])
    assert m["action_rate"] == 2 / 3 and m["head_starts"] == 2
    assert m["reaction_ms_mean"] == pytest.approx(90.0)
    assert m["head_start_ms_p50"] == pytest.approx(30.0)
    assert m["first_response_ms_mean"] == pytest.approx((30.0 + 30.0 + 90.0) / 3)


def test_the_reaction_is_the_head_start_the_action_drives_on_with() -> None:
    pose = {"action": "move_to", "target": 7, "final_pose": [1.0, 2.0, 0.5]}
    head = {"risk_at": 1.0, "created_at": 1.02, "observed_at": 0.99, "head_start": True, **pose}
    same = {"risk_at": 1.0, "created_at": 1.08, "observed_at": 0.99, "in_time": True, **pose}
    other = {**same, "final_pose": [1.0, 2.2, 0.5]}
    driven_on = TrialRecord(0, 1, {"probability": 1.0}, same, head, head)
    switched = TrialRecord(1, 1, {"probability": 1.0}, other, head, head)
    assert driven_on.reaction_ms == pytest.approx(20.0) and driven_on.e2e_ms == pytest.approx(30.0)
    assert switched.reaction_ms == pytest.approx(80.0) and switched.e2e_ms == pytest.approx(90.0)
    m = metrics([Scored(driven_on, FELL), Scored(switched, FELL)])
    assert m["reaction_ms_mean"] == pytest.approx(50.0) and m["decision_ms_mean"] == pytest.approx(80.0)


def test_a_person_tripped_by_the_robot_is_counted_even_where_somebody_else_falls_anyway() -> None:
    """Trial 0 is safe idle and Ben falls with the robot acting (one robot-caused collision, one person); in
    trial 1 Ada falls either way and Ben only with the robot acting (no robot-caused trial, one person)."""

    def trial(index: int, fell_acting: list[str], fell_idle: frozenset[str]) -> Scored:
        record = TrialRecord(index, intentions=1, outcome={"collisions": [fall(p) for p in fell_acting]})
        return Scored(record, fell_idle)

    scored = [
        trial(0, ["ben"], frozenset()),
        trial(1, ["ada", "ben"], frozenset({"ada"})),
        trial(2, ["ada"], frozenset({"ada"})),
    ]
    m = metrics(scored)
    assert m["robot_caused_collisions"] == 1
    assert m["robot_tripped_people"] == 2
    assert [s.robot_tripped for s in scored] == [["ben"], ["ben"], []]


def test_a_fall_is_seen_by_the_first_mark_near_it_at_or_after_it_and_a_mark_of_no_fall_is_false() -> None:
    marks = {
        1: Mark(5.2, (0.1, 0.0)),  # Ana, lying where she fell
        2: Mark(4.0, (3.0, 0.0)),  # before Ben's fall, and far from it: a fall seen where nobody fell
        3: Mark(7.3, (2.9, 0.1)),  # Ben, lying
    }
    falls = [fall("ana", 5.0, (0.0, 0.0)), fall("ben", 7.0, (3.0, 0.0)), fall("cy", 8.0, (-3.0, 0.0))]
    # Dee, the last one walking, falls and the trial ends a step later: no frame could show her lying.
    falls.append(fall("dee", 9.5, (1.0, 1.0)))
    seen = falls_seen(falls, marks.values(), ended_at=9.55)
    assert seen.delays == (pytest.approx(0.2), pytest.approx(0.3), None, None) and seen.unmatched == 1
    assert seen.seeable == (True, True, True, False)
    record = TrialRecord(0, intentions=1, outcome={"collisions": falls, "duration": 9.55}, fall_marks=marks)
    m = metrics([Scored(record, frozenset({"ana", "ben", "cy", "dee"}))])
    assert (m["falls_acting"], m["falls_seeable"], m["falls_seen"], m["false_fall_marks"]) == (4, 3, 2, 1)
    assert m["fall_seen_after_s_p50"] == pytest.approx(0.25) and m["fall_seen_after_s_max"] == pytest.approx(0.3)


def test_a_move_to_someone_fallen_is_no_command_against_a_danger() -> None:
    """The robot sent to someone lying there before any move against the danger: the pipeline's delay is timed to
    the first command against it, or not at all."""
    going = {"time": 0.7, "move": {"target": "1", "x": 0.0, "y": 0.0, "heading": 0.0}, "accepted": True}
    late = _commanded(0, 0.5, 0.9, True, True, True)
    late.record.outcome["commands"].insert(0, {**going, "action": "go_to"})
    only = _commanded(1, 0.5, None, True, False, True)
    only.record.outcome["commands"] = [{**going, "action": "go_to"}]
    assert pipeline_delay([late]) == pytest.approx(0.4) and pipeline_delay([only]) is None


def test_each_person_marked_fallen_is_answered_with_an_alert_and_the_robot_sent_to_them() -> None:
    marks = {1: Mark(5.2, (0.1, 0.0)), 3: Mark(7.3, (2.9, 0.1))}
    answers = {"alert": {1: 5.25, 3: 7.4}, "go_to": {1: 5.6, 7: 2.0}}  # node 7: not marked fallen, no answer
    record = TrialRecord(
        0, intentions=1, outcome={"collisions": [], "duration": 9.0}, fall_marks=marks, answers=answers
    )
    m = metrics([Scored(record, NOBODY)])
    assert (m["fall_marks"], m["falls_alerted"], m["fallen_gone_to"]) == (2, 2, 1)
    assert m["alert_after_mark_s_max"] == pytest.approx(0.1)


def test_a_fall_in_a_trial_discarded_for_want_of_any_intention_counts_as_never_flagged() -> None:
    """Trial 0 has no intention at all (the person came into view too late): Table I's figures leave it out, as
    the paper does, but the person who fell there counts against the recall by person and is shown apart."""
    unseen = Scored(TrialRecord(0, intentions=0), FELL, falls=(Faller("p", 3.0, None, True),))
    flagged = Scored(
        TrialRecord(1, intentions=1, risky={"probability": 1.0}), FELL, falls=(Faller("p", 4.0, 2.5, True),)
    )
    m = metrics([unseen, flagged])
    assert (m["discarded"], m["discarded_truly_risky"], m["valid"], m["recall"]) == (1, 1, 1, 1.0)
    assert (m["people_at_risk"], m["person_recall"]) == (2, 0.5)
