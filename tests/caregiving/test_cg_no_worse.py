"""Never make it worse, world by world: a move whose sampled falls lie in worlds the robot as it is keeps clear is refused."""

import json
from dataclasses import replace
from pathlib import Path

import pytest

from agents.caregiving.model import move_choice
from agents.caregiving.model.move_search import SearchItem
from agents.caregiving.model.robot_moves import RobotMove
from agents.caregiving.model.scene import Scene
from agents.caregiving.model.service import item_from_wire, serve_one

#: A search recorded live: the paper's room, seed 12011, trial 21, 0.65 s into the trial, on perception's belief.
#: The person passes the ball by 2.2 cm in the truth; on the belief, she touches it in 28 of 64 sampled worlds.
RECORDED = Path(__file__).parent / "data" / "paper_experiment1_s12011_trial21_search.json"
#: The stand-off the search chose live, before moves were compared world by world: the person, walking round the
#: robot there, walked into the ball in every run.
STAND_OFF = RobotMove("ball_3", 1.62125564673523, 0.27983505291000815, -3.141592653589793)


def recorded_search() -> tuple[Scene, SearchItem]:
    data = json.loads(RECORDED.read_text())
    item = item_from_wire(data["item"])
    assert isinstance(item, SearchItem)
    return Scene.from_wire(data["scene"]), item


def _worlds(scene: Scene, item: SearchItem, move: RobotMove | None) -> int:
    """The sampled worlds in which the person falls with ``move`` (None: the robot as it is), in the first walk set."""
    answer = serve_one(scene, item.spec.items(move or item.spec.current, item.uncertainty)[0])
    assert answer.risks is not None
    return answer.risks["person_4"].worlds


def test_a_stand_off_that_lowers_the_sampled_risk_but_makes_other_worlds_fall_is_refused() -> None:
    scene, item = recorded_search()
    idle, stand_off = _worlds(scene, item, None), _worlds(scene, item, STAND_OFF)
    assert stand_off.bit_count() < idle.bit_count()  # the stand-off lowers the sampled risk...
    assert (stand_off & ~idle).bit_count() > 1  # ...in worlds of its own, where the idle robot keeps her clear
    found = serve_one(scene, item).search
    assert found is not None and found.chosen is not None
    refused = next(v for v in found.verdicts if v.move == STAND_OFF)
    assert not refused.clear and refused.falls[0].obstacle == "ball_3" and refused.falls[0].made_worse
    assert refused.reason.startswith("person_4 may walk into ball_3 in ")
    assert refused.reason.endswith(" of 64 sampled worlds where the robot as it is keeps them clear")
    assert found.chosen.move != STAND_OFF
    chosen = _worlds(scene, item, found.chosen.move)
    assert (chosen & ~idle).bit_count() <= move_choice.MADE_WORSE * item.uncertainty.samples


def test_without_the_comparison_the_search_sends_that_stand_off(monkeypatch: pytest.MonkeyPatch) -> None:
    monkeypatch.setattr(move_choice, "MADE_WORSE", 1.0)
    scene, item = recorded_search()
    found = serve_one(scene, item).search
    assert found is not None and found.chosen is not None and found.chosen.move == STAND_OFF


def test_the_move_under_way_judged_again_makes_no_world_worse_than_itself() -> None:
    """With the stand-off under way, carrying on with it is the robot as it is: its sampled risk stays its own."""
    scene, item = recorded_search()
    under_way = replace(item.spec, current=STAND_OFF)
    found = serve_one(scene, replace(item, spec=under_way, moves=(STAND_OFF,))).search
    assert found is not None and found.verdicts[0].clear and found.verdicts[0].risk > 0.0
