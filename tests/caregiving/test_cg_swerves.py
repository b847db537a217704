"""Swerves, crossings and moves that make nothing worse: the search's answers to the dangers its first stand-offs leave.

The recorded cases are truly risky trials with perfect belief, at the moment a live run first saw the
danger, the robot starting one world step later and 20 ms later per candidate judged, as
``bench/bench_move_search.py`` sets them up.
"""

import math
from dataclasses import replace
from functools import partial
from itertools import islice

import pytest
from recorded_cases import DELAY, EXACT, HELD_OUT, JUDGING, THRESHOLD, recorded_case

from agents.caregiving.model.candidates import (
    Danger,
    candidates,
    crossing_time,
    crossings,
    guards,
    in_reach,
    path_poses,
    swerves,
    travel_direction,
)
from agents.caregiving.model.errors import ReplyError
from agents.caregiving.model.fields import Fields
from agents.caregiving.model.imagine import imagine_person
from agents.caregiving.model.move_choice import NoWorse
from agents.caregiving.model.move_search import search
from agents.caregiving.model.robot_moves import RobotMove
from agents.caregiving.model.scenario import load_scenario
from agents.caregiving.model.scene import Scene
from agents.caregiving.model.search_spec import SearchSpec
from agents.caregiving.model.service import serve_one
from agents.caregiving.model.verdict import Fall, Verdict
from bridges.experiment.beliefs import perception_uncertainty
from bridges.experiment.oracle import saves, world_at
from bridges.experiment.perfect_belief import saved_in_truth

NOISY_SLOW_ROBOT = HELD_OUT / "noisy_slow_robot.yaml"
HURRIED_WALKER = HELD_OUT / "hurried_walker.yaml"
GAZE = math.radians(8)


def test_a_swerve_saves_a_person_who_grazes_the_obstacle_walking_round_the_stand_off() -> None:
    """Seed 2024's trial 74: the person walks round the robot behind the ball and still grazes the ball."""
    trial, planner, scene, spec = recorded_case("paper_experiment1", 2024, 74, 0.65)
    result = search(scene, spec, partial(serve_one, scene), EXACT, THRESHOLD, 24, judging=JUDGING)

    first = result.verdicts[0]
    assert first.move is not None and first.falls and first.falls[0].obstacle == "ball"
    assert not result.verdicts[1].safe(THRESHOLD)
    assert result.chosen is not None and result.chosen.safe(THRESHOLD)
    assert result.chosen.move in swerves(scene, spec.dangers[0], first.move, first)
    sent_at = 0.65 + DELAY + JUDGING * len(result.verdicts)
    assert saves(world_at(trial, sent_at, planner), result.chosen.move)
    # Without the swerves, none of the next candidates the search would judge saves the person in time.
    plain = [m for m in candidates(scene, spec.dangers)][2:8]
    assert not any(saves(world_at(trial, 0.65 + DELAY + JUDGING * (k + 3), planner), m) for k, m in enumerate(plain))


def test_a_first_stand_off_clear_but_passed_too_close_gets_swerves_that_clear_the_obstacle_by_more() -> None:
    """The box room at seed 11, trial 12: the person walks round the robot behind the box clear of it, but so close
    that in 39 % of the worlds perception's noise allows they touch it. A swerve widens the detour: the search
    sends it with no sampled risk, and it saves the person in the truth."""
    trial, planner, scene, spec = recorded_case("box_obstacle", 11, 12, 0.65)
    uncertainty = perception_uncertainty(scene, trial.sensors, 0.65, 12)
    result = search(scene, spec, partial(serve_one, scene), uncertainty, THRESHOLD, 24, judging=JUDGING)

    first = result.verdicts[0]
    assert first.move is not None and first.clear and not first.safe(THRESHOLD) and not first.falls
    assert first.near is not None and first.near.obstacle == spec.dangers[0].obstacle
    shifted = swerves(scene, spec.dangers[0], first.move, first)
    assert shifted and swerves(scene, spec.dangers[0], first.move, replace(first, near=None)) == []
    assert result.chosen is not None and result.chosen.move in shifted and result.chosen.risk < first.risk
    assert saved_in_truth(trial, 0.65, planner, DELAY, JUDGING, result)


@pytest.fixture(scope="module")
def paper() -> tuple[Scene, Danger]:
    scene = load_scenario("paper_experiment1").scene()
    danger = Danger.of(imagine_person(scene, "person", "couch", GAZE))
    assert danger is not None
    return scene, danger


def touched(scene: Scene, danger: Danger, bearing_deg: float, obstacle: str = "ball", walk_set: int = 0) -> Verdict:
    """A refused verdict: the person touched ``obstacle`` at this bearing from straight ahead (left positive),
    in the walk set ``walk_set`` (0: the gaze class found risky)."""
    dx, dy = travel_direction(danger.path, danger.point)
    shape = scene.obstacle("ball").shape
    b = math.radians(bearing_deg)
    ux, uy = -dx * math.cos(b) - dy * math.sin(b), -dy * math.cos(b) + dx * math.sin(b)
    point = (shape.x + 0.1 * ux, shape.y + 0.1 * uy)
    return Verdict(None, False, 1.0, None, "", (Fall(walk_set, "person", obstacle, point),))


def test_swerves_shift_the_stand_off_towards_the_side_the_person_grazed_and_only_then(
    paper: tuple[Scene, Danger],
) -> None:
    scene, danger = paper
    behind = next(iter(candidates(scene, (danger,))))
    dx, dy = travel_direction(danger.path, danger.point)

    def lateral(m: RobotMove) -> float:
        return (m.y - behind.y) * dx - (m.x - behind.x) * dy

    left = swerves(scene, danger, behind, touched(scene, danger, 50.0))
    right = swerves(scene, danger, behind, touched(scene, danger, -50.0))
    assert [round(lateral(m), 3) for m in left] == [0.15, 0.3]
    assert [round(lateral(m), 3) for m in right] == [-0.15, -0.3]
    assert all(m.heading == behind.heading and m.target == behind.target for m in left + right)
    # Clear at the gaze found risky, grazing at another: the same side.
    assert swerves(scene, danger, behind, touched(scene, danger, 50.0, walk_set=1)) == left
    assert swerves(scene, danger, behind, touched(scene, danger, 10.0)) == []  # head-on: no side to widen
    assert swerves(scene, danger, behind, touched(scene, danger, 50.0, "robot")) == []
    other = RobotMove("couch", behind.x, behind.y, behind.heading)
    assert swerves(scene, danger, other, touched(scene, danger, 50.0)) == []
    path_pose = next(m for m, _ in path_poses(scene, danger))  # it names the obstacle too, but is no stand-off
    assert path_pose.target == danger.obstacle and swerves(scene, danger, path_pose, touched(scene, danger, 50.0)) == []


def test_the_swerves_follow_the_first_candidate_once_its_verdict_is_in_and_no_candidate_repeats(
    paper: tuple[Scene, Danger],
) -> None:
    scene, danger = paper
    plain = list(candidates(scene, (danger,)))
    first = plain[0]
    shifted = swerves(scene, danger, first, touched(scene, danger, 50.0))
    assert shifted
    with_swerves = list(candidates(scene, (danger,), [touched(scene, danger, 50.0)]))
    keys = [(round(m.x, 3), round(m.y, 3), round(m.heading, 3)) for m in with_swerves]
    assert len(keys) == len(set(keys))
    assert with_swerves[0] == first and with_swerves[1 : 1 + len(shifted)] == shifted
    # A verdict that comes in only after the second candidate was asked for brings its swerves right after it.
    verdicts: list[Verdict] = []
    stream = candidates(scene, (danger,), verdicts)
    asked = [next(stream), next(stream)]
    verdicts.append(touched(scene, danger, 50.0))
    assert asked == plain[:2] and list(islice(stream, len(shifted))) == shifted


def test_a_verdicts_falls_and_sampled_contact_survive_the_wire() -> None:
    v = Verdict(RobotMove("ball", 1.0, 2.0, 0.5), False, 0.1, 3.0, "why", (Fall(1, "ann", "ball", (0.5, 0.25)),))
    stuck = Verdict(None, False, 1.0, None, "stuck", (Fall(0, "ann", None, None),))
    near = Verdict(RobotMove("ball", 1.0, 2.0, 0.5), True, 0.3, 3.0, "close", near=Fall(1, "ann", "ball", (0.5, 0.2)))
    worse = Verdict(None, False, 1.0, None, "just misses", (Fall(0, "ann", "ball", (0.5, 0.25), made_worse=True),))
    for verdict in (v, stuck, near, worse):
        assert Verdict.from_fields(Fields(verdict.to_wire(), "verdict", ReplyError)) == verdict
    with pytest.raises(ReplyError, match=r"verdict.falls\[0\].walk_set"):
        Verdict.from_fields(
            Fields({**v.to_wire(), "falls": [{"walk_set": 0.5, "person": "ann"}]}, "verdict", ReplyError)
        )


def test_a_move_that_saves_the_person_at_the_gaze_found_risky_and_makes_nothing_worse_is_sent() -> None:
    """Poor sensors, a slow robot and a stool: at the two higher gazes the person walks into the stool anyway.

    No move keeps them clear at every gaze. The move sent saves them at the gaze the danger was found at;
    at the others they walk into the stool as they would with the robot as it is, so it makes nothing worse.
    """
    trial, planner, scene, spec = recorded_case(NOISY_SLOW_ROBOT, 5, 6, 0.7)
    result = search(scene, spec, partial(serve_one, scene), EXACT, THRESHOLD, 24, judging=JUDGING)

    chosen = result.chosen
    assert chosen is not None and chosen is result.verdicts[-1] and not chosen.clear
    assert [(f.walk_set, f.obstacle) for f in chosen.falls] == [(1, "stool"), (2, "stool")]
    assert chosen.reason.startswith("clear at the gaze found risky; at another, person walks into stool")
    assert chosen.move is not None
    assert saves(world_at(trial, 0.7 + DELAY + JUDGING * len(result.verdicts), planner), chosen.move)


def test_a_move_that_makes_someone_fall_who_would_not_with_the_robot_as_it_is_is_not_no_worse(
    paper: tuple[Scene, Danger],
) -> None:
    scene, danger = paper
    sees_ball = math.radians(-10)  # looking that far down, the person sees the ball and walks round it
    assert not imagine_person(scene, "person", "couch", sees_ball).collided
    spec = SearchSpec((danger,), {"person": (GAZE, sees_ball)}, {})
    no_worse = NoWorse(spec, partial(serve_one, scene), EXACT, THRESHOLD, "robot")
    move = RobotMove("ball", 1.0, 1.0, 0.0)

    def refused(*falls: Fall, risk: float = 0.0) -> Verdict:
        return Verdict(move, False, risk, None, "", falls)

    # At the gaze that sees the ball, the person walks clear with the robot as it is: a fall there is new.
    assert not no_worse(refused(Fall(1, "person", "couch", None)))
    assert not no_worse(refused(Fall(0, "person", "ball", None)))  # not clear at the gaze found risky
    assert not no_worse(refused(Fall(1, "person", "robot", None)))  # into the robot: never
    assert not no_worse(refused(Fall(1, "person", None, None)))  # stuck
    spec_low = SearchSpec((danger,), {"person": (sees_ball, GAZE)}, {})
    low = NoWorse(spec_low, partial(serve_one, scene), EXACT, THRESHOLD, "robot")
    assert low(refused(Fall(1, "person", "couch", None)))  # at the low gaze they fall idle too
    assert not low(refused(Fall(1, "person", "couch", None), risk=0.5))  # too risky where it is clear


def test_a_drive_across_the_persons_route_to_a_far_object_saves_them() -> None:
    """Seed 6's trial 11: every stand-off of the slipper fails, and the wardrobe is too far to reach in time.

    The robot's drive to a stand-off of the wardrobe crosses the person's route past the slipper; they see
    it in their way, plan anew round it, and the new route misses the slipper. The crossings to the other
    objects are judged here on their own: the whole search finds a guard first (the next test).
    """
    trial, planner, scene, spec = recorded_case(HURRIED_WALKER, 6, 11, 0.6)
    danger = spec.dangers[0]
    far = tuple(m for m in crossings(scene, danger) if m.target != danger.obstacle)
    result = search(scene, spec, partial(serve_one, scene), EXACT, THRESHOLD, 24, judging=JUDGING, moves=far)

    assert result.chosen is not None and result.chosen.safe(THRESHOLD)
    move = result.chosen.move
    assert move is not None and move.target != danger.obstacle
    assert not in_reach(scene, move, danger.time_to_collision)
    sent_at = 0.6 + DELAY + JUDGING * len(result.verdicts)
    assert saves(world_at(trial, sent_at, planner), move)


def test_a_guard_saves_the_hurried_walker_before_any_crossing_is_judged() -> None:
    """The same trial: past every stand-off of the slipper, cover and path pose, a robot at the edge of the
    person's way on the slipper's side is safe, and they pass it on its far side, clear of the slipper."""
    trial, planner, scene, spec = recorded_case(HURRIED_WALKER, 6, 11, 0.6)
    danger = spec.dangers[0]
    result = search(scene, spec, partial(serve_one, scene), EXACT, THRESHOLD, 24, judging=JUDGING)

    assert result.chosen is not None and result.chosen.safe(THRESHOLD)
    assert result.chosen.move in set(guards(scene, danger))
    assert not any(v.clear for v in result.verdicts[:-1])
    sent_at = 0.6 + DELAY + JUDGING * len(result.verdicts)
    assert saves(world_at(trial, sent_at, planner), result.chosen.move)


def test_a_crossing_is_timed_where_the_drive_first_stands_in_the_persons_way() -> None:
    _, _, scene, spec = recorded_case(HURRIED_WALKER, 6, 11, 0.6)
    danger = spec.dangers[0]
    robot = scene.robot
    assert robot is not None
    straight_up = RobotMove("wardrobe", robot.x, robot.y + 2.5, 0.0)  # across the route to the door
    away = RobotMove("wardrobe", robot.x + 0.5, robot.y, 0.0)  # along the wall, behind the robot
    crossed = crossing_time(scene, danger, straight_up, 0.0)
    assert crossed is not None and 0.0 < crossed < danger.time_to_collision
    assert crossing_time(scene, danger, straight_up, 0.2) == crossed + 0.2
    assert crossing_time(scene, danger, straight_up, danger.time_to_collision) is None
    assert crossing_time(scene, danger, away, 0.0) is None


def test_a_person_without_a_route_has_no_crossings() -> None:
    scene = load_scenario("paper_experiment1").scene()
    person = scene.person("person")
    danger = Danger("person", "couch", ((person.x, person.y),), (person.x, person.y), "ball", 1.0)
    assert list(crossings(scene, danger)) == []
