"""Imagine requests: person-only and joint, wire forms and malformed requests."""

import math
from dataclasses import replace

import msgpack
import pytest

from caregiving.errors import RequestError
from caregiving.imagine import Imagination, JointImagination, answer, imagine_joint, imagine_person, planner_for
from caregiving.robot_moves import RobotMove, standoff_moves
from caregiving.rollout import BulletRollout
from caregiving.scenario import load_scenario
from caregiving.scene import Scene

GAZE = math.radians(8)


@pytest.fixture(scope="module")
def scene() -> Scene:
    return load_scenario("paper_experiment1").scene()


def test_person_walks_into_the_unseen_ball(scene: Scene) -> None:
    im = imagine_person(scene, "person", "couch", GAZE)
    assert "ball" not in im.seen and "robot" in im.seen
    assert im.reachable and im.collided and im.collision_object == "ball"
    assert im.collision_time == pytest.approx(4.3) and im.duration == im.collision_time
    assert im.path[0] == (-2.5, 0.0)


def test_looking_down_the_person_sees_and_avoids_the_ball(scene: Scene) -> None:
    im = imagine_person(scene, "person", "couch", math.radians(-30))
    assert "ball" in im.seen and not im.collided and im.min_clearance > 0.0
    assert im.collision_time is None and im.collision_point is None


def test_bullet_and_numpy_imagine_the_same(scene: Scene) -> None:
    a = imagine_person(scene, "person", "couch", GAZE)
    b = imagine_person(scene, "person", "couch", GAZE, rollout=BulletRollout.shared())
    assert (a.collided, a.collision_object, a.collision_time) == (b.collided, b.collision_object, b.collision_time)


def test_unreachable_target(scene: Scene) -> None:
    fenced = replace(scene, obstacles=scene.obstacles + (
        replace(scene.obstacle("ball"), name="fence", kind="wall", shape=replace(scene.obstacle("wall2").shape, x=2.0)),))
    im = imagine_person(fenced, "person", "couch", GAZE)
    assert not im.reachable and not im.collided and im.path == ()


def test_joint_robot_in_front_of_the_ball_removes_the_danger(scene: Scene) -> None:
    moves = {round(m.x, 2): m for m in standoff_moves(scene, "ball") if abs(m.y) < 1e-6}
    front = moves[-0.46]
    joint = imagine_joint(scene, "person", "couch", GAZE, front)
    assert joint.robot_reachable and joint.robot_seen and joint.removes_danger
    assert 0.0 < joint.robot_arrival < 10.0
    assert "robot" in joint.person.seen


def test_joint_with_unreachable_move_keeps_the_danger(scene: Scene) -> None:
    joint = imagine_joint(scene, "person", "couch", GAZE, RobotMove("couch", 3.5, 0.0, 0.0))
    assert not joint.robot_reachable and not joint.removes_danger and joint.robot_arrival == math.inf
    assert joint.person.collided


def test_wire_round_trips_through_msgpack(scene: Scene) -> None:
    im = imagine_person(scene, "person", "couch", GAZE)
    packed = msgpack.unpackb(msgpack.packb(im.to_wire()))
    assert Imagination.from_wire(packed) == im
    move = standoff_moves(scene, "ball")[0]
    joint = imagine_joint(scene, "person", "couch", GAZE, move)
    assert JointImagination.from_wire(msgpack.unpackb(msgpack.packb(joint.to_wire()))) == joint
    unreachable = imagine_joint(scene, "person", "couch", GAZE, RobotMove("couch", 3.5, 0.0, 0.0))
    assert JointImagination.from_wire(unreachable.to_wire()) == unreachable
    assert Scene.from_wire(msgpack.unpackb(msgpack.packb(scene.to_wire()))) == scene
    assert RobotMove.from_wire(move.to_wire()) == move


def test_answer_dispatches_wire_requests(scene: Scene) -> None:
    person = answer(scene, {"kind": "person", "person": "person", "target": "couch", "gaze": GAZE})
    assert person["collided"] and person["collision_object"] == "ball"
    move = standoff_moves(scene, "ball")[0].to_wire()
    joint = answer(scene, {"kind": "joint", "person": "person", "target": "couch", "gaze": GAZE, "move": move})
    assert joint["move"] == move


@pytest.mark.parametrize(("request_", "message"), [
    ({"kind": "dance", "person": "person", "target": "couch", "gaze": 0.1}, "request.kind: expected one of"),
    ({"kind": "person", "target": "couch", "gaze": 0.1}, "request.person: is required"),
    ({"kind": "person", "person": "ghost", "target": "couch", "gaze": 0.1}, "unknown person 'ghost'"),
    ({"kind": "person", "person": "person", "target": "fridge", "gaze": 0.1}, "unknown object 'fridge'"),
    ({"kind": "person", "person": "person", "target": "couch", "gaze": "up"}, "request.gaze: expected a number"),
    ({"kind": "person", "person": "person", "target": "couch", "gaze": 3.0}, "gaze: expected a pitch"),
    ({"kind": "joint", "person": "person", "target": "couch", "gaze": 0.1}, "request.move: is required"),
    ({"kind": "joint", "person": "person", "target": "couch", "gaze": 0.1, "move": {"x": 1, "y": 2}},
     "request.move.target: is required"),
    ({"kind": "joint", "person": "person", "target": "couch", "gaze": 0.1,
      "move": {"target": "ball", "x": "a", "y": 2}}, "request.move.x: expected a number"),
    ([1, 2], "request: expected a mapping"),
])
def test_malformed_requests_raise_request_error(scene: Scene, request_: object, message: str) -> None:
    with pytest.raises(RequestError, match=message.replace("(", r"\(").replace("[", r"\[")):
        answer(scene, request_)


def test_joint_without_robot_is_a_request_error(scene: Scene) -> None:
    with pytest.raises(RequestError, match="no robot"):
        imagine_joint(scene.with_robot(None), "person", "couch", GAZE, RobotMove("ball", 0.0, 0.5, 0.0))


@pytest.mark.parametrize(("data", "message"), [
    ({"bounds": [0, 0, -1, 1], "obstacles": [], "people": [], "robot": None}, "scene.bounds: expected xmin < xmax"),
    ({"bounds": [0, 0, 1, 1], "obstacles": [{"name": "a", "kind": "ball", "height": 1,
                                             "shape": {"type": "star", "x": 0, "y": 0}}], "people": []},
     "scene.obstacles[0].shape.type"),
    ({"bounds": [0, 0, 1, 1], "obstacles": [], "people": [{"name": "p"}]}, "scene.people[0].x: is required"),
    ({"bounds": [0, 0, 1, 1], "obstacles": [], "people": [], "robot": {"name": "r"}}, "scene.robot.x: is required"),
])
def test_malformed_scenes_raise_request_error(data: dict, message: str) -> None:
    with pytest.raises(RequestError, match=message.replace("[", r"\[")):
        Scene.from_wire(data)


def test_malformed_results_raise_request_error(scene: Scene) -> None:
    wire = imagine_person(scene, "person", "couch", GAZE).to_wire()
    wire["path"] = [[0, 0], [1]]
    with pytest.raises(RequestError, match=r"imagination.path\[1\]: expected an \[x, y\] point"):
        Imagination.from_wire(wire)
    wire["path"] = "nowhere"
    with pytest.raises(RequestError, match="imagination.path: expected a list"):
        Imagination.from_wire(wire)


def test_planner_is_shared_per_room(scene: Scene) -> None:
    assert planner_for(scene.bounds) is planner_for(tuple(scene.bounds))
