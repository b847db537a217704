"""Poses past the obstacle on the person's way: crossings whose drive, seen in the person's way, saves them."""

from __future__ import annotations

import math
from functools import partial

import pytest
from recorded_cases import DELAY, EXACT, HELD_OUT, JUDGING, THRESHOLD, recorded_case

from agents.caregiving.model.candidates import (
    BEYOND_ROWS,
    COVER_SHIFT,
    LATERAL,
    SPACING,
    Danger,
    beyond_poses,
    candidates,
    covers_farther_back,
    crossing_time,
    crossings,
    guards,
    obstacle_side,
    ordered_moves,
    path_poses,
    standoffs,
    touching_distance,
)
from agents.caregiving.model.move_search import search
from agents.caregiving.model.scenario import load_scenario
from agents.caregiving.model.service import serve_one
from bridges.experiment.perfect_belief import saved_in_truth


def test_poses_past_the_obstacle_stand_on_and_beside_the_persons_way_beyond_the_touch() -> None:
    scene = load_scenario("paper_experiment1").scene()
    person, robot = scene.person("person"), scene.robot
    assert robot is not None
    path = ((0.0, 0.0), (1.0, 0.0), (3.0, 0.0))
    danger = Danger("person", "couch", path, (1.5, 0.12), "ball", 2.0)
    first = person.radius + max(robot.length, robot.width) / 2

    poses = beyond_poses(scene, danger)

    rows = [x for x in (1.5 + first + k * SPACING for k in range(BEYOND_ROWS)) if x <= 3.0]
    assert rows
    expected = [(x, offset) for x in rows for offset in LATERAL]
    assert [c for m in poses for c in (m.x, m.y)] == pytest.approx([c for pose in expected for c in pose])
    assert all(m.heading == pytest.approx(math.pi / 2) and m.target == "ball" for m in poses)
    assert beyond_poses(scene, Danger("person", "couch", path[:1], (1.5, 0.12), "ball", 2.0)) == []


def test_a_drive_that_crosses_the_persons_way_saves_them() -> None:
    """The ward at seed 11, trial 9: no stand-off of the footstool, cover or path pose saves the patient.

    The robot's drive towards a pose across their way (a stand-off of the washroom door, or a pose past the
    footstool on their way, as the candidates' timing has it) puts it in their way while they are still far
    from the footstool; they plan their walk anew round it, and the new walk clears the footstool.
    """
    at = 0.6
    trial, planner, scene, spec = recorded_case(HELD_OUT / "ward_footstool.yaml", 11, 9, at)
    danger = spec.dangers[0]
    past = beyond_poses(scene, danger)

    result = search(
        scene, spec, partial(serve_one, scene), EXACT, THRESHOLD, 24, judging=JUDGING, head_start=lambda lead: None
    )

    assert result.chosen is not None and result.chosen.risk < THRESHOLD
    move = result.chosen.move
    assert move in crossings(scene, danger) and move not in standoffs(scene, danger, danger.obstacle)
    assert crossing_time(scene, danger, move, 0.0) is not None
    assert result.verdicts[-1] is result.chosen
    # Every candidate before it walks the patient into something at the gaze found risky.
    assert all(any(f.walk_set == 0 for f in v.falls) for v in result.verdicts[:-1])
    assert sum(v.move not in past for v in result.verdicts) >= 10
    assert saved_in_truth(trial, at, planner, DELAY, JUDGING, result)


def test_the_poses_past_the_obstacle_are_the_last_crossings() -> None:
    _, _, scene, spec = recorded_case(HELD_OUT / "ward_footstool.yaml", 11, 9, 0.6)
    danger = spec.dangers[0]
    crossing = list(crossings(scene, danger))
    past = [m for m in crossing if m in beyond_poses(scene, danger)]
    assert past and crossing[-len(past) :] == past
    assert set(past) <= set(candidates(scene, spec.dangers))


def test_the_covers_farther_back_come_right_after_the_obstacles_stand_offs() -> None:
    _, _, scene, spec = recorded_case(HELD_OUT / "face_to_face.yaml", 419, 12, 0.55)
    danger = spec.dangers[0]
    own = set(standoffs(scene, danger, danger.obstacle))
    moves = list(ordered_moves(scene, danger))
    first_other = next(k for k, m in enumerate(moves) if m not in own)
    covers = list(covers_farther_back(scene, danger))

    assert first_other > 0 and covers and moves[first_other : first_other + len(covers)] == covers
    assert not own & set(moves[first_other:])
    straight = set(beyond_poses(scene, danger, (0.0,)))
    shifted = set(beyond_poses(scene, danger, (COVER_SHIFT * obstacle_side(scene, danger),)))
    first_shifted = next(k for k, m in enumerate(covers) if m not in straight)
    assert 0 < first_shifted and set(covers[:first_shifted]) <= straight and set(covers[first_shifted:]) <= shifted
    assert all(crossing_time(scene, danger, m, 0.0) is not None for m in covers)


def test_the_obstacle_side_is_the_side_of_the_way_its_centre_lies_on() -> None:
    scene = load_scenario("paper_experiment1").scene()
    ball = scene.obstacle("ball").shape
    path = ((ball.x - 2.0, ball.y - 0.2), (ball.x + 2.0, ball.y - 0.2))
    assert obstacle_side(scene, Danger("person", "couch", path, (ball.x, ball.y - 0.1), "ball", 2.0)) == 1.0
    backwards = path[::-1]
    assert obstacle_side(scene, Danger("person", "couch", backwards, (ball.x, ball.y - 0.1), "ball", 2.0)) == -1.0


def test_a_cover_shifted_towards_the_obstacles_side_saves_where_one_straight_on_the_way_does_not() -> None:
    """Series hall at seed 211, trial 9: a toy car on the resident's way.

    No stand-off of the toy car saves the resident, and they walk into a robot standing straight on their way
    past it. A robot a little towards the toy car's side of their way is passed on its other side, and the
    detour clears the toy car. The code before found no move in its 24 candidates.
    """
    at = 0.65
    trial, planner, scene, spec = recorded_case(HELD_OUT / "series_hall.yaml", 211, 9, at)
    danger = spec.dangers[0]
    shifted = beyond_poses(scene, danger, (COVER_SHIFT * obstacle_side(scene, danger),))

    result = search(
        scene, spec, partial(serve_one, scene), EXACT, THRESHOLD, 24, judging=JUDGING, head_start=lambda lead: None
    )

    assert result.chosen is not None and result.chosen.safe(THRESHOLD) and result.chosen.move in shifted
    straight = [v for v in result.verdicts if v.move in beyond_poses(scene, danger, (0.0,))]
    assert straight and not any(v.clear for v in straight)
    assert saved_in_truth(trial, at, planner, DELAY, JUDGING, result)


def test_a_cover_farther_back_saves_where_no_stand_off_or_path_pose_does() -> None:
    """Face to face at seed 419, trial 12: a toy lies on the resident's way to the sofa.

    No stand-off of the toy and no pose on the resident's path before it saves them. A robot straight on
    their way farther past the toy does: they plan round it while still short of the toy, and the detour
    clears the toy too. Tried after every path pose and crossing, it came past the search's 24 candidates.
    """
    at = 0.55
    trial, planner, scene, spec = recorded_case(HELD_OUT / "face_to_face.yaml", 419, 12, at)
    danger = spec.dangers[0]

    result = search(
        scene, spec, partial(serve_one, scene), EXACT, THRESHOLD, 24, judging=JUDGING, head_start=lambda lead: None
    )

    assert result.chosen is not None and result.chosen.safe(THRESHOLD)
    assert result.chosen.move in beyond_poses(scene, danger, (0.0,))
    assert not any(v.safe(THRESHOLD) for v in result.verdicts if v.move in standoffs(scene, danger, danger.obstacle))
    assert saved_in_truth(trial, at, planner, DELAY, JUDGING, result)


def test_a_guard_at_the_edge_of_the_way_on_the_obstacles_side_saves_where_no_other_candidate_does() -> None:
    """Face to face at seed 60013, trial 19 (lost live at that seed): a toy lies just off the resident's way.

    Every stand-off of the toy, cover and path pose leaves the resident walking into the toy or into the robot.
    A robot standing at the edge of their way past the toy, on the toy's side, is passed on its far side, and
    the detour clears the toy.
    """
    at = 0.6
    trial, planner, scene, spec = recorded_case(HELD_OUT / "face_to_face.yaml", 60013, 19, at)
    danger = spec.dangers[0]
    edge = touching_distance(scene, danger.person)
    at_the_edge = beyond_poses(scene, danger, (edge * obstacle_side(scene, danger),))

    result = search(
        scene, spec, partial(serve_one, scene), EXACT, THRESHOLD, 32, judging=JUDGING, head_start=lambda lead: None
    )

    assert result.chosen is not None and result.chosen.safe(THRESHOLD) and result.chosen.move in at_the_edge
    assert set(guards(scene, danger)) <= set(at_the_edge)
    assert not any(v.clear for v in result.verdicts[:-1])
    assert saved_in_truth(trial, at, planner, DELAY, JUDGING, result)


def test_the_guards_come_after_the_path_poses_and_before_the_crossings() -> None:
    _, _, scene, spec = recorded_case(HELD_OUT / "face_to_face.yaml", 60013, 19, 0.6)
    danger = spec.dangers[0]
    moves = list(ordered_moves(scene, danger))
    watching = list(guards(scene, danger))
    start = moves.index(watching[0])

    path = {m for m, _ in path_poses(scene, danger)}
    assert moves[start : start + len(watching)] == watching
    assert moves[start - 1] in path and not path & set(moves[start:])
    assert moves[start + len(watching)] in set(crossings(scene, danger))
    assert all(crossing_time(scene, danger, m, 0.0) is not None for m in watching)
