"""The simulation agent as a process: replies match PyBullet ground truth; malformed requests get errors."""

from __future__ import annotations

import asyncio
import math
from collections.abc import Callable
from pathlib import Path

import pytest

from agents.caregiving import keys
from agents.caregiving.model import imagine_reply
from agents.caregiving.model.candidates import Danger
from agents.caregiving.model.imagine import imagine_person
from agents.caregiving.model.imagine_reply import ImagineReply
from agents.caregiving.model.joint import imagine_joint
from agents.caregiving.model.move_search import SearchItem
from agents.caregiving.model.planner import GridPlanner
from agents.caregiving.model.recorded_batch import RecordedBatch, read_batches
from agents.caregiving.model.robot_moves import standoff_moves
from agents.caregiving.model.rollout import BulletRollout
from agents.caregiving.model.scenario import load_scenario
from agents.caregiving.model.uncertainty import Uncertainty
from agents.caregiving.model.world_model import Walk
from agents.messaging import Messaging, NoReply, RemoteError
from bridges.experiment.perfect_belief import perfect_belief_spec
from bridges.world.bridge import trial_for
from procs import PYTHON, Proc, endpoint, free_port, wait_until
from wm.net.connection import close_session, open_session

GRAPH = "simtest"
GAZES = [math.radians(8), math.radians(-30)]
HURRIED_WALKER = Path(__file__).resolve().parents[2] / "docs" / "results" / "heldout" / "hurried_walker.yaml"


@pytest.fixture(scope="module")
def recorded(tmp_path_factory: pytest.TempPathFactory) -> Path:
    """Where the simulation agent records its batches of robot moves."""
    return tmp_path_factory.mktemp("searches")


@pytest.fixture(scope="module")
def sim_endpoint(recorded: Path):
    port = free_port()
    proc = Proc(
        [
            PYTHON,
            "-m",
            "agents.caregiving.simulation",
            "--graph",
            GRAPH,
            "--listen",
            endpoint(port),
            "--rollout",
            "bullet",
            "--record",
            str(recorded),
        ],
        "simulation",
    )
    try:
        yield endpoint(port), proc
    finally:
        proc.stop()


def ask(ep: str, request: object, progress: Callable[[ImagineReply], None] | None = None) -> ImagineReply:
    async def go() -> ImagineReply:
        session = await open_session(connect=[ep])
        try:
            for _ in range(100):  # until the agent's queryable is declared
                try:
                    return await Messaging(session).ask(
                        keys.imagine(GRAPH), request, decode=imagine_reply.decode, timeout=2.0, progress=progress
                    )
                except NoReply:
                    await asyncio.sleep(0.1)
            raise AssertionError("the simulation agent never answered")
        finally:
            await close_session(session)

    return asyncio.run(go())


def test_replies_match_pybullet_on_fixed_cases(sim_endpoint) -> None:
    ep, _ = sim_endpoint
    scene = load_scenario("paper_experiment1").scene()
    moves = standoff_moves(scene, "ball")[:3]
    items = [{"kind": "person", "person": "person", "target": t, "gaze": g} for t in ("couch", "door") for g in GAZES]
    walk = {"person": "person", "target": "couch", "gaze": GAZES[0]}
    items += [{"kind": "joint", "walks": [walk], "move": m.to_wire()} for m in moves]
    reply = ask(ep, {"items": items, "scene": scene.to_wire()})
    results = reply.results
    assert all(r.error is None for r in results), results
    assert reply.episode is None and reply.written_at is None and reply.stamp == scene.time  # a pinned scene
    bullet = BulletRollout.shared()
    for item, r in zip(items[:4], results[:4], strict=True):
        truth = imagine_person(scene, "person", item["target"], item["gaze"], rollout=bullet)
        got = r.imagination
        assert got is not None and (got.collided, got.collision_object) == (truth.collided, truth.collision_object)
        assert (
            got.collision_time == pytest.approx(truth.collision_time) if truth.collided else got.collision_time is None
        )
    first = results[0].imagination
    assert first is not None and first.collided and first.collision_object == "ball"
    for m, r in zip(moves, results[4:], strict=True):
        truth = imagine_joint(scene, [Walk("person", "couch", GAZES[0])], m)
        assert r.joint == truth


def test_uncertainty_gives_a_collision_probability(sim_endpoint) -> None:
    ep, _ = sim_endpoint
    scene = load_scenario("paper_experiment1").scene()
    item = {
        "kind": "person",
        "person": "person",
        "target": "couch",
        "gaze": GAZES[0],
        "uncertainty": {"size_error": 0.2, "sigma": {"ball": 0.02, "person": 0.03}, "samples": 128},
    }
    risk = ask(ep, {"items": [item], "scene": scene.to_wire()}).results[0].risk
    assert risk is not None and risk.probability == pytest.approx(1.0) and risk.obstacle == "ball"


def test_malformed_requests_get_errors_and_the_service_carries_on(sim_endpoint) -> None:
    ep, proc = sim_endpoint
    paper = load_scenario("paper_experiment1").scene()
    scene = paper.to_wire()
    with pytest.raises(RemoteError, match="request.items"):
        ask(ep, {"items": "nope", "scene": scene})
    with pytest.raises(RemoteError, match="RequestError"):
        ask(ep, [1, 2, 3])
    with pytest.raises(RemoteError, match="no context"):
        ask(ep, {"items": [{"kind": "person"}]})
    walk = {"person": "person", "target": "couch", "gaze": 0.1}
    walked = imagine_person(paper, "person", "couch", GAZES[0])
    assert walked.collision_point and walked.collision_object and walked.collision_time
    danger = Danger(
        "person", "couch", walked.path, walked.collision_point, walked.collision_object, walked.collision_time
    ).to_wire()
    search = {"kind": "search", "uncertainty": {"samples": 16}, "threshold": 0.2, "max_moves": 4}
    reply = ask(
        ep,
        {
            "items": [
                {"kind": "fly", "person": "person"},
                {"kind": "person", "person": "nobody", "target": "couch", "gaze": 0.1},
                {"kind": "joint", "walks": "everyone", "move": None},
                {"kind": "joint", "walks": [walk], "move": {"target": "ball", "x": 1.0}},
                {"kind": "joint", "walks": [walk], "move": None, "delay": 1e9},
                {"kind": "person", "person": "person", "target": "couch", "gaze": 0.1},
                {"kind": "joint", "walks": [walk], "move": None},
                {**search, "spec": {"dangers": [danger], "gazes": {}}},
                {**search, "spec": {"dangers": [danger], "gazes": {"person": [GAZES[0]]}}},
            ],
            "scene": scene,
        },
    )
    bad_kind, unknown, bad_walks, bad_move, bad_delay, good, braking, bad_search, searched = reply.results
    assert "kind" in (bad_kind.error or "")
    assert "unknown person 'nobody'" in (unknown.error or "")
    assert "request.walks: expected a list" in (bad_walks.error or "")
    assert "request.move.y: is required" in (bad_move.error or "")
    assert "request.delay: expected at most" in (bad_delay.error or "")
    assert good.imagination is not None and good.imagination.reachable
    assert braking.joint is not None and braking.joint.walks[0].status == "collided"
    assert "request.spec.gazes.person: is required" in (bad_search.error or "")
    assert searched.search is not None and searched.search.chosen is not None and searched.search.chosen.clear
    assert proc.popen.poll() is None


def test_a_head_start_comes_back_before_the_search_ends(sim_endpoint, recorded: Path) -> None:
    """Trial 0 of the held-out hurried walker: the first candidate fails harmlessly and is sent on the way.

    The search is recorded as served, and served again offline it gives the answer sent.
    """
    ep, _ = sim_endpoint
    s = load_scenario(HURRIED_WALKER)
    trial = trial_for(s, 6, 0)
    found = perfect_belief_spec(trial, 0.55, GridPlanner(s.scene().bounds), 0.05)
    assert found is not None
    scene, spec = found
    item = SearchItem(spec, Uncertainty(0.0, {}, 1), 0.2, 24, judging=0.02, head_start=True)
    request = {"items": [item.to_wire()], "scene": scene.to_wire()}
    early: list[ImagineReply] = []
    final = ask(ep, request, early.append)
    assert len(early) == 1
    lead = early[0].results[0].search
    searched = final.results[0].search
    assert lead is not None and searched is not None
    assert lead.verdicts == () and lead.chosen is None and lead.lead is not None
    assert searched.lead == lead.lead and searched.verdicts[0].move == lead.lead.move
    assert searched.chosen is not None and searched.chosen.safe(0.2)
    # An asker that takes no progress gets the same final reply, and nothing else.
    assert ask(ep, request).results[0].search == searched

    def mine() -> list[RecordedBatch]:
        return [b for b in read_batches(recorded) if b.items == request["items"]]

    wait_until(lambda: len(mine()) == 2, 10.0, "both searches recorded")  # written just after each reply is sent
    batches = mine()
    assert all(b.reply.results == final.results for b in batches)
    assert batches[0].scene == scene
    assert batches[0].serve_again()[0].search == searched
