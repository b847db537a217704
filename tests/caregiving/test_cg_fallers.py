"""Each fall with the robot idle, scored by whether its own person was flagged before it, and saved."""

from __future__ import annotations

import pytest
from outcomes import fall

from agents.caregiving.model.scenario import load_scenario
from agents.caregiving.model.world_model import World
from bridges.experiment.experiment import Scored, metrics
from bridges.experiment.fallers import Faller, Mark, fallers, position_at
from bridges.experiment.trials import TrialRecord


def _two_people() -> World:
    """The shipped room of two people, run with the robot idle: ``person`` walks into the ball, the visitor not."""
    idle = World.from_scenario(load_scenario("two_people"))
    idle.run()
    assert [c.person for c in idle.outcome().collisions] == ["person"]
    return idle


def _flag(idle: World, person: str, at_time: float, off: float = 0.0) -> Mark:
    x, y = position_at(idle, person, at_time)
    return Mark(at_time, (x + off, y))


def test_a_fall_whose_person_was_flagged_before_it_counts_with_its_lead() -> None:
    idle = _two_people()
    (fall,) = fallers(idle, [_flag(idle, "person", 0.6, off=0.05)], ())
    assert fall.person == "person"
    assert fall.flagged_at == 0.6
    assert fall.lead == pytest.approx(idle.outcome().collisions[0].time - 0.6)


def test_a_false_alarm_about_someone_else_does_not_flag_the_person_who_falls() -> None:
    idle = _two_people()
    (fall,) = fallers(idle, [_flag(idle, "visitor", 0.6)], ())
    assert fall.flagged_at is None and fall.lead is None


def test_a_flag_after_the_fall_does_not_count() -> None:
    idle = _two_people()
    falls_at = idle.outcome().collisions[0].time
    (fall,) = fallers(idle, [_flag(idle, "person", falls_at + 0.5)], ())
    assert fall.flagged_at is None


def test_the_earliest_of_a_persons_flags_counts() -> None:
    idle = _two_people()
    (fall,) = fallers(idle, [_flag(idle, "person", 2.0), _flag(idle, "person", 1.0)], ())
    assert fall.flagged_at == 1.0


def test_a_position_is_where_the_person_stood_then_and_where_they_stopped_after() -> None:
    idle = _two_people()
    track = idle.walker("person").track
    assert position_at(idle, "person", 0.0) == track[0]
    assert position_at(idle, "person", 10 * idle.dt) == track[10]
    assert position_at(idle, "person", 1e6) == track[-1]


def test_recall_by_person_sees_the_miss_that_recall_by_trial_hides() -> None:
    idle = _two_people()
    missed = fallers(idle, [_flag(idle, "visitor", 0.6)], {"person"})
    caught = fallers(idle, [_flag(idle, "person", 0.6)], ())
    fell = frozenset({"person"})
    record = TrialRecord(0, intentions=1, risky={"probability": 1.0})
    m = metrics([Scored(record, fell, falls=missed), Scored(record, fell, falls=caught)])
    assert m["recall"] == 1.0
    assert m["people_at_risk"] == 2
    assert m["person_recall"] == 0.5
    assert m["flag_lead_s_min"] == m["flag_lead_s_p50"] == pytest.approx(caught[0].lead)
    assert m["people_saved"] == 1 and m["person_prevention_rate"] == 0.5


def test_saving_one_of_two_who_fall_counts_by_person_though_the_trial_is_not_prevented() -> None:
    falls = (Faller("ana", 4.0, 0.5, fell_acting=False), Faller("ben", 6.0, 0.5, fell_acting=True))
    record = TrialRecord(0, intentions=1, risky={"probability": 1.0}, outcome={"collisions": [fall("ben")]})
    scored = Scored(record, frozenset({"ana", "ben"}), saveable=False, falls=falls, saveable_people=frozenset({"ana"}))
    m = metrics([scored])
    assert m["prevented"] == 0 and m["oracle_saveable"] == 0
    assert m["people_at_risk"] == 2 and m["people_saved"] == 1 and m["person_prevention_rate"] == 0.5
    assert m["people_saveable"] == m["people_saved_saveable"] == 1
    assert m["person_prevention_rate_of_saveable"] == 1.0
