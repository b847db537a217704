"""A danger found at one gaze class that no move removes is searched at another; the closed loop finds dangers
as Algorithm 1 does.

The café room, seed 90210, trial 0, 0.6 s in, on the exact scene: the guest heads for the counter past a low
table. At the higher of her two gaze classes she never sees it and walks into it; at the lower she sees it,
goes round, and trips on a tray beyond (her true gaze is in that class). Algorithm 1 knows neither her gaze
nor that she saw the table: it reports the danger that comes soonest, the table's, with only what she saw at
every gaze as known. No move saves her from the table; one by the tray saves her at the other class and
leaves her no worse off at the first, and the search sends it.
"""

from dataclasses import replace
from functools import partial

from recorded_cases import HELD_OUT, JUDGING, THRESHOLD

from agents.caregiving.model.move_search import at_another_gaze, search
from agents.caregiving.model.planner import GridPlanner
from agents.caregiving.model.scenario import load_scenario
from agents.caregiving.model.service import serve_one
from agents.caregiving.model.uncertainty import Uncertainty
from agents.caregiving.model.visibility import gaze_classes, surely_seen
from bridges.experiment.oracle import idle_run, saves, world_at
from bridges.experiment.perfect_belief import Gazes, spec_on
from bridges.world.bridge import trial_for

SEED, INDEX, AT, DELAY = 90210, 0, 0.6, 0.05


def cafe() -> tuple:
    scenario = load_scenario(HELD_OUT / "cafe_tables.yaml")
    trial = trial_for(scenario, SEED, INDEX)
    planner = GridPlanner(scenario.scene().bounds)
    now = world_at(trial, AT, planner)
    scene = now.scene()
    seen = {p.name: surely_seen(gaze_classes(p, scene.bodies_around(p.name))) for p in scene.people}
    return trial, planner, idle_run(trial, planner), now, scene, seen


def test_algorithm_1_finds_the_danger_that_comes_soonest_knowing_only_what_was_seen_at_every_gaze() -> None:
    _, _, idle, now, scene, seen = cafe()
    as_live = spec_on(scene, idle, now, DELAY, Gazes.SOONEST, surely_seen=seen)
    by_true_gaze = spec_on(scene, idle, now, DELAY, Gazes.ANY_CLASS)
    assert as_live is not None and by_true_gaze is not None
    assert [d.obstacle for d in as_live.dangers] == ["table_2"]
    assert [d.obstacle for d in by_true_gaze.dangers] == ["tray"]
    assert "table_2" not in as_live.known["guest"] and "table_2" in by_true_gaze.known["guest"]


def test_a_danger_no_move_removes_is_searched_at_another_gaze_class_and_the_move_found_saves() -> None:
    trial, planner, idle, now, scene, seen = cafe()
    spec = spec_on(scene, idle, now, DELAY, Gazes.SOONEST, surely_seen=seen)
    assert spec is not None
    first, second = spec.gazes["guest"]
    other = at_another_gaze(scene, spec)
    assert other is not None and [d.obstacle for d in other.dangers] == ["tray"]
    assert other.gazes["guest"] == (second, first)
    found = search(scene, spec, partial(serve_one, scene), Uncertainty(), THRESHOLD, 32, 1.0, JUDGING)
    assert found.chosen is not None and found.chosen.move is not None
    assert "none at the gaze found first; searched at" in found.chosen.reason
    assert saves(world_at(trial, AT + DELAY + JUDGING * found.judged, planner), found.chosen.move)


def test_a_single_danger_met_at_no_other_gaze_class_is_not_searched_again() -> None:
    _, _, idle, now, scene, seen = cafe()
    spec = spec_on(scene, idle, now, DELAY, Gazes.SOONEST, surely_seen=seen)
    assert spec is not None
    only_first = dict(spec.gazes, guest=spec.gazes["guest"][:1])
    assert at_another_gaze(scene, type(spec)(spec.dangers, only_first, spec.known)) is None


def test_another_gaze_class_where_the_person_meets_the_same_obstacle_is_not_searched_again() -> None:
    """The first search's candidates were made for that obstacle: only a class where the walk meets another counts."""
    _, _, idle, now, scene, seen = cafe()
    spec = spec_on(scene, idle, now, DELAY, Gazes.SOONEST, surely_seen=seen)
    assert spec is not None
    (danger,) = spec.dangers
    assert at_another_gaze(scene, replace(spec, dangers=(replace(danger, obstacle="tray"),))) is None
