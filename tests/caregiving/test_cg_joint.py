"""The joint imagination in time against the world model, on fixed cases: same outcome, paths within 5 cm."""

import math
from dataclasses import replace

import msgpack
import numpy as np
import pytest

from agents.caregiving.model.errors import RequestError
from agents.caregiving.model.geometry import Polyline
from agents.caregiving.model.joint import JointImagination, imagine_joint
from agents.caregiving.model.robot_moves import RobotMove, standoff_moves
from agents.caregiving.model.scenario import Scenario, load_scenario
from agents.caregiving.model.world_model import Outcome, Passing, Walk, World

GAZE = math.radians(8)


def truth(s: Scenario, move: RobotMove | None, delay: float) -> tuple[Outcome, World]:
    world = World.from_scenario(s)
    while world.time < delay - 1e-9:
        world.step()
    world.command_robot(move)
    return world.run(30.0), world


def cross_check(s: Scenario, move: RobotMove, delay: float) -> JointImagination:
    """Imagine the move from the scenario's start; assert the world agrees, and return the imagination."""
    joint = imagine_joint(s.scene(), [Walk("person", s.people[0].target, GAZE)], move, delay=delay)
    out, world = truth(s, move, delay)
    walk = joint.walks[0]
    assert walk.collided == out.collided
    if out.collided:
        assert walk.collision_object == out.collisions[0].obstacle
        assert walk.collision_time == pytest.approx(out.collisions[0].time, abs=0.051)
    imagined, real = np.array(walk.track), np.array(world.walker("person").track)
    n = min(len(imagined), len(real))
    assert abs(len(imagined) - len(real)) <= 1
    assert np.hypot(*(imagined[:n] - real[:n]).T).max() <= 0.05
    return joint


@pytest.fixture(scope="module")
def paper() -> Scenario:
    return load_scenario("paper_experiment1")


def in_front_of_the_ball(s: Scenario) -> RobotMove:
    return next(m for m in standoff_moves(s.scene(), "ball") if m.x < -0.4 and abs(m.y) < 1e-6)


def test_a_robot_that_arrives_in_time_saves_the_person(paper: Scenario) -> None:
    joint = cross_check(paper, in_front_of_the_ball(paper), 0.0)
    assert joint.safe and joint.robot_arrival is not None
    assert joint.walks[0].saw_robot_at is not None and "robot" in joint.walks[0].seen


def test_a_robot_that_arrives_late_does_not(paper: Scenario) -> None:
    joint = cross_check(paper, in_front_of_the_ball(paper), 3.0)
    assert not joint.safe and joint.walks[0].collision_object == "ball"


def test_a_robot_crossing_the_path_causes_the_collision_it_predicts() -> None:
    safe = load_scenario("safe_walk")
    assert not truth(safe, None, 0.0)[0].collided
    joint = cross_check(safe, RobotMove("couch", -1.6, 1.6, 0.0), 0.0)
    assert not joint.safe and joint.walks[0].collision_object == "robot"


def test_someone_walking_with_no_target_known_walks_straight_to_their_point_and_into_a_robot_crossing() -> None:
    """A walk ``toward`` a point: the person arrives there with the robot idle, and walks into it crossing their way
    as into any robot; it goes over the wire as it came."""
    scene = load_scenario("safe_walk").scene()
    ahead = Walk("person", "", GAZE, toward=(1.0, 0.0))
    idle = imagine_joint(scene, [ahead], None)
    (walk,) = idle.walks
    assert walk.status == "arrived" and walk.track[-1] == pytest.approx((1.0, 0.0), abs=1e-6)
    assert all(abs(y) < 1e-6 for _, y in walk.track)  # straight along the way
    crossing = imagine_joint(scene, [ahead], RobotMove("couch", -1.0, 0.6, -math.pi / 2))
    assert crossing.walks[0].collision_object == "robot"
    assert JointImagination.from_wire(msgpack.unpackb(msgpack.packb(crossing.to_wire()))) == crossing


def test_the_robot_keeps_its_current_move_during_the_delay() -> None:
    scene = load_scenario("safe_walk").scene()
    aside = RobotMove("couch", 2.0, -2.0, 0.0)
    walk = [Walk("person", "couch", GAZE)]
    kept = imagine_joint(scene, walk, aside, delay=1.0, current=aside)
    stopped = imagine_joint(scene, walk, aside, delay=1.0)
    assert kept.robot_arrival is not None and stopped.robot_arrival is not None
    assert kept.robot_arrival < stopped.robot_arrival


def test_moving_robot_speed_carries_into_the_imagination(paper: Scenario) -> None:
    scene = paper.scene()
    walk = [Walk("person", "couch", GAZE)]
    robot = scene.robot
    assert robot is not None
    rolling = scene.with_robot(type(robot)(**{**vars(robot), "speed": robot.max_speed}))
    move = in_front_of_the_ball(paper)
    assert imagine_joint(rolling, walk, move).robot_arrival < imagine_joint(scene, walk, move).robot_arrival


def test_wire_round_trip_and_errors(paper: Scenario) -> None:
    scene = paper.scene()
    joint = imagine_joint(scene, [Walk("person", "couch", GAZE, ("door",))], in_front_of_the_ball(paper))
    assert JointImagination.from_wire(msgpack.unpackb(msgpack.packb(joint.to_wire()))) == joint
    braking = imagine_joint(scene, [Walk("person", "couch", GAZE)], None)
    assert braking.move is None and braking.walks[0].collided
    assert JointImagination.from_wire(braking.to_wire()) == braking
    passing = imagine_joint(scene, [Walk("person", "couch", GAZE)], None, passing={"person": Passing("ball")})
    assert passing.walks[0].passed_size is not None
    assert JointImagination.from_wire(msgpack.unpackb(msgpack.packb(passing.to_wire()))) == passing
    with pytest.raises(RequestError, match="no robot"):
        imagine_joint(scene.with_robot(None), [Walk("person", "couch", GAZE)], None)
    with pytest.raises(RequestError, match="unknown object 'fridge'"):
        imagine_joint(scene, [Walk("person", "fridge", GAZE)], None)


def test_a_move_under_way_goes_on_along_the_route_the_robot_reports(paper: Scenario) -> None:
    """A person who stepped onto the robot's route since its command does not re-route it: it drives on."""
    world = World.from_scenario(paper)
    move = in_front_of_the_ball(paper)
    assert world.command_robot(move)
    while world.time < 1.0 - 1e-9:
        world.step()
    going_on = world.fork()
    going_on.run(30.0)
    scene = world.scene()
    assert scene.robot is not None and len(scene.robot.route) >= 1 and scene.robot.speed > 0.0
    ahead = np.array([(scene.robot.x, scene.robot.y), *scene.robot.route])
    onto_route = Polyline.of(ahead).point_at(Polyline.of(ahead).length / 2)
    bystander = replace(scene.person("person"), name="bystander", x=onto_route[0], y=onto_route[1])
    scene = replace(scene, people=(*scene.people, bystander))
    kept = imagine_joint(scene, [Walk("person", paper.people[0].target, GAZE)], move, delay=0.3, current=move)
    assert going_on.robot_arrival is not None and kept.robot_arrival is not None
    assert kept.robot_arrival == pytest.approx(going_on.robot_arrival - 1.0, abs=0.051)


def test_until_first_fall_ends_at_the_first_fall_with_the_same_verdict() -> None:
    """The imagination a search asks for ends when someone falls: here the person, before the visitor is through."""
    scene = load_scenario("two_people_two_obstacles").scene()
    walks = [Walk("person", "couch", GAZE), Walk("visitor", "door", GAZE)]
    whole = imagine_joint(scene, walks, None)
    short = imagine_joint(scene, walks, None, until_first_fall=True)
    assert [w.status for w in whole.walks] == ["collided", "arrived"]
    assert [w.status for w in short.walks] == ["collided", "walking"]
    assert short.walks[0] == whole.walks[0]
    assert len(short.walks[1].track) < len(whole.walks[1].track)
    assert not short.safe and not whole.safe
    excused = imagine_joint(scene, walks, None, until_first_fall=True, falling={"person": "ball"})
    assert excused == whole and excused.safe_given({"person": "ball"}) and not excused.safe_given({"person": "couch"})
