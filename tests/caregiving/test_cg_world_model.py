"""Ground truth: idle outcomes of the shipped scenarios, replanning, commanded robot."""

import math
from dataclasses import replace

import numpy as np
import pytest
from recorded_cases import HELD_OUT, STACK_SCENARIOS

from agents.caregiving.model.joint import imagine_joint
from agents.caregiving.model.robot_moves import RobotMove, standoff_moves, travel_time
from agents.caregiving.model.scenario import load_scenario, sample_trial
from agents.caregiving.model.scene import Obstacle
from agents.caregiving.model.visibility import can_see
from agents.caregiving.model.world_model import Passing, Walk, World, _Walker, run_idle
from bridges.world.bridge import trial_for


def test_paper_default_person_does_not_see_the_ball_and_collides() -> None:
    s = load_scenario("paper_experiment1")
    scene = s.scene()
    person = scene.people[0]
    assert not can_see(person, scene.obstacle("ball"), math.radians(s.people[0].gaze_deg))
    out = run_idle(s)
    assert out.collided
    (hit,) = out.collisions
    assert hit.person == "person" and hit.obstacle == "ball"
    assert hit.time == pytest.approx(4.3)
    assert math.hypot(hit.point[0], hit.point[1]) == pytest.approx(0.11, abs=1e-6)
    assert out.arrival["person"] is None and out.min_clearance["person"] <= 0.0


def test_a_person_imagined_passing_walks_through_or_touches_only_deeper_than_the_allowance() -> None:
    """The paper's person, imagined passing the ball: not there for them, they walk through it to the couch and
    say how deep they went and how large it is; allowed deeper than that, they pass it; allowed half as deep, they touch it later."""
    s = load_scenario("paper_experiment1")
    walks = [Walk("person", s.people[0].target, math.radians(s.people[0].gaze_deg))]
    idle = World(s.scene(), walks).run()
    through = World(s.scene(), walks, passing={"person": Passing("ball")})
    assert not through.run().collided and through.walker("person").status == "arrived"
    depth = through.passed_clearance("person")
    assert depth is not None and depth < 0.0
    assert through.passed_size("person") == pytest.approx(s.scene().obstacle("ball").shape.bound)
    assert World(s.scene(), walks).passed_clearance("person") is None
    assert World(s.scene(), walks).passed_size("person") is None
    assert World(s.scene(), walks, passing={"person": Passing("wall0")}).passed_size("person") is None  # known exactly
    missed = World(s.scene(), walks, passing={"person": Passing("ball", -depth + 0.01)}).run()
    assert not missed.collided
    grazed = World(s.scene(), walks, passing={"person": Passing("ball", -depth / 2)}).run()
    (hit,) = grazed.collisions
    assert hit.obstacle == "ball" and hit.time > idle.collisions[0].time


def test_person_who_sees_the_obstacle_walks_around_it() -> None:
    out = run_idle(load_scenario("person_sees_obstacle"))
    assert not out.collided
    assert out.closest["person"] == "plant" and 0.0 < out.min_clearance["person"] < 0.2
    assert out.arrival["person"] == pytest.approx(10.6, abs=0.5)


def test_safe_walk_and_two_people() -> None:
    assert not run_idle(load_scenario("safe_walk")).collided
    two = run_idle(load_scenario("two_people"))
    assert [c.person for c in two.collisions] == ["person"]
    assert two.arrival["visitor"] is not None


def test_cluttered_room_outcome_is_deterministic() -> None:
    s = load_scenario("cluttered_room")
    assert run_idle(s) == run_idle(s)


def test_robot_in_front_of_the_ball_prevents_the_collision() -> None:
    s = load_scenario("paper_experiment1")
    world = World.from_scenario(s)
    move = next(m for m in standoff_moves(s.scene(), "ball") if m.x < -0.4 and abs(m.y) < 1e-6)
    assert world.command_robot(move)
    out = world.run()
    assert not out.collided and out.arrival["person"] is not None
    assert (world.robot.x, world.robot.y) == pytest.approx((move.x, move.y))
    assert world.robot.heading == pytest.approx(move.heading)


def test_robot_respects_speed_and_acceleration() -> None:
    s = load_scenario("safe_walk")
    world = World.from_scenario(s)
    assert world.command_robot(RobotMove("door", 0.0, 1.0, 0.0))
    xs, ys = [world.robot.x], [world.robot.y]
    arrived_at = None
    for _ in range(200):
        world.step()
        xs.append(world.robot.x)
        ys.append(world.robot.y)
        if arrived_at is None and (world.robot.x, world.robot.y) == (0.0, 1.0):
            arrived_at = world.time
    v = np.hypot(np.diff(xs), np.diff(ys)) / world.dt
    r = s.robot
    assert v.max() <= r.max_speed + 1e-9
    moving = np.flatnonzero(v > 0)
    dv = np.abs(np.diff(v[: moving[-1] + 1]))
    assert dv.max() / world.dt <= r.max_accel + 1e-6
    assert v[moving[-1]] <= 2 * r.max_accel * world.dt  # the stopping step is gentle too
    assert arrived_at == pytest.approx(travel_time(3.0, r.max_speed, r.max_accel), abs=0.15)


def test_unreachable_command_and_stopping() -> None:
    world = World.from_scenario(load_scenario("safe_walk"))
    assert not world.command_robot(RobotMove("couch", 3.5, 0.0, 0.0))
    assert world.command_robot(RobotMove("door", 0.0, 1.0, 0.0))
    for _ in range(20):
        world.step()
    assert world.command_robot(None)
    for _ in range(40):
        world.step()
    before = (world.robot.x, world.robot.y)
    world.step()
    assert (world.robot.x, world.robot.y) == before


def test_person_replans_when_the_robot_comes_into_view() -> None:
    s = load_scenario("paper_experiment1")
    idle = World.from_scenario(s)
    idle.step()
    path_before = idle._walkers[0].route.points.copy()
    world = World.from_scenario(s)
    move = next(m for m in standoff_moves(s.scene(), "ball") if m.x < -0.4 and abs(m.y) < 1e-6)
    world.command_robot(move)
    for _ in range(60):
        world.step()
    assert not np.array_equal(world._walkers[0].route.points, path_before)
    assert "robot" in world._walkers[0].known


def test_sampled_trials_mix_risky_and_safe() -> None:
    s = load_scenario("paper_experiment1")
    rng = np.random.default_rng(3)
    outcomes = [run_idle(sample_trial(s, rng)).collided for _ in range(12)]
    assert any(outcomes) and not all(outcomes)


def test_max_time_bounds_a_run() -> None:
    out = World.from_scenario(load_scenario("safe_walk")).run(max_time=1.0)
    assert out.duration == pytest.approx(1.0) and out.arrival["person"] is None


def test_a_person_sees_the_robot_turn_and_walks_around_its_new_footprint() -> None:
    """The robot drives a few centimetres and turns a quarter at the end: its centre moves less than
    REPLAN_SHIFT, its corners much more. The person, who sees it, must not walk into the turned robot."""
    trial = trial_for(load_scenario(str(STACK_SCENARIOS / "box_obstacle_exact.yaml")), 7, 22)
    world = World.from_scenario(trial)
    while world.time < 0.65 - 1e-9:
        world.step()
    assert world.command_robot(RobotMove("parcel", 1.511, -0.668, -math.pi))
    while world.time < 4.55 - 1e-9:
        world.step()
    assert world.command_robot(RobotMove("parcel", 1.31, -0.25, math.pi / 2))
    assert not world.run(30.0).collided


def test_a_walk_that_knows_the_robot_plans_around_it_from_the_start_where_they_remember_it() -> None:
    scene = load_scenario("paper_experiment1").scene()
    assert scene.robot is not None
    world = World(scene, [Walk("person", "couch", 0.1, known=("robot",))])
    assert world.walker("person").known["robot"] == scene.robot.body()
    assert world.robot_memory("person") == scene.robot.pose
    elsewhere = (scene.robot.x + 0.3, scene.robot.y - 0.2, 1.0)
    world = World(scene, [Walk("person", "couch", 0.1, known=("robot",), robot_at=elsewhere)])
    assert world.walker("person").known["robot"] == scene.robot.moved(*elsewhere).body()
    assert world.robot_memory("person") == elsewhere
    assert World(scene, [Walk("person", "couch", 0.1, robot_at=elsewhere)]).robot_memory("person") is None


def test_a_walk_imagined_midway_ends_as_the_truth_only_with_where_the_person_remembers_the_robot() -> None:
    """Face to face, seed 331, trial 2: the robot drives to the toy; 0.33 s later the resident last looked at it
    3 cm back along its way. Imagined from that moment with that memory, she walks the truth's track to the end;
    imagined knowing the robot where it stands, she replans at another step and walks into it."""
    trial = trial_for(load_scenario(str(HELD_OUT / "face_to_face.yaml")), 331, 2)
    truth = World.from_scenario(trial)
    move = RobotMove("toy", 1.1913, 0.0778, 1.5656)
    truth.advance(0.72)
    assert truth.command_robot(move)
    truth.advance(1.05)
    scene, walker = truth.scene(), truth.walker("resident")
    memory = truth.robot_memory("resident")
    assert memory is not None and scene.robot is not None and memory != scene.robot.pose
    known = tuple(n for n in walker.known if not n.startswith("wall"))
    steps = len(walker.track)
    truth.run(60.0)
    assert truth.walker("resident").status == "arrived"
    expected = np.array(truth.walker("resident").track[steps - 1 :])
    remembered = imagine_joint(scene, [Walk("resident", walker.target, walker.gaze, known, memory)], move, current=move)
    (walk,) = remembered.walks
    assert walk.status == "arrived" and np.array(walk.track).shape == expected.shape
    assert np.abs(np.array(walk.track) - expected).max() < 1e-9
    as_it_stands = imagine_joint(scene, [Walk("resident", walker.target, walker.gaze, known)], move, current=move)
    assert as_it_stands.walks[0].collision_object == "robot"


@pytest.mark.parametrize("scenario", ["paper_experiment1", "box_obstacle", "cluttered_room", "two_people"])
def test_advancing_in_bulk_ends_as_stepping_does(scenario: str) -> None:
    """World.advance walks a lone person past a resting robot in one pass; every step must be as World.step's."""

    class Counted(World):
        steps = 0

        def step(self) -> None:
            self.steps += 1
            super().step()

    s = load_scenario(scenario)
    rng = np.random.default_rng(17)
    checked = bulk_steps = single_steps = 0
    for _ in range(8):
        trial = sample_trial(s, rng)
        moves: list[RobotMove | None] = [None, *standoff_moves(trial.scene(), s.people[0].target)[:2]]
        for move in moves:
            bulk, stepped = Counted.from_scenario(trial), World.from_scenario(trial)
            bulk.advance(0.3)
            for _ in range(6):
                stepped.step()
            bulk.command_robot(move)
            stepped.command_robot(move)
            bulk.advance(40.0)
            while not stepped.done and stepped.time < 40.0 - 1e-9:
                stepped.step()
            a, b = bulk.outcome(), stepped.outcome()
            assert [(c.person, c.obstacle) for c in a.collisions] == [(c.person, c.obstacle) for c in b.collisions]
            assert [c.time for c in a.collisions] == pytest.approx([c.time for c in b.collisions], abs=1e-9)
            assert a.arrival == pytest.approx(b.arrival, abs=1e-9) and a.closest == b.closest
            assert a.min_clearance == pytest.approx(b.min_clearance, abs=1e-12)
            assert bulk.robot_seen == pytest.approx(stepped.robot_seen, abs=1e-9)
            for p in s.people:
                assert np.allclose(bulk.walker(p.name).track, stepped.walker(p.name).track, atol=1e-9, rtol=0)
                # The length walked bounds when a thing out of sight can show (World._sees): step by step.
                assert bulk.walker(p.name).travelled == pytest.approx(stepped.walker(p.name).travelled, abs=1e-9)
            checked += 1
            bulk_steps += bulk.steps
            single_steps += round(stepped.time / stepped.dt)
    assert checked == 24 and bulk_steps < 0.8 * single_steps  # many steps went in bulk


@pytest.mark.parametrize(
    "scenario",
    [
        "two_people",
        "two_people_two_obstacles",
        *(str(HELD_OUT / f"{n}.yaml") for n in ("three_people_lounge", "crossing_hall")),
    ],
)
def test_looking_again_only_when_a_thing_could_show_ends_as_looking_every_step(scenario: str) -> None:
    """World._sees skips what stays hidden within visibility.sight's bound (the robot's for the disc it turns
    in), and World._check_contacts what never moves and stays farther than the closest approach; with several
    people walking past a driving robot, every trial must end as it does with every look and clearance worked
    out."""
    s = load_scenario(scenario)
    rng = np.random.default_rng(23)
    for _ in range(4):
        trial = sample_trial(s, rng)
        for move in [None, *standoff_moves(trial.scene(), s.people[0].target)[:2]]:
            walks = [Walk(p.name, p.target, math.radians(p.gaze_deg)) for p in trial.people]
            _walk_alike(World(trial.scene(), walks), _LooksEveryStep(trial.scene(), walks), move)


def test_a_slow_walker_overtaken_sees_the_other_come_into_view_at_once() -> None:
    """The slow walker has hardly moved when the fast one comes into their cone: the other's steps count
    against visibility.sight's bound too."""
    scene = load_scenario("two_people").scene()
    slow, fast = scene.people
    overtaken = replace(scene, people=(replace(slow, speed=0.05), fast.moved(-3.4, -0.4, 0.15)))
    walks = [Walk("person", "couch", math.radians(8)), Walk("visitor", "door", math.radians(8))]
    _walk_alike(World(overtaken, walks), _LooksEveryStep(overtaken, walks), None)


class _LooksEveryStep(World):
    """The world with every look and every clearance worked out afresh at every step."""

    def _sees(self, w: _Walker, o: Obstacle) -> bool:
        return can_see(w.state, o, w.gaze)

    def _check_contacts(self, w: _Walker, around: tuple[Obstacle, ...]) -> None:
        w.measured.clear()
        super()._check_contacts(w, around)


def _walk_alike(bounded: World, every: World, move: RobotMove | None) -> None:
    """Step both worlds with the robot sent on ``move`` and check that everybody sees the same things at the
    same step, and that the walks end alike."""
    for world in (bounded, every):
        world.advance(0.3)
        world.command_robot(move)
    names = every.walking()
    while not every.done and every.time < 40.0 - 1e-9:
        bounded.step()
        every.step()
        for name in names:
            assert bounded.walker(name).known.keys() == every.walker(name).known.keys()
    assert bounded.outcome() == every.outcome() and bounded.robot_seen == every.robot_seen
    for name in names:
        assert bounded.walker(name).track == every.walker(name).track


def test_a_world_begun_midway_walks_the_route_planned_where_the_walk_began() -> None:
    """The imagination starts from a scene mid-walk; a route planned afresh there bends elsewhere than the truth's."""
    truth = World.from_scenario(trial_for(load_scenario(str(HELD_OUT / "corner_flat.yaml")), 3, 12))
    while truth.time < 0.6 - 1e-9:
        truth.step()
    scene, walker = truth.scene(), truth.walker("resident")
    walk = Walk("resident", walker.target, walker.gaze, tuple(walker.known))
    steps = len(walker.track)
    truth.run()
    tracks = {}
    for origin in (scene.person("resident").origin, None):
        person = replace(scene.person("resident"), origin=origin)
        twin = World(replace(scene, people=(person,)), [walk])
        twin.run()
        tracks[origin is not None] = np.array(twin.walker("resident").track)
    expected = np.array(truth.walker("resident").track[steps - 1 :])
    assert tracks[True].shape == expected.shape
    assert np.abs(tracks[True] - expected).max() < 1e-9
    assert np.abs(tracks[False][: len(expected) // 2] - expected[: len(expected) // 2]).max() > 0.02


def test_setting_off_away_from_what_one_stands_against_is_no_fall_walking_into_it_is() -> None:
    """As in the rollouts: someone imagined 5 cm into the door they reached (a belief a few sigmas off),
    setting off for the couch, does not fall over the door; someone 5 cm into the ball and walking on into it
    falls at once."""
    scene = load_scenario("two_people").scene()
    visitor = replace(scene.person("visitor"), x=1.5, y=2.7, heading=-math.pi / 2)  # 5 cm into the door
    person = replace(scene.person("person"), x=-0.31, y=0.0, heading=0.0)  # 5 cm into the ball, facing it
    at_door = World(replace(scene, people=(visitor,)), [Walk("visitor", "couch", 0.0)])
    assert at_door.walker("visitor").leaving == {"door": pytest.approx(-0.05)}
    away = at_door.run()
    assert not away.collided and away.arrival["visitor"] is not None and away.min_clearance["visitor"] > 0.0
    into = World(replace(scene, people=(person,)), [Walk("person", "couch", 0.0)]).run()
    assert [(c.obstacle, c.time) for c in into.collisions] == [("ball", pytest.approx(0.05))]
