"""Prevention over the real processes: a saveable trial is flagged from the first frames showing the person,
and saved; a move that trips a person is never sent, and one already under way is braked; a person who has
fallen is seen lying and guessed walking no more, and the robot raises an alert and goes to them.

Trials of seed 7 of the box-obstacle room, with exact sensors so that the closed loop sees what the oracle
sees. The room runs at half speed: these tests check what the search decides, not how fast the pipeline is
(the experiment measures that), so a loaded machine must not turn a saving decision into a late one. The
saved trial is one whose saving moves stay many for seconds after the danger shows, for the same reason.
"""

from __future__ import annotations

import asyncio
import math
import time
from collections.abc import Iterator
from typing import Any

import pytest
from stack_helpers import GRAPH, SCENARIOS, recording_stack, run_trial

from agents.caregiving.model.move_search import SearchItem
from agents.caregiving.model.planner import GridPlanner
from agents.caregiving.model.recorded_batch import read_batches
from agents.caregiving.model.rollout import DT
from agents.caregiving.model.scenario import load_scenario
from agents.caregiving.model.service import item_from_wire
from agents.caregiving.model.world_model import run_idle
from agents.caregiving.names import ALERT, GO_TO, HAS, HAS_INTENTION, INTENTION, OBJECT, PERSON, ROBOT, WORLD
from bridges.experiment.falls_seen import falls_seen
from bridges.experiment.launch import Stack
from bridges.experiment.oracle import oracle
from bridges.experiment.trials import TrialRecord, open_harness
from bridges.world.bridge import trial_for
from wm import Event, Graph, Node

SCENARIO = str(SCENARIOS / "box_obstacle_exact.yaml")
SEED, SAVEABLE, UNSAVEABLE = 7, 25, (42,)
ALGORITHM_1_PERIOD = 0.1  # simulated seconds between Algorithm 1's passes at most (the intention agent's --period)


@pytest.fixture(scope="module")
def stack(tmp_path_factory: pytest.TempPathFactory) -> Iterator[Stack]:
    yield from recording_stack(tmp_path_factory, SCENARIO, 0.5)


def test_a_saveable_trial_is_flagged_from_the_first_frames_showing_her_and_saved(stack: Stack) -> None:
    """Algorithm 1 guesses from the first frame perception writes the person: the danger is flagged at its first
    pass after that frame, no later than its period (and the frame's own step) after it."""
    trial = trial_for(load_scenario(SCENARIO), SEED, SAVEABLE)
    planner = GridPlanner(trial.scene().bounds)
    assert run_idle(trial, planner=planner).collided
    r = run_trial(stack, SCENARIO, SEED, SAVEABLE)
    assert r.risky is not None and r.action is not None and r.person_seen_at is not None
    assert r.risky["at_time"] - r.person_seen_at <= ALGORITHM_1_PERIOD + DT + 1e-6
    assert oracle(trial, r.risky["at_time"], planner).saveable
    assert [c for c in r.outcome["commands"] if c["accepted"]]
    assert r.outcome["collisions"] == []


def test_the_searches_are_recorded_as_served_and_serve_again_to_the_answers_sent(stack: Stack) -> None:
    """Run after a saveable trial: every batch of robot moves served so far is recorded; the first ones,
    served again offline, give the answers sent."""
    batches = read_batches(stack.logdir / "searches")
    assert len(batches) == (stack.logdir / "simulation.log").read_text().count("served robot moves") > 0
    for batch in batches[:3]:
        assert batch.serve_again() == batch.reply.results


@pytest.mark.parametrize("index", UNSAVEABLE)
def test_where_no_move_saves_nothing_worse_than_idle_happens(stack: Stack, index: int) -> None:
    trial = trial_for(load_scenario(SCENARIO), SEED, index)
    planner = GridPlanner(trial.scene().bounds)
    idle = run_idle(trial, planner=planner)
    r = run_trial(stack, SCENARIO, SEED, index)
    assert r.risky is not None and not oracle(trial, r.risky["at_time"], planner).saveable
    assert {c["obstacle"] for c in r.outcome["collisions"]} <= {c.obstacle for c in idle.collisions}
    assert all(c["obstacle"] != "robot" for c in r.outcome["collisions"])


def test_moves_after_which_a_person_walks_into_the_robot_are_refused(stack: Stack) -> None:
    log = (stack.logdir / "action.log").read_text()
    refusals = [line for line in log.splitlines() if "walks into robot" in line]
    assert refusals, "the search met and refused moves after which the person walks into the robot"


def test_a_move_under_way_that_walks_the_person_into_the_robot_is_braked(stack: Stack) -> None:
    """As soon as the ball is in W, before the danger shows, a move into the person's way is written to W, as if
    decided on a belief since proved wrong. Carried on, it has the person walk into the robot; no move saves them
    from the ball, so the action agent brakes the robot and the person's fall stays the one that happens with the
    robot idle. (Written once the danger shows, the move would race the head start the action agent sends for it
    within milliseconds, from a replica that has not yet seen the move.)"""
    scenario = str(SCENARIOS / "robot_sent_into_the_way.yaml")
    trial = trial_for(load_scenario(scenario), 0, None)
    idle = run_idle(trial, planner=GridPlanner(trial.scene().bounds))
    r = asyncio.run(run_with_a_move_into_the_way(stack, scenario, (-1.2, 0.0, math.pi / 2)))
    moves = [c["move"] for c in r.outcome["commands"] if c["accepted"]]
    sent = next((k for k, m in enumerate(moves) if m is not None and (m["x"], m["y"]) == (-1.2, 0.0)), None)
    assert sent is not None, f"the move into the way was never sent: {moves}"
    assert None in moves[sent + 1 :], f"the robot was never braked: {moves}"
    assert [c["obstacle"] for c in r.outcome["collisions"]] == [c.obstacle for c in idle.collisions] == ["ball"]
    assert "braking" in (stack.logdir / "action.log").read_text()


async def run_with_a_move_into_the_way(stack: Stack, scenario: str, pose: tuple[float, float, float]) -> TrialRecord:
    async with open_harness(stack.endpoint, GRAPH, name="test-harness") as harness:
        g = harness.g
        before = episode(g)
        run = asyncio.create_task(harness.run(0, None, timeout=60.0, scenario=scenario))
        while not (running_after(g, before) and g.nodes(ROBOT) and balls(g)):
            await asyncio.sleep(0.01)
        robot, ball = g.nodes(ROBOT)[0], balls(g)[0]
        with g.batch():
            move = g.insert_node(
                INTENTION,
                "move_into_the_way",
                {
                    "action": "move_to",
                    "target": ball.id,
                    "final_pose": list(pose),
                    "status": "proposed",
                    "created_at": time.time(),
                    "reason": "written by the test",
                },
            )
            g.insert_or_assign_edge(robot.id, move, HAS, {"status": "proposed", "updated_at": time.time()})
        return await run


def test_a_move_under_way_is_judged_again_when_someone_new_comes_into_w(stack: Stack) -> None:
    """As soon as the robot's move for the saveable trial is in W, someone new is written into W, as a person
    tracked by another sensor would be: walking across the robot's way ahead of it. The action agent judges the
    move under way again, with them walking on (straight ahead when no target is in their view), without waiting
    for a danger of theirs to be flagged."""
    searched_before = len(read_batches(stack.logdir / "searches"))
    logged_before = len((stack.logdir / "action.log").read_text())
    move = asyncio.run(run_with_someone_new_in_the_way(stack, SCENARIO))
    judged_with_them = [
        item.spec
        for batch in read_batches(stack.logdir / "searches")[searched_before:]
        for item in map(item_from_wire, batch.items)
        if isinstance(item, SearchItem)
        and item.moves is not None
        and [(m.x, m.y) for m in item.moves if m is not None] == [move]
        and any(w.person == "someone_new" for w in item.spec.bystanders)
    ]
    assert judged_with_them, "the move under way was never judged with the newcomer"
    looks = (stack.logdir / "action.log").read_text()[logged_before:]
    assert "move under way judged again: someone or a target new in W" in looks


async def run_with_someone_new_in_the_way(stack: Stack, scenario: str) -> tuple[float, float]:
    """Run the saveable trial, writing a walker across the robot's first move as soon as it is in W; return where
    that move ends."""
    async with open_harness(stack.endpoint, GRAPH, name="test-harness") as harness:
        g = harness.g
        before = episode(g)
        run = asyncio.create_task(harness.run(SEED, SAVEABLE, timeout=60.0, scenario=scenario))
        while not (running_after(g, before) and [n for n in g.nodes(INTENTION) if n.get("action") == "move_to"]):
            await asyncio.sleep(0.005)
        intention = max(
            (n for n in g.nodes(INTENTION) if n.get("action") == "move_to"), key=lambda n: n.get("created_at", 0.0)
        )
        (person,) = g.nodes(PERSON)
        rx, ry, _ = g.rt.pose2d(WORLD, g.nodes(ROBOT)[0].id)
        fx, fy, _ = intention.get("final_pose")
        cx, cy = rx + 2 * (fx - rx) / 3, ry + 2 * (fy - ry) / 3  # two thirds of the way, crossed square to it
        way = math.atan2(fy - ry, fx - rx)
        starts = [(cx - 1.2 * math.cos(h), cy - 1.2 * math.sin(h), h) for h in (way + math.pi / 2, way - math.pi / 2)]
        sx, sy, across = max(starts, key=lambda start: targets_off_heading(g, *start))
        with g.batch():
            walker = g.insert_node(
                PERSON,
                "someone_new",
                {
                    **person.attrs,
                    "velocity": [0.6 * math.cos(across), 0.6 * math.sin(across)],
                    "velocity_sigma": 0.05,
                    "speed": 0.6,
                    "origin": [sx, sy],
                },
            )
            g.rt.set_pose2d(WORLD, walker, sx, sy, across)
        await run
        return fx, fy


def targets_off_heading(g: Graph, x: float, y: float, heading: float) -> float:
    """How far (rad) from ``heading`` the target object nearest to it in bearing lies, seen from ``(x, y)``."""
    return min(
        (
            abs(math.remainder(math.atan2(oy - y, ox - x) - heading, 2 * math.pi))
            for n in g.nodes(OBJECT)
            if n.get("is_target")
            for ox, oy, _ in [g.rt.pose2d(WORLD, n.id)]
        ),
        default=math.pi,
    )


def test_a_person_who_has_fallen_is_seen_lying_and_guessed_walking_no_more(stack: Stack) -> None:
    """Ana falls into the ball at once; Ben walks on for seconds. Perception marks her fallen in W within a few
    frames of her fall; Algorithm 1 guesses no walk of hers after that and deletes those it had, while Ben's
    are guessed on."""
    scenario = str(SCENARIOS / "one_falls_one_walks_on.yaml")
    r, people, guessed, left = asyncio.run(run_watching_guesses(stack, scenario))
    (fall,) = r.outcome["collisions"]
    lying = [name for name, p in people.items() if p.get("fallen")]
    assert len(people) == 2 and len(lying) == 1, people
    (ana,), (ben,) = lying, set(people) - set(lying)
    fallen_at = float(people[ana]["fallen_at"])  # type: ignore[arg-type]
    assert fall["time"] <= fallen_at <= fall["time"] + 0.5
    assert math.dist(people[ana]["position"], fall["point"]) < 0.3  # type: ignore[arg-type]
    assert any(at < fall["time"] for name, at in guessed if name == ana), "her walks were guessed before"
    # An evaluation under way when she was marked may still land; none begun after it does.
    late = [at for name, at in guessed if name == ana and at > fallen_at + 0.2]
    assert late == [], f"walks of hers guessed after she fell: {late}"
    assert ana not in left, "her guesses were deleted"
    assert any(at > fallen_at + 1.0 for name, at in guessed if name == ben), "Ben's walks are guessed on"
    seen = falls_seen(r.outcome["collisions"], r.fall_marks.values(), r.outcome["duration"])  # as scored
    assert seen.unmatched == 0 and seen.seen == [pytest.approx(fallen_at - fall["time"])]


def test_someone_fallen_gets_an_alert_and_the_robot_goes_to_them_clear_of_whoever_walks_on(stack: Stack) -> None:
    """Ana falls into the ball out of the robot's reach; Ben walks on. Once perception marks her fallen, the
    assist agent raises an alert about her and sends the robot to a pose beside her, judged clear of Ben: the
    robot drives towards her and Ben walks on untouched. A move made to help is no action against a danger,
    and the experiment does not time it as one."""
    scenario = str(SCENARIOS / "one_falls_one_walks_on.yaml")
    r, people, intentions = asyncio.run(run_keeping_intentions(stack, scenario))
    (fall,) = r.outcome["collisions"]
    ana = next(p for p in people.values() if p.get("fallen"))
    (alert,) = [i for i in intentions if i["action"] == ALERT]
    assert alert["status"] == "raised" and alert["target"] == alert["person"] == ana["id"]
    assert f"{ana['name']} has fallen" in alert["reason"]
    (going,) = [i for i in intentions if i["action"] == GO_TO]
    assert going["person"] == ana["id"] and going["at_time"] >= ana["fallen_at"]
    assert math.dist(going["final_pose"][:2], ana["position"]) < 1.0
    sent = [c for c in r.outcome["commands"] if c["action"] == GO_TO]
    assert sent and sent[0]["accepted"] and sent[0]["time"] < ana["fallen_at"] + 0.5
    robot = r.outcome["tracks"]["robot"]
    start, end = robot[0][1:3], robot[-1][1:3]
    assert math.dist(end, ana["position"]) < math.dist(start, ana["position"]) - 1.0, "the robot drove towards her"
    assert fall["person"] == "ana" and r.action is None
    assert r.answers[ALERT] == {ana["id"]: alert["at_time"]} and r.answers[GO_TO] == {ana["id"]: going["at_time"]}


async def run_keeping_intentions(
    stack: Stack, scenario: str
) -> tuple[TrialRecord, dict[str, dict[str, Any]], list[dict[str, Any]]]:
    """Run ``scenario``'s nominal trial; return its record, each person node's attributes (with its id and
    position) and each robot intention's attributes, as W holds them at its end."""
    async with open_harness(stack.endpoint, GRAPH, name="test-harness") as harness:
        g = harness.g
        r = await harness.run(0, None, timeout=60.0, scenario=scenario)
        people = {
            n.name: {**n.attrs, "id": n.id, "name": n.name, "position": g.rt.pose2d(WORLD, n.id)[:2]}
            for n in g.nodes(PERSON)
        }
        return r, people, [dict(n.attrs) for n in g.nodes(INTENTION)]


async def run_watching_guesses(
    stack: Stack, scenario: str
) -> tuple[TrialRecord, dict[str, dict[str, object]], list[tuple[str, float]], set[str]]:
    """Run ``scenario``'s nominal trial; return its record, each person node's attributes and position at its end,
    each ``has_intention`` written during it (person, simulated time), and the people who still have some."""
    async with open_harness(stack.endpoint, GRAPH, name="test-harness") as harness:
        g = harness.g
        guessed: list[tuple[str, float]] = []

        def on_guess(event: Event) -> None:
            edge = g.find_edge(event.src, event.dst, HAS_INTENTION)  # type: ignore[arg-type]
            if edge is not None and running_after(g, before):
                guessed.append((g.get_node(edge.src).name, float(edge.get("at_time", 0.0))))

        before = episode(g)
        g.on(on_guess, kind=["edge_added", "edge_updated"], type=HAS_INTENTION)
        r = await harness.run(0, None, timeout=60.0, scenario=scenario)
        people = {n.name: {**n.attrs, "position": g.rt.pose2d(WORLD, n.id)[:2]} for n in g.nodes(PERSON)}
        left = {g.get_node(e.src).name for e in g.edges(type=HAS_INTENTION)}
        return r, people, guessed, left


def balls(g: Graph) -> list[Node]:
    return [n for n in g.nodes(OBJECT) if n.get("kind") == "ball"]


def episode(g: Graph) -> int:
    world = g.find_node(WORLD)
    return int(world.get("episode", 0)) if world is not None else 0


def running_after(g: Graph, before: int) -> bool:
    """Whether a trial after episode ``before`` has started its clock (W was cleared for it by then)."""
    world = g.find_node(WORLD)
    return episode(g) > before and world is not None and world.get("sim_time", 0.0) > 0.0
