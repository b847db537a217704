"""The robot's side of W when someone has fallen: the alert, the move to them, and how the other agents see both."""

from dataclasses import replace
from pathlib import Path

from recorded_cases import STACK_SCENARIOS

import wm
from agents.caregiving.context import Context
from agents.caregiving.fall_response import (
    alerts,
    end_alert,
    fallen,
    going_spec,
    raise_alert,
    seen_to,
    someone_in_danger,
    write_go_to,
)
from agents.caregiving.model.robot_moves import RobotMove
from agents.caregiving.model.scenario import load_scenario
from agents.caregiving.names import ALERT, GO_TO, HAS, HAS_INTENTION, INTENTION, OBJECT, PERSON, ROBOT
from agents.caregiving.robot_intentions import move_of, move_under_way


def w(
    scenario: str | Path = "paper_experiment1", lying: frozenset[str] = frozenset({"person"})
) -> tuple[wm.Graph, Context]:
    """A replica of ``scenario``'s room with the people ``lying`` where they fell, and a context on it at 2 s."""
    scene = replace(load_scenario(scenario).scene(), time=2.0)
    g = wm.Graph()
    ids = {
        p.name: g.insert_node(PERSON, p.name, {"fallen": True, "fallen_at": 1.85} if p.name in lying else {})
        for p in scene.people
    }
    ids |= {o.name: g.insert_node(OBJECT, o.name) for o in scene.obstacles if o.kind != "wall"}
    assert scene.robot is not None
    ids[scene.robot.name] = g.insert_node(ROBOT, scene.robot.name)
    return g, Context(scene, 3, ids, {}, {}, 0.0, lying)


def test_an_alert_names_who_fell_and_when_and_is_no_move() -> None:
    g, ctx = w()
    (person,) = fallen(g)
    alert = raise_alert(g, ctx, person, "1")
    node = g.get_node(alert)
    assert node.get("action") == ALERT and node.get("status") == "raised"
    assert node.get("target") == node.get("person") == person.id
    assert node.get("reason") == "person has fallen (seen lying at 1.85 s)"
    assert g.find_edge(ctx.ids["robot"], alert, HAS) is not None
    assert alerts(g) == {person.id: node} and move_under_way(g) is None  # the executor and the action agent skip it
    end_alert(g, node)
    assert alerts(g) == {} and g.get_node(alert).get("status") == "ended"


def test_a_move_to_someone_fallen_is_the_move_under_way_and_says_whom_it_is_for() -> None:
    g, ctx = w()
    move = RobotMove("person", -2.0, 0.6, -1.2)
    going = write_go_to(g, ctx, "person", move, "everyone imagined walks clear", "2")
    node = g.get_node(going)
    assert node.get("action") == GO_TO and node.get("status") == "proposed" and node.get("at_time") == 2.0
    assert node.get("final_pose") == (-2.0, 0.6, -1.2) and node.get("person") == ctx.ids["person"]
    assert seen_to(g) == {ctx.ids["person"]}
    under_way = move_under_way(g)
    assert under_way is not None and under_way.id == going and move_of(under_way, ctx) == move
    g.update_node(going, {"status": "superseded"})  # a move against a danger replaced it
    assert seen_to(g) == set() and move_under_way(g) is None
    assert [n.get("action") for n in g.nodes(INTENTION)] == [GO_TO]


def test_a_risky_walk_keeps_the_robot_from_going_unless_it_is_of_someone_fallen() -> None:
    g, ctx = w()
    g.insert_or_assign_edge(ctx.ids["person"], ctx.ids["couch"], HAS_INTENTION, {"risky": True})
    assert not someone_in_danger(g)  # a guess of someone lying there, not yet pruned
    g.update_node(ctx.ids["person"], {"fallen": False})
    assert someone_in_danger(g)
    g.insert_or_assign_edge(ctx.ids["person"], ctx.ids["couch"], HAS_INTENTION, {"risky": False})
    assert not someone_in_danger(g)


def test_a_move_to_someone_fallen_imagines_whoever_is_up_setting_off_though_nothing_is_guessed_of_them() -> None:
    """Two people: one lying there, one standing with no walk guessed (or tracked too briefly to tell). The spec
    a move to the fallen is judged with imagines the one standing on the walks ahead of them, not standing still."""
    g, ctx = w(STACK_SCENARIOS / "one_falls_one_walks_on.yaml", frozenset({"ana"}))
    spec = going_spec(g, ctx)
    assert spec.dangers == () and spec.bystanders and {w.person for w in spec.bystanders} == {"ben"}
    assert {w.target for w in spec.bystanders} <= {o.name for o in ctx.scene.obstacles if o.target}
