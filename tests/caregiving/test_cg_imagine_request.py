"""Typed imagine items: what an agent builds is what the simulator parses back, and bad fields are named."""

import math
import re

import pytest

from agents.caregiving.model.candidates import Danger
from agents.caregiving.model.errors import RequestError
from agents.caregiving.model.imagine_request import JointItem, PersonItem
from agents.caregiving.model.move_search import SearchItem
from agents.caregiving.model.robot_moves import RobotMove
from agents.caregiving.model.search_spec import SearchSpec
from agents.caregiving.model.service import item_from_wire
from agents.caregiving.model.uncertainty import Uncertainty
from agents.caregiving.model.world_model import Passing, Walk

U = Uncertainty(0.2, {"person": 0.05, "ball": 0.02}, 32, 7)
WALK = Walk("person", "couch", math.radians(8), ("door",))
MOVE = RobotMove("ball", -0.5, 0.1, math.pi)


@pytest.mark.parametrize(
    "item",
    [
        PersonItem(WALK),
        PersonItem(WALK, U),
        PersonItem(Walk("person", "couch", 0.1, ("robot",), (0.5, -1.0, math.pi / 2))),
        JointItem((WALK, Walk("bob", "door", 0.1)), MOVE, RobotMove("couch", 1.0, 2.0, 0.0), 0.3, U),
        JointItem((WALK,), None),
        JointItem((WALK, Walk("bob", "", 0.1, toward=(1.5, -0.5))), MOVE),
        JointItem((WALK, Walk("bob", "door", 0.1)), MOVE, uncertainty=U, anyway={"bob": 0.25}),
        JointItem(
            (WALK, Walk("bob", "door", 0.1)), MOVE, passing={"bob": Passing("ball"), "person": Passing("ball", 0.03)}
        ),
        SearchItem(
            SearchSpec((Danger("person", "couch", ((0, 0), (1, 0)), (0.5, 0.0), "ball", 2.0),), {"person": (0.1,)}, {}),
            U,
            0.2,
            24,
            0.9,
            0.03,
            (MOVE,),
        ),
        SearchItem(
            SearchSpec(
                (Danger("person", "couch", ((0, 0), (1, 0)), (0.5, 0.0), "ball", 2.0),),
                {"person": (0.1,)},
                {"person": ("robot",)},
                robot_at={"person": (0.5, -1.0, 0.3)},
            ),
            U,
            0.2,
            24,
        ),
    ],
)
def test_an_item_survives_the_wire(item: PersonItem | JointItem | SearchItem) -> None:
    assert item_from_wire(item.to_wire()) == item


def _search_wire(**spec: object) -> dict[str, object]:
    """A search item's wire form with some of its spec's fields replaced."""
    danger = Danger("person", "couch", ((0, 0), (1, 0)), (0.5, 0.0), "ball", 2.0)
    wire = SearchItem(SearchSpec((danger,), {"person": (0.1,)}, {}), U, 0.2, 24).to_wire()
    return {**wire, "spec": {**wire["spec"], **spec}}


@pytest.mark.parametrize(
    ("wire", "message"),
    [
        ({"kind": "dance"}, "request.kind"),
        ({**JointItem((WALK,), MOVE).to_wire(), "walks": []}, "request.walks: expected at least one walk"),
        ({**JointItem((WALK,), MOVE).to_wire(), "delay": 60.0}, "request.delay"),
        ({**PersonItem(WALK, U).to_wire(), "uncertainty": {"samples": -1}}, "request.uncertainty.samples"),
        ({**PersonItem(WALK).to_wire(), "gaze": 3.0}, "request.gaze: expected a pitch"),
        ({**PersonItem(WALK).to_wire(), "toward": [1.0, 0.0]}, "request.toward: Algorithm 1 imagines walks to targets"),
        ({**JointItem((WALK,), MOVE).to_wire(), "walks": [{"person": "bob", "gaze": 0.1}]}, "request.walks[0].target"),
        (
            {**JointItem((WALK,), MOVE).to_wire(), "walks": [{"person": "bob", "gaze": 0.1, "toward": [1.0, "x"]}]},
            "request.walks[0].toward[1]: expected a number",
        ),
        ({**PersonItem(WALK).to_wire(), "robot_at": [0.5, -1.0]}, "request.robot_at: expected a list of 3 numbers"),
        ({**PersonItem(WALK).to_wire(), "robot_at": [0.5, "x", 0.0]}, "request.robot_at[1]: expected a number"),
        (_search_wire(robot_at={"bob": [0.0, 0.0, 0.0]}), "request.spec.robot_at.bob: expected one of the endangered"),
        (_search_wire(robot_at={"person": [0.0, math.inf, 0.0]}), "request.spec.robot_at.person[1]: expected a number"),
        ({**JointItem((WALK,), MOVE).to_wire(), "anyway": {"bob": 0.2}}, "request.anyway.bob: expected one of"),
        ({**JointItem((WALK,), MOVE).to_wire(), "anyway": {"person": 1.5}}, "request.anyway.person"),
        (
            {**JointItem((WALK,), MOVE).to_wire(), "passing": {"bob": {"object": "ball"}}},
            "request.passing.bob: expected",
        ),
        (
            {**JointItem((WALK,), MOVE).to_wire(), "passing": {"person": {"object": "ball", "allowance": -0.1}}},
            "request.passing.person.allowance",
        ),
        (
            {**JointItem((WALK,), MOVE).to_wire(), "passing": {"person": {"allowance": 0.1}}},
            "request.passing.person.object",
        ),
    ],
)
def test_a_malformed_item_names_its_bad_field(wire: dict[str, object], message: str) -> None:
    with pytest.raises(RequestError, match=re.escape(message)):
        item_from_wire(wire)
