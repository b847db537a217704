"""The helper process that judges candidates alongside a search: same verdicts as a lone search, any failure absorbed."""

import math
import os
import signal
import subprocess
import sys
import time
from collections.abc import Hashable, Iterator
from functools import partial

import pytest

from agents.caregiving.model.candidates import Danger
from agents.caregiving.model.imagine import imagine_person
from agents.caregiving.model.imagine_reply import Answer
from agents.caregiving.model.imagine_request import JointItem
from agents.caregiving.model.judge_ahead import JudgeAhead
from agents.caregiving.model.move_search import search
from agents.caregiving.model.robot_moves import RobotMove
from agents.caregiving.model.scenario import load_scenario
from agents.caregiving.model.scene import Scene
from agents.caregiving.model.search_spec import SearchSpec
from agents.caregiving.model.service import serve_one
from agents.caregiving.model.uncertainty import Uncertainty
from agents.caregiving.model.verdict import SearchResult, Verdict
from agents.caregiving.model.visibility import gaze_classes
from agents.caregiving.model.world_model import World
from bridges.world.bridge import trial_for

GAZE = math.radians(8)
UNCERTAINTY = Uncertainty(0.2, {"person": 0.03, "person_55": 0.03}, 64)


@pytest.fixture(scope="module")
def ahead() -> Iterator[JudgeAhead]:
    helper = JudgeAhead()
    yield helper
    helper.close()


@pytest.fixture(scope="module")
def hard_case() -> tuple[Scene, SearchSpec]:
    """A trial of the paper's room 1.5 s before its collision, where no candidate saves the person."""
    trial = trial_for(load_scenario("paper_experiment1"), 2024, 55)
    truth = World.from_scenario(trial)
    hit = truth.run(60.0).collisions[0]
    world = World.from_scenario(trial, planner=truth.planner)
    world.advance(hit.time - 1.5)
    scene, walker = world.scene(), truth.walker(hit.person)
    track = world.walker(hit.person).track
    danger = Danger(hit.person, walker.target, tuple(walker.track[len(track) - 1 :]), hit.point, hit.obstacle, 1.5)
    gazes = tuple(c.gaze for c in gaze_classes(scene.person(hit.person), scene.bodies_around(hit.person)))
    return scene, SearchSpec((danger,), {hit.person: gazes}, {hit.person: ()}, (), None, 0.05)


def lone(
    scene: Scene,
    spec: SearchSpec,
    moves: list[RobotMove] | None = None,
    ahead: JudgeAhead | None = None,
    judging: float = 0.03,
    head_start: bool = False,
) -> SearchResult:
    imagine = partial(serve_one, scene)
    sent = (lambda _lead: None) if head_start else None
    return search(
        scene, spec, imagine, UNCERTAINTY, 0.2, 24, judging=judging, moves=moves, ahead=ahead, head_start=sent
    )


def test_a_search_with_the_helper_finds_what_a_lone_search_finds(
    ahead: JudgeAhead, hard_case: tuple[Scene, SearchSpec]
) -> None:
    scene, spec = hard_case
    alone = lone(scene, spec)
    assert len(alone.verdicts) >= 4
    assert lone(scene, spec, ahead=ahead) == alone


def test_the_search_stops_at_the_first_safe_move_and_leftovers_stay_out_of_the_next(
    ahead: JudgeAhead, hard_case: tuple[Scene, SearchSpec]
) -> None:
    scene = load_scenario("paper_experiment1").scene()
    danger = Danger.of(imagine_person(scene, "person", "couch", GAZE))
    assert danger is not None
    spec = SearchSpec((danger,), {"person": (GAZE,)}, {})
    inside_the_couch = [RobotMove("couch", 3.5, y, 0.0) for y in (0.0, 0.2, 0.4, 0.6, 0.8)]  # unreachable
    moves = [*inside_the_couch, RobotMove("ball", 0.46, 0.0, -math.pi), *inside_the_couch]
    alone = lone(scene, spec, moves, judging=0.0)
    assert len(alone.verdicts) == 6 and alone.chosen is alone.verdicts[-1]

    assert lone(scene, spec, moves, ahead, judging=0.0) == alone
    assert lone(*hard_case, ahead=ahead) == lone(*hard_case)  # the verdicts left over from the last search are dropped


class _Noting(JudgeAhead):
    """A helper that notes each move lent to it in a log the search's own imagination writes to as well."""

    def __init__(self, log: list[str]) -> None:
        super().__init__()
        self.log = log

    def lend(
        self, tag: Hashable, scene: Scene, spec: SearchSpec, move: RobotMove | None, uncertainty: Uncertainty
    ) -> bool:
        self.log.append("lent")
        return super().lend(tag, scene, spec, move, uncertainty)


def test_after_a_head_start_the_helper_is_lent_candidates_before_one_is_judged_here(
    hard_case: tuple[Scene, SearchSpec],
) -> None:
    scene, spec = hard_case
    log: list[str] = []

    def imagine(item: JointItem) -> Answer:
        if item.move is not None and item.uncertainty is not None:  # a candidate's judgement, not the head start's
            log.append("judged")
        return serve_one(scene, item)

    helper, sent = _Noting(log), list[Verdict]()
    try:
        led = search(scene, spec, imagine, UNCERTAINTY, 0.2, 24, judging=0.03, ahead=helper, head_start=sent.append)
    finally:
        helper.close()
    assert sent and led.lead is not None and len(led.verdicts) >= 2
    assert log.index("lent") < log.index("judged")  # the robot drives meanwhile: lending need not wait
    assert led == lone(scene, spec, head_start=True)


def test_a_search_outlives_its_helper(hard_case: tuple[Scene, SearchSpec]) -> None:
    scene, spec = hard_case
    alone = lone(scene, spec)
    helper = JudgeAhead()
    assert helper.pid is not None
    os.kill(helper.pid, signal.SIGKILL)
    try:
        assert lone(scene, spec, ahead=helper) == alone  # every lent move judged here instead
        assert lone(scene, spec, ahead=helper) == alone
        assert lone(scene, spec, ahead=helper, head_start=True) == lone(scene, spec, head_start=True)
    finally:
        helper.close()


def test_the_helper_does_not_outlive_a_killed_simulator() -> None:
    code = "from agents.caregiving.model.judge_ahead import JudgeAhead\nimport time\nif __name__ == '__main__':\n    print(JudgeAhead().pid, flush=True)\n    time.sleep(60)\n"
    parent = subprocess.Popen([sys.executable, "-c", code], stdout=subprocess.PIPE, text=True)
    try:
        assert parent.stdout is not None
        helper = int(parent.stdout.readline())
    finally:
        parent.kill()
        parent.wait()
    for _ in range(100):  # the helper sees its pipe close and leaves
        if not _alive(helper):
            return
        time.sleep(0.1)
    os.kill(helper, signal.SIGKILL)
    raise AssertionError("the helper process outlived its parent")


def _alive(pid: int) -> bool:
    try:
        os.kill(pid, 0)
    except ProcessLookupError:
        return False
    with open(f"/proc/{pid}/stat") as stat:  # a zombie (reaped by init later) counts as gone
        return stat.read().split()[2] != "Z"
