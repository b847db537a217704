"""The robot going to someone who has fallen: the poses beside them, and the search that keeps walkers safe."""

import math
from dataclasses import replace
from functools import partial
from pathlib import Path

import pytest

from agents.caregiving.model.errors import RequestError
from agents.caregiving.model.geometry import point_distance
from agents.caregiving.model.go_to import GAP, going_to
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

STACK_SCENARIOS = Path(__file__).parents[1] / "caregiving_stack" / "scenarios"
EXACT = Uncertainty(0.0, {}, 1)
BEN = Walk("ben", "couch", math.radians(8))


def room(ana: tuple[float, float], robot: tuple[float, float, float]) -> Scene:
    """Ana lying at ``ana``, Ben setting off for the couch along y = -1.5, the robot at ``robot`` (x, y, heading)."""
    scene = load_scenario(str(STACK_SCENARIOS / "one_falls_one_walks_on.yaml")).scene()
    people = tuple(p.moved(*ana, p.heading) if p.name == "ana" else p for p in scene.people)
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


def test_a_pose_whose_drive_walks_someone_into_the_robot_is_passed_over_for_one_that_harms_nobody() -> None:
    """Ana lies north of Ben's way; the robot starts south of it. Driving to the three poses nearest it, the
    robot crosses Ben's way as he comes, and he walks into it; the search goes on to a pose he passes clear of."""
    scene = room((1.0, 0.3), (1.2, -2.6, math.pi / 2))
    found = search(scene, SearchSpec((), {}, {}, (BEN,)))
    refused = [v for v in found.verdicts if not v.clear]
    assert len(refused) >= 1 and all(v.reason.startswith("ben walks into robot") for v in refused)
    assert found.chosen is not None and found.chosen is found.verdicts[-1] and found.chosen.safe(0.2)
    assert found.chosen.move == moves_beside(scene, "ana", GAP)[len(refused)]


def test_with_nobody_in_its_way_the_nearest_pose_is_taken() -> None:
    scene = room((2.0, -0.6), (2.0, -2.6, math.pi / 2))
    found = search(scene, SearchSpec((), {}, {}, (BEN,)))
    assert found.chosen is not None and found.chosen.move == moves_beside(scene, "ana", GAP)[0]
    assert len(found.verdicts) == 1


def test_a_search_for_no_danger_travels_with_its_walkers_and_needs_one() -> None:
    spec = SearchSpec((), {}, {}, (BEN,))
    item = SearchItem(
        spec, EXACT, 0.2, 4, 0.0, moves=tuple(moves_beside(room((1.0, 0.3), (3.8, 2.2, 0.0)), "ana", GAP))
    )
    assert item_from_wire(item.to_wire()) == item
    assert spec.walk_sets() == [(BEN,)]
    with pytest.raises(RequestError, match="expected a danger, or a bystander"):
        item_from_wire({**item.to_wire(), "spec": {**spec.to_wire(), "bystanders": []}})
