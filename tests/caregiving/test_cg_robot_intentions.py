"""The robot's side of W for Algorithm 2: reading dangers and the move under way, writing moves and stops."""

import argparse
import math
from dataclasses import replace

import pytest

import wm
from agents.caregiving.action import Action
from agents.caregiving.context import Context
from agents.caregiving.intention import Intention
from agents.caregiving.model.guesses import DEFAULT_WALKING, Walking, unguessed_walks
from agents.caregiving.model.robot_moves import RobotMove
from agents.caregiving.model.scenario import load_scenario
from agents.caregiving.model.verdict import Verdict
from agents.caregiving.names import HAS, HAS_INTENTION, KNOWS, OBJECT, PERSON, ROBOT
from agents.caregiving.odometry import OdometryClock
from agents.caregiving.person_intentions import remember_robot
from agents.caregiving.risk_options import walking
from agents.caregiving.robot_intentions import (
    bystander_walks,
    dangers_in,
    move_of,
    move_under_way,
    search_spec,
    write_intention,
)


@pytest.fixture()
def w() -> tuple[wm.Graph, Context]:
    """A replica holding the paper room's people, objects and robot, and a context on it at 1 s."""
    scene = load_scenario("paper_experiment1").scene()
    g = wm.Graph()
    ids = {p.name: g.insert_node(PERSON, p.name) for p in scene.people}
    ids |= {o.name: g.insert_node(OBJECT, o.name) for o in scene.obstacles if o.kind != "wall"}
    assert scene.robot is not None
    ids[scene.robot.name] = g.insert_node(ROBOT, scene.robot.name)
    scene = replace(scene, time=1.0)
    return g, Context(scene, 3, ids, {}, {}, 0.0)


def risky(g: wm.Graph, ctx: Context, target: str, ttc: float, at_time: float) -> wm.Edge:
    g.insert_or_assign_edge(
        ctx.ids["person"],
        ctx.ids[target],
        HAS_INTENTION,
        {
            "risky": True,
            "path": [-2.5, 0.0, 3.0, 0.0],
            "collision_point": [-0.3, 0.0],
            "collision_object": ctx.ids["ball"],
            "time_to_collision": ttc,
            "at_time": at_time,
            "gaze": math.radians(8),
        },
    )
    edge = g.find_edge(ctx.ids["person"], ctx.ids[target], HAS_INTENTION)
    assert edge is not None
    return edge


def test_the_most_urgent_danger_not_due_nor_failed_lately_is_read(w: tuple[wm.Graph, Context]) -> None:
    g, ctx = w
    to_couch, to_door = risky(g, ctx, "couch", 2.0, 0.5), risky(g, ctx, "door", 1.0, 0.8)
    dangers = dangers_in(ctx, [to_couch, to_door], {}, 0.5)
    edge, danger = dangers["person"]
    assert edge == to_door and danger.target == "door" and danger.obstacle == "ball"
    assert danger.time_to_collision == pytest.approx(0.8)  # 1 s from the edge's 0.8 s, the context is at 1 s
    assert danger.path == ((-2.5, 0.0), (3.0, 0.0))
    assert dangers_in(ctx, [risky(g, ctx, "door", 0.1, 0.5)], {}, 0.5) == {}  # due before now
    assert dangers_in(ctx, [to_couch], {ctx.ids["person"]: 0.7}, 0.5) == {}  # no move found 0.3 s ago
    assert dangers_in(ctx, [to_couch], {ctx.ids["person"]: 0.4}, 0.5) != {}


def test_a_bystander_is_imagined_on_their_guesses_or_when_walking_unguessed_on_every_target_ahead(
    w: tuple[wm.Graph, Context],
) -> None:
    g, ctx = w
    person = ctx.scene.person("person")
    moving = replace(ctx, velocity={"person": (0.5, 0.1)})
    assert bystander_walks(g, ctx, person) == ([], None)  # standing, nothing guessed: imagined standing
    ahead, guess = bystander_walks(g, moving, person)
    assert guess is None and ahead == list(unguessed_walks(person, ctx.scene.obstacles)) and len(ahead) > 1
    for target, updated in (("couch", 1.0), ("door", 2.0)):
        g.insert_or_assign_edge(ctx.ids["person"], ctx.ids[target], HAS_INTENTION, {"gaze": 0.1, "updated_at": updated})
    walks, guess = bystander_walks(g, moving, person)
    assert [x.target for x in walks] == ["door", "couch"]  # every guess, the latest first
    assert guess is not None and guess.dst == ctx.ids["door"]
    assert [x.target for x in bystander_walks(g, ctx, person)[0]] == ["door"]  # standing: the latest only
    slower = Walking(speed=0.6)  # the agents' --moving-speed: at 0.51 m/s the person now stands
    assert [x.target for x in bystander_walks(g, moving, person, slower)[0]] == ["door"]
    young = replace(ctx, velocity={"person": (0.05, 0.0)}, velocity_sigma={"person": 0.3})
    assert len(bystander_walks(g, young, person)[0]) == 2  # a track too young to tell: she may be walking


def test_someone_fallen_is_in_no_danger_and_walks_nowhere(w: tuple[wm.Graph, Context]) -> None:
    g, ctx = w
    edge = risky(g, ctx, "couch", 2.0, 0.5)
    g.insert_or_assign_edge(ctx.ids["person"], ctx.ids["door"], HAS_INTENTION, {"gaze": 0.1, "updated_at": 1.0})
    moving = replace(ctx, velocity={"person": (0.5, 0.1)})
    assert dangers_in(moving, [edge], {}, 0.5) != {} and bystander_walks(g, moving, ctx.scene.person("person"))[0]
    lying = replace(moving, fallen=frozenset({"person"}))
    assert dangers_in(lying, [edge], {}, 0.5) == {}
    assert bystander_walks(g, lying, ctx.scene.person("person")) == ([], None)


def test_the_action_agent_takes_the_intention_agents_walking_options() -> None:
    """Who walks, and which targets lie aside of them, must be the same for Algorithm 1 and Algorithm 2."""
    parsers = []
    for agent in (Action, Intention):
        parser = argparse.ArgumentParser()
        agent.add_arguments(parser)
        parsers.append(parser)
    argv = ["--heading-gate-deg", "15", "--moving-speed", "0.3"]
    action, intention = (walking(p.parse_args(argv)) for p in parsers)
    assert action == intention == Walking(0.3, math.radians(30))
    assert walking(parsers[0].parse_args([])) == DEFAULT_WALKING


def test_a_move_then_a_stop_are_written_each_superseding_the_one_before(w: tuple[wm.Graph, Context]) -> None:
    g, ctx = w
    dangers = dangers_in(ctx, [risky(g, ctx, "couch", 2.0, 1.0)], {}, 0.5)
    move = RobotMove("ball", 0.4, 0.0, math.pi)
    assert write_intention(g, ctx, Verdict(move, True, 0.0, 1.5, "clear"), dangers, None, "1") is not None
    first = move_under_way(g)
    assert first is not None and first.name == "move_to_3_1" and move_of(first, ctx) == move
    assert first.get("in_time") and first.get("reason") == "clear; protects person"
    assert [e.src for e in g.edges(type=HAS, dst=first.id)] == [ctx.ids["robot"]]
    spec = search_spec(g, ctx, dangers, first)
    assert spec.current == move and spec.dangers == (dangers["person"][1],)

    write_intention(g, ctx, Verdict(None, False, 1.0, None, "falls as idle"), dangers, first, "2", "bob")
    stop = move_under_way(g)
    assert stop is not None and stop.name == "stop_3_2" and stop.get("action") == "stop"
    assert stop.get("target") == ctx.ids["robot"] and move_of(stop, ctx) is None and not stop.get("in_time")
    assert "not saved: bob" in stop.get("reason")
    assert g.get_node(first.id).get("status") == "superseded"
    assert search_spec(g, ctx, dangers, stop).current is None  # braking is the move None


def test_the_robot_is_remembered_where_the_person_last_surely_saw_it_and_searched_from_there(
    w: tuple[wm.Graph, Context],
) -> None:
    g, ctx = w
    robot = ctx.scene.robot
    assert robot is not None

    def with_robot(x: float, y: float, heading: float) -> Context:
        return replace(ctx, scene=replace(ctx.scene, robot=robot.moved(x, y, heading)))

    assert remember_robot(g, ctx, "person") == robot.pose  # it stands in their view, at every gaze
    edge = g.find_edge(ctx.ids["person"], ctx.ids[robot.name], KNOWS)
    assert edge is not None and tuple(edge.get("seen_at")) == pytest.approx(robot.pose)
    assert remember_robot(g, with_robot(robot.x, robot.y + 0.05, robot.heading), "person") == robot.pose  # 5 cm on
    behind = with_robot(-3.3, 0.0, 0.0)  # driven behind them: they did not see it go
    assert remember_robot(g, behind, "person") == robot.pose
    dangers = dangers_in(behind, [risky(g, behind, "couch", 2.0, 0.5)], {}, 0.5)
    spec = search_spec(g, behind, dangers, None)
    assert "robot" in spec.known["person"] and spec.robot_at == {"person": pytest.approx(robot.pose)}
    (walk, *_) = spec.walk_sets()[0]
    assert walk.robot_at == pytest.approx(robot.pose)
    ahead = with_robot(robot.x + 0.5, robot.y, robot.heading)  # seen again, half a metre on
    assert ahead.scene.robot is not None and remember_robot(g, ahead, "person") == ahead.scene.robot.pose


def test_a_bystander_is_imagined_knowing_what_their_knows_edges_say() -> None:
    scene = replace(load_scenario("two_people").scene(), time=1.0)
    g = wm.Graph()
    ids = {p.name: g.insert_node(PERSON, p.name) for p in scene.people}
    ids |= {o.name: g.insert_node(OBJECT, o.name) for o in scene.obstacles if o.kind != "wall"}
    assert scene.robot is not None
    ids[scene.robot.name] = g.insert_node(ROBOT, scene.robot.name)
    ctx = Context(scene, 3, ids, {}, {}, 0.0)
    g.insert_or_assign_edge(ids["visitor"], ids["door"], KNOWS, {})
    g.insert_or_assign_edge(ids["visitor"], ids["robot"], KNOWS, {"seen_at": [0.5, -1.5, 0.0]})
    g.insert_or_assign_edge(ids["visitor"], ids["couch"], HAS_INTENTION, {"risky": False, "gaze": 0.1})
    dangers = dangers_in(ctx, [risky(g, ctx, "couch", 2.0, 0.5)], {}, 0.5)
    spec = search_spec(g, ctx, dangers, None)
    assert spec.bystanders and all(w.person == "visitor" for w in spec.bystanders)
    assert all(w.known == ("door", "robot") and w.robot_at == (0.5, -1.5, 0.0) for w in spec.bystanders)
    assert spec.robot_at == {} and set(spec.known) == {"person"}


def test_nothing_is_written_for_a_person_gone_from_w(w: tuple[wm.Graph, Context]) -> None:
    g, ctx = w
    dangers = dangers_in(ctx, [risky(g, ctx, "couch", 2.0, 1.0)], {}, 0.5)
    g.delete_node(ctx.ids["person"])
    assert write_intention(g, ctx, Verdict(None, True, 0.0, None, ""), dangers, None, "1") is None
    assert move_under_way(g) is None


def test_the_odometry_clock_tells_the_lag_and_the_rate(w: tuple[wm.Graph, Context]) -> None:
    g, ctx = w
    clock = OdometryClock()
    assert clock.lag(g, 1.0) == 0.0 and clock.rate(g) == 1.0  # no odometry yet
    g.update_node("robot", {"stamp": 1.0, "written_at": 100.0})
    assert clock.rate(g) == 1.0
    g.update_node("robot", {"stamp": 1.6, "written_at": 101.2})
    assert clock.lag(g, 1.0) == pytest.approx(0.6) and clock.rate(g) == pytest.approx(0.5)
    clock.reset()
    assert clock.rate(g) == 1.0  # a new trial starts a new clock
