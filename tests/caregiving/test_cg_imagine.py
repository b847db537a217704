"""Imagine requests: the person-only walk, the service's dispatch, wire forms and malformed requests."""

import math
from dataclasses import replace

import msgpack
import pytest

from agents.caregiving.model.errors import RequestError
from agents.caregiving.model.imagine import Imagination, imagine_person, planner_for
from agents.caregiving.model.robot_moves import RobotMove, standoff_moves
from agents.caregiving.model.rollout import BulletRollout
from agents.caregiving.model.scenario import load_scenario
from agents.caregiving.model.scene import Scene
from agents.caregiving.model.service import judges_robot_moves, serve_item

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
    fenced = replace(
        scene,
        obstacles=scene.obstacles
        + (
            replace(
                scene.obstacle("ball"), name="fence", kind="wall", shape=replace(scene.obstacle("wall2").shape, x=2.0)
            ),
        ),
    )
    im = imagine_person(fenced, "person", "couch", GAZE)
    assert not im.reachable and not im.collided and im.path == ()


def test_wire_round_trips_through_msgpack(scene: Scene) -> None:
    im = imagine_person(scene, "person", "couch", GAZE)
    packed = msgpack.unpackb(msgpack.packb(im.to_wire()))
    assert Imagination.from_wire(packed) == im
    move = standoff_moves(scene, "ball")[0]
    assert Scene.from_wire(msgpack.unpackb(msgpack.packb(scene.to_wire()))) == scene
    assert scene.robot is not None
    driving = scene.with_robot(replace(scene.robot, speed=0.4, route=((0.5, 1.0), (1.5, 1.0))))
    assert Scene.from_wire(msgpack.unpackb(msgpack.packb(driving.to_wire()))) == driving
    assert RobotMove.from_wire(move.to_wire()) == move


def test_the_service_dispatches_wire_requests(scene: Scene) -> None:
    person = serve_item(scene, {"kind": "person", "person": "person", "target": "couch", "gaze": GAZE}).imagination
    assert person is not None and person.collided and person.collision_object == "ball"
    move = standoff_moves(scene, "ball")[0]
    walk = {"person": "person", "target": "couch", "gaze": GAZE}
    joint = serve_item(scene, {"kind": "joint", "walks": [walk], "move": move.to_wire()}).joint
    assert joint is not None and joint.move == move and joint.walks[0].walk.person == "person"
    found = serve_item(scene, {**SEARCH, "max_moves": 6}).search
    assert found is not None and found.chosen is not None and found.chosen.clear
    assert 1 <= len(found.verdicts) <= 6 and found.verdicts[-1] is found.chosen


def test_a_joint_answer_samples_the_risk_only_when_every_walk_is_clear(scene: Scene) -> None:
    walk = {"person": "person", "target": "couch", "gaze": GAZE}
    uncertainty = {"samples": 16}
    idle = serve_item(scene, {"kind": "joint", "walks": [walk], "move": None, "uncertainty": uncertainty})
    assert idle.joint is not None and idle.joint.walks[0].collided and idle.risk is None
    saving = serve_item(scene, {**SEARCH, "max_moves": 6}).search
    assert saving is not None and saving.chosen is not None and saving.chosen.move is not None
    item = {"kind": "joint", "walks": [walk], "move": saving.chosen.move.to_wire(), "uncertainty": uncertainty}
    clear = serve_item(scene, {**item, "delay": 0.2})
    assert clear.joint is not None and clear.joint.safe and clear.risk is not None


DANGER = {
    "person": "person",
    "target": "couch",
    "path": [[-2.5, 0.0], [3.0, 0.0]],
    "point": [-0.36, 0.0],
    "obstacle": "ball",
    "time_to_collision": 4.3,
}
SPEC = {"dangers": [DANGER], "gazes": {"person": [GAZE]}, "known": {}, "bystanders": [], "delay": 0.2}
SEARCH = {"kind": "search", "spec": SPEC, "uncertainty": {"samples": 16}, "threshold": 0.2, "max_moves": 4}


def test_searches_and_joint_imaginations_are_served_first() -> None:
    person = {"kind": "person", "person": "person", "target": "couch", "gaze": GAZE}
    joint = {"kind": "joint", "walks": [], "move": None}
    assert judges_robot_moves([SEARCH]) and judges_robot_moves([person, joint])
    assert not judges_robot_moves([person, person]) and not judges_robot_moves(["not an item"])


@pytest.mark.parametrize(
    ("request_", "message"),
    [
        ({"kind": "dance", "person": "person", "target": "couch", "gaze": 0.1}, "request.kind: expected one of"),
        ({"kind": "person", "target": "couch", "gaze": 0.1}, "request.person: is required"),
        ({"kind": "person", "person": "ghost", "target": "couch", "gaze": 0.1}, "unknown person 'ghost'"),
        ({"kind": "person", "person": "person", "target": "fridge", "gaze": 0.1}, "unknown object 'fridge'"),
        ({"kind": "person", "person": "person", "target": "couch", "gaze": "up"}, "request.gaze: expected a number"),
        ({"kind": "person", "person": "person", "target": "couch", "gaze": 3.0}, "gaze: expected a pitch"),
        ({"kind": "joint", "move": None}, "request.walks: is required"),
        ({"kind": "joint", "walks": [], "move": None}, "request.walks: expected at least one walk"),
        (
            {
                "kind": "joint",
                "walks": [{"person": "person", "target": "couch", "gaze": 0.1}],
                "move": {"x": 1, "y": 2},
            },
            "request.move.target: is required",
        ),
        (
            {
                "kind": "joint",
                "walks": [{"person": "person", "target": "couch", "gaze": 0.1}],
                "move": {"target": "ball", "x": "a", "y": 2},
            },
            "request.move.x: expected a number",
        ),
        (
            {"kind": "joint", "walks": [{"person": "ghost", "target": "couch", "gaze": 0.1}], "move": None},
            "unknown person 'ghost'",
        ),
        (
            {
                "kind": "joint",
                "walks": [{"person": "person", "target": "couch", "gaze": 0.1}],
                "move": None,
                "delay": -1,
            },
            "request.delay: expected a non-negative number",
        ),
        (
            {"kind": "joint", "walks": [{"person": "person", "target": "couch"}], "move": None},
            "request.walks[0].gaze: is required",
        ),
        ([1, 2], "request: expected a mapping"),
        ({**SEARCH, "spec": None}, "request.spec: expected a mapping, got None"),
        ({**SEARCH, "uncertainty": {"samples": -3}}, "request.uncertainty.samples: expected a positive number"),
        ({**SEARCH, "spec": {**SPEC, "dangers": []}}, "request.spec.dangers: expected a danger, or a bystander"),
        ({**SEARCH, "spec": {**SPEC, "gazes": {}}}, "request.spec.gazes.person: is required"),
        ({**SEARCH, "spec": {**SPEC, "gazes": {"person": [4.0]}}}, "request.spec.gazes.person: expected one or more"),
        ({**SEARCH, "spec": {**SPEC, "delay": 60}}, "request.spec.delay: expected at most 5.0"),
        ({**SEARCH, "spec": {**SPEC, "keep_clear": -0.5}}, "request.spec.keep_clear: expected a non-negative number"),
        ({**SEARCH, "threshold": 2}, "request.threshold: expected at most 1.0"),
        ({**SEARCH, "max_moves": 0}, "request.max_moves: expected a positive number"),
        (
            {**SEARCH, "spec": {**SPEC, "dangers": [{**DANGER, "time_to_collision": "soon"}]}},
            "request.spec.dangers[0].time_to_collision: expected a positive number",
        ),
    ],
)
def test_malformed_requests_raise_request_error(scene: Scene, request_: object, message: str) -> None:
    with pytest.raises(RequestError, match=message.replace("(", r"\(").replace("[", r"\[")):
        serve_item(scene, request_)


@pytest.mark.parametrize(
    ("data", "message"),
    [
        ({"bounds": [0, 0, -1, 1], "obstacles": [], "people": [], "robot": None}, "scene.bounds: expected xmin < xmax"),
        (
            {
                "bounds": [0, 0, 1, 1],
                "obstacles": [{"name": "a", "kind": "ball", "height": 1, "shape": {"type": "star", "x": 0, "y": 0}}],
                "people": [],
            },
            "scene.obstacles[0].shape.type",
        ),
        ({"bounds": [0, 0, 1, 1], "obstacles": [], "people": [{"name": "p"}]}, "scene.people[0].x: is required"),
        ({"bounds": [0, 0, 1, 1], "obstacles": [], "people": [], "robot": {"name": "r"}}, "scene.robot.x: is required"),
    ],
)
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
