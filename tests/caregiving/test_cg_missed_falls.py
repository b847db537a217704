"""A fall let happen may be a false alarm: a move must not harm the person who only just misses it, by as much as
perception's errors in positions and sizes allow."""

import json
from collections.abc import Mapping
from dataclasses import replace
from functools import partial
from pathlib import Path

import pytest

from agents.caregiving.model.imagine_reply import Answer
from agents.caregiving.model.imagine_request import JointItem
from agents.caregiving.model.joint import JointImagination
from agents.caregiving.model.judging import Misses, RobotMargin, judge_move
from agents.caregiving.model.move_search import SearchItem
from agents.caregiving.model.robot_moves import RobotMove
from agents.caregiving.model.scene import Scene
from agents.caregiving.model.service import item_from_wire, serve_one
from agents.caregiving.model.world_model import Passing

DATA = Path(__file__).parent / "data"
#: A search recorded live: crossing hall, seed 8521, trial 3, 5.0 s into the trial, on perception's belief.
RECORDED = DATA / "crossing_hall_s8521_trial3_search.json"
#: The search for a pose beside someone fallen, recorded live: crossing hall, seed 24007, trial 5, at 5.65 s.
GOING_TO = DATA / "crossing_hall_s24007_trial5_going_to.json"
#: The cabinet stand-off the crossing-hall search (RECORDED) chose live.
CABINET = RobotMove("cabinet_8", 1.1058033926029978, 2.0959732469531973, 2.356194490192345)


def recorded_search(path: Path = RECORDED) -> tuple[Scene, SearchItem]:
    data = json.loads(path.read_text())
    item = item_from_wire(data["item"])
    assert isinstance(item, SearchItem)
    return Scene.from_wire(data["scene"]), item


def test_a_move_that_walks_someone_just_missing_a_fall_let_happen_into_the_robot_is_refused() -> None:
    """The search protects Ana (person_11) and lets Ben's (person_12) fall into the bag happen: no move saved
    him a moment before. On the belief, Ben touches the bag by less than perception's error, and in the truth
    he passes it. The cabinet stand-off the search chose live saves Ana, and Ben, walking on past the bag,
    walks into the robot there (live, he did, in two runs). Imagined just missing the bag, he does so too: the
    move is refused, and the search chooses no move that walks him into the robot.

    The stand-off is judged on its own, set off as the search's first candidate: in the whole search its verdict
    turns on its slot (judged two candidates later, it comes too late for Ana)."""
    scene, item = recorded_search()
    assert item.spec.falling == {"person_12": "backpack_10"}
    alone = serve_one(scene, replace(item, moves=(CABINET,))).search
    assert alone is not None and alone.chosen is None
    assert [v.reason for v in alone.verdicts] == ["person_12 walks into robot where person_12 just misses backpack_10"]
    found = serve_one(scene, item).search
    assert found is not None
    assert not any(v.clear_where_found for v in found.verdicts if v.move is not None and v.move.target == "cabinet_8")
    if found.chosen is not None:
        assert "person_12 walks into robot" not in found.chosen.reason


def test_a_search_imagines_the_robot_as_it_is_once_for_the_candidates_that_let_the_same_falls_happen(
    monkeypatch: pytest.MonkeyPatch,
) -> None:
    """The search for a pose beside Ana, fallen (below), holds each pose to Ben just missing her. The robot as it
    is, imagined to the end with him passing her, is the same at every candidate's set-off, so the search
    imagines it once for both poses, and the answer is the one imagined at the candidate's own set-off."""
    scene, item = recorded_search(GOING_TO)
    wanted: list[JointItem] = []
    robot_as_it_is = Misses.robot_as_it_is

    def wanting(misses: Misses, passing: Mapping[str, Passing]) -> JointImagination | None:
        wanted.append(misses.item)
        return robot_as_it_is(misses, passing)

    monkeypatch.setattr(Misses, "robot_as_it_is", wanting)
    imagined: list[JointItem] = []

    def imagine(joint: JointItem) -> Answer:
        if joint.move == joint.current and joint.passing and joint.uncertainty is None:
            imagined.append(joint)
        return serve_one(scene, joint)

    item.run(scene, imagine)
    assert len(imagined) == 1 and len(wanted) == 2, "both poses let Ben's same fall happen"
    at_its_own = replace(imagined[0], delay=wanted[-1].delay)
    assert wanted[-1].delay > 0.0 and serve_one(scene, at_its_own).joint == serve_one(scene, imagined[0]).joint


def test_a_fall_let_happen_that_goes_deeper_than_perceptions_error_is_not_imagined_missed() -> None:
    """The same move, judged with perception's errors (positions and sizes) a hundredth as large: Ben's touch of the bag is then deeper
    than the error allows, his fall is sure, and the move is clear where Ana's danger was found."""
    scene, item = recorded_search()
    u = item.uncertainty
    sure = replace(u, sigma={name: sigma / 100 for name, sigma in u.sigma.items()}, size_error=u.size_error / 100)
    imagine = partial(serve_one, scene)
    refused = judge_move(item.spec, CABINET, imagine, item.uncertainty, scene.robot_name)
    assert refused.reason == "person_12 walks into robot where person_12 just misses backpack_10"
    assert judge_move(item.spec, CABINET, imagine, sure, scene.robot_name).clear_where_found


def test_a_move_to_someone_fallen_is_not_sent_into_the_way_of_a_walker_believed_to_touch_them() -> None:
    """Ana (person_35) has fallen; Ben (person_36) walks on north to the cabinet, beside her. On the belief their
    discs overlap by a centimetre, so his first step touches her, a fall that happens with the robot as it is
    too; in the truth he passes her. The first pose beside her stands on his way: imagined just missing her, he
    walks into the robot there (live, he did, 2 s later), so it is refused, and the pose behind him is taken."""
    scene, item = recorded_search(GOING_TO)
    assert not item.spec.dangers and [w.person for w in item.spec.bystanders] == ["person_36"]
    found = serve_one(scene, item).search
    assert found is not None and len(found.verdicts) == 2
    in_his_way, behind_him = found.verdicts
    assert in_his_way.reason == "person_36 walks into robot where person_36 just misses person_35"
    assert (
        found.chosen is behind_him and behind_him.move is not None and behind_him.move.y < scene.person("person_36").y
    )


def test_a_fall_just_missed_may_be_as_deep_as_the_object_held_too_large_explains() -> None:
    """Perception may hold a person two sigmas of both positions off from an object, and the object up to its size
    error too large: its true outline may lie that share of its bounding radius inside the believed one."""
    margin = RobotMargin("robot", {"person": 0.03, "basket": 0.04}, size_error=0.2)
    assert margin.error("person", "basket") == pytest.approx(2 * 0.05)
    assert margin.error("person", "basket", 0.24) == pytest.approx(2 * 0.05 + 0.24 * 0.2 / 1.2)
    exact_sizes = replace(margin, size_error=0.0)
    assert exact_sizes.error("person", "basket", 0.24) == pytest.approx(2 * 0.05)
