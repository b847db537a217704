"""The robot going to someone who has fallen: the poses beside them, and the search that keeps walkers safe."""

import math
from dataclasses import replace
from functools import partial

import pytest
from recorded_cases import STACK_SCENARIOS

from agents.caregiving.model.errors import RequestError
from agents.caregiving.model.geometry import point_distance
from agents.caregiving.model.go_to import GAP, KEEP_CLEAR, going_to
from agents.caregiving.model.move_search import SearchItem
from agents.caregiving.model.response import Ask, Asked, drive
from agents.caregiving.model.robot_moves import moves_beside, robot_fits
from agents.caregiving.model.scenario import load_scenario
from agents.caregiving.model.scene import Scene
from agents.caregiving.model.search_spec import SearchSpec
from agents.caregiving.model.service import item_from_wire, serve_one
from agents.caregiving.model.uncertainty import Uncertainty
from agents.caregiving.model.verdict import SearchResult
from agents.caregiving.model.world_model import Walk

EXACT = Uncertainty(0.0, {}, 1)
BEN = Walk("ben", "couch", math.radians(8))


def room(
    ana: tuple[float, float], robot: tuple[float, float, float], ben: tuple[float, float, float] | None = None
) -> Scene:
    """Ana lying at ``ana``, Ben walking to the couch along y = -1.5 (from its start, or from ``ben``: x, y,
    heading), the robot at ``robot`` (x, y, heading)."""
    scene = load_scenario(str(STACK_SCENARIOS / "one_falls_one_walks_on.yaml")).scene()
    moved = {"ana": (*ana, 0.0), **({"ben": ben} if ben is not None else {})}
    people = tuple(p.moved(*moved[p.name]) if p.name in moved else p for p in scene.people)
    assert scene.robot is not None
    return replace(scene, people=people, robot=replace(scene.robot, x=robot[0], y=robot[1], heading=robot[2]))


def search(scene: Scene, spec: SearchSpec) -> SearchResult:
    """The going-to search, run by the simulator's own search in process."""
    imagine = partial(serve_one, scene)

    def run(ask: Ask) -> Asked:
        return Asked(ask.item(0.1, EXACT, 0.2, 32, 0.01).run(scene, imagine))

    found = drive(going_to(spec, moves_beside(scene, "ana", GAP)), run)
    assert found is not None
    return found


def test_the_poses_beside_someone_face_them_at_the_gap_and_the_nearest_comes_first() -> None:
    scene = room((1.0, 0.3), (3.8, 2.2, math.pi))
    moves = moves_beside(scene, "ana", GAP)
    body = scene.person("ana").body().shape
    assert len(moves) >= 8
    robot = scene.robot
    assert robot is not None
    half = max(robot.length, robot.width) / 2
    for m in moves:
        assert point_distance(body, m.x, m.y) == pytest.approx(GAP + half, abs=1e-3)
        facing = math.atan2(body.y - m.y, body.x - m.x)
        assert math.cos(m.heading - facing) == pytest.approx(1.0)
        assert m.target == "ana" and robot_fits(scene, m)
    drives = [math.hypot(m.x - robot.x, m.y - robot.y) for m in moves]
    assert drives == sorted(drives)


def test_while_someone_comes_the_robot_waits_rather_than_cross_their_way_or_pass_near_them() -> None:
    """Ana lies north of Ben's way; the robot starts south of it. While Ben comes, every pose beside her has the
    robot cross his way as he comes: he walks into it, or it passes him closer than it keeps from anyone."""
    found = search(room((1.0, 0.3), (1.2, -2.6, math.pi / 2)), SearchSpec((), {}, {}, (BEN,)))
    reasons = [v.reason for v in found.verdicts]
    assert found.chosen is None and len(reasons) == len(moves_beside(room((1.0, 0.3), (1.2, -2.6, 0.0)), "ana", GAP))
    assert reasons[0].startswith("ben walks into robot")
    near = [int(r.split(" passes ")[1].split(" cm")[0]) for r in reasons if " passes " in r]
    assert near and all(0 < cm < KEEP_CLEAR * 100 for cm in near)
    assert all(r.startswith("ben walks into robot") or " passes " in r for r in reasons)


def test_once_they_have_gone_by_the_nearest_pose_is_taken() -> None:
    scene = room((1.0, 0.3), (1.2, -2.6, math.pi / 2), ben=(2.0, -1.5, 0.0))
    found = search(scene, SearchSpec((), {}, {}, (BEN,)))
    assert found.chosen is not None and found.chosen.safe(0.2)
    assert found.chosen.move == moves_beside(scene, "ana", GAP)[0] and len(found.verdicts) == 1


def test_a_search_for_no_danger_travels_with_its_walkers_and_needs_one() -> None:
    spec = SearchSpec((), {}, {}, (BEN,))
    item = SearchItem(
        spec, EXACT, 0.2, 4, 0.0, moves=tuple(moves_beside(room((1.0, 0.3), (3.8, 2.2, 0.0)), "ana", GAP))
    )
    assert item_from_wire(item.to_wire()) == item
    assert spec.walk_sets() == [(BEN,)]
    with pytest.raises(RequestError, match="expected a danger, or a bystander"):
        item_from_wire({**item.to_wire(), "spec": {**spec.to_wire(), "bystanders": []}})
