"""A bystander's sampled risk refuses a move only where the move raises it."""

from dataclasses import replace
from functools import partial

from recorded_cases import DELAY, HELD_OUT, JUDGING, THRESHOLD, recorded_case

from agents.caregiving.model.joint import walk_risks, worst_risk
from agents.caregiving.model.judging import as_it_is, judge_move
from agents.caregiving.model.move_search import search
from agents.caregiving.model.service import serve_one
from bridges.experiment.beliefs import perception_uncertainty
from bridges.experiment.perfect_belief import saved_in_truth

AT = 0.65


def test_a_bystanders_risk_the_move_does_not_raise_refuses_no_move() -> None:
    """The crossing hall at seed 29, trial 3: Ana walks towards a toy car while Ben crosses the hall.

    On perception's uncertainty Ben may walk into a bag whatever the robot does (a sampled risk with the robot
    as it is). That risk used to refuse every move, and the search found none; now the search sends a
    stand-off of the toy car, and in the ground truth it saves Ana and trips nobody.
    """
    trial, planner, scene, spec = recorded_case(HELD_OUT / "crossing_hall.yaml", 29, 3, AT)
    uncertainty = perception_uncertainty(scene, trial.sensors, AT, 0)
    imagine = partial(serve_one, scene)

    told = as_it_is(spec, imagine, scene, uncertainty)
    assert [(w.person, risk > 0.0) for w, risk in told.risks_anyway] == [("ben", True)]
    assert not told.falls_anyway

    result = search(scene, spec, imagine, uncertainty, THRESHOLD, 24, judging=JUDGING, head_start=lambda lead: None)
    assert result.chosen is not None and result.chosen.safe(THRESHOLD)
    assert result.chosen.reason.endswith(f"sampled risk with the robot as it is too: ben {told.risks_anyway[0][1]:.2f}")
    assert saved_in_truth(trial, AT, planner, DELAY, JUDGING, result)

    # Not told Ben's risk with the robot as it is, the same move is refused for it.
    untold = judge_move(spec, result.chosen.move, imagine, uncertainty, scene.robot_name)
    assert not untold.clear and untold.reason.startswith("ben, a bystander, may walk into")


def test_a_walks_risk_counts_only_above_its_risk_with_the_robot_as_it_is() -> None:
    trial, _, scene, spec = recorded_case(HELD_OUT / "crossing_hall.yaml", 29, 3, AT)
    uncertainty = perception_uncertainty(scene, trial.sensors, AT, 0)
    item = replace(spec.letting_dangers_fall().items(None, None)[0], until_first_fall=False)
    joint = serve_one(scene, item).joint
    assert joint is not None
    falling = spec.letting_dangers_fall().falling
    risks = walk_risks(scene, joint, uncertainty, falling)
    ben = risks["ben"].probability
    assert ben > 0.0

    assert worst_risk(risks).person == "ben"
    assert worst_risk(risks, {"ben": ben}).probability < ben
    assert worst_risk(risks, {"ben": ben / 2}).person == "ben"


def test_a_bystanders_other_walk_is_told_its_risk_with_the_robot_as_it_is_too() -> None:
    """Two people heading for two obstacles at seed 24007, trial 1: a person walks towards a ball while a visitor
    heads for the door, and perception leaves it open that the visitor heads for the couch instead.

    On the walk to the couch the visitor may walk into the shoe whatever the robot does. That walk is imagined
    in a walk set of its own; told only what befalls the likeliest walks with the robot as it is, the search
    let the visitor's risk there refuse every move and found none. Told that walk's risk too, it sends the
    first stand-off, which saves the person in the ground truth.
    """
    at = 0.55
    trial, planner, scene, spec = recorded_case("two_people_two_obstacles", 24007, 1, at)
    uncertainty = perception_uncertainty(scene, trial.sensors, at, 0)
    imagine = partial(serve_one, scene)
    visitor = spec.bystanders[0]
    spec = replace(spec, bystanders=(visitor, replace(visitor, target="couch")))

    told = as_it_is(spec, imagine, scene, uncertainty)
    assert [(w.target, risk > 0.0) for w, risk in told.risks_anyway] == [("couch", True)]

    result = search(scene, spec, imagine, uncertainty, THRESHOLD, 32, judging=JUDGING, head_start=lambda lead: None)
    assert result.chosen is result.verdicts[0] and result.chosen.safe(THRESHOLD)
    assert saved_in_truth(trial, at, planner, DELAY, JUDGING, result)

    untold = judge_move(spec, result.chosen.move, imagine, uncertainty, scene.robot_name)
    assert not untold.clear and untold.reason.startswith("visitor, a bystander, may walk into shoe")
