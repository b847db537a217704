"""The head start: a robot at rest sets off on the first candidate while the search judges on.

The recorded cases are truly risky trials of held-out rooms with perfect belief, at the moment a live
run first saw the danger, the robot starting one world step later and 20 ms later per candidate judged,
as ``bench/bench_move_search.py`` sets them up.
"""

import math
from dataclasses import replace
from functools import partial
from pathlib import Path

import pytest
from recorded_cases import DELAY, EXACT, HELD_OUT, JUDGING, THRESHOLD, recorded_case

from agents.caregiving.model import imagine_reply
from agents.caregiving.model.candidates import candidates, swerves
from agents.caregiving.model.errors import ReplyError
from agents.caregiving.model.fields import Fields
from agents.caregiving.model.imagine_reply import Answer, ImagineReply
from agents.caregiving.model.imagine_request import JointItem
from agents.caregiving.model.joint import imagine_joint
from agents.caregiving.model.judging import driven_on, judge_lead, judge_move
from agents.caregiving.model.move_choice import NoWorse
from agents.caregiving.model.move_search import SearchItem, search
from agents.caregiving.model.robot_moves import RobotMove
from agents.caregiving.model.scenario import load_scenario
from agents.caregiving.model.search_spec import SearchSpec
from agents.caregiving.model.service import item_from_wire, serve_one
from agents.caregiving.model.uncertainty import Uncertainty
from agents.caregiving.model.verdict import SearchResult, Verdict
from agents.caregiving.model.world_model import Walk, run_idle
from bridges.experiment.oracle import world_at
from bridges.experiment.perfect_belief import saved_in_truth

HURRIED_WALKER = HELD_OUT / "hurried_walker.yaml"
FACE_TO_FACE = HELD_OUT / "face_to_face.yaml"
THREE_RESIDENTS = HELD_OUT / "three_residents.yaml"


def test_a_head_start_saves_the_hurried_walker_a_search_from_rest_loses() -> None:
    """Trial 0 of the hurried walker: the fourth candidate saves them only if the robot has set off already."""
    trial, planner, scene, spec = recorded_case(HURRIED_WALKER, 6, 0, 0.55)
    imagine = partial(serve_one, scene)

    from_rest = search(scene, spec, imagine, EXACT, THRESHOLD, 24, judging=JUDGING)
    assert from_rest.lead is None
    assert not saved_in_truth(trial, 0.55, planner, DELAY, JUDGING, from_rest)

    sent: list[Verdict] = []
    led = search(scene, spec, imagine, EXACT, THRESHOLD, 24, judging=JUDGING, head_start=sent.append)
    first = led.verdicts[0]
    assert not first.safe(THRESHOLD) and first.move is not None
    assert sent == [led.lead] and led.lead is not None and led.lead.move == first.move
    assert not led.lead.trips(scene.robot_name)
    assert led.chosen is not None and led.chosen.safe(THRESHOLD) and led.chosen is not first
    assert saved_in_truth(trial, 0.55, planner, DELAY, JUDGING, led)


def test_the_head_start_is_judged_first_and_every_candidate_as_a_switch_from_it() -> None:
    _, _, scene, spec = recorded_case(HURRIED_WALKER, 6, 0, 0.55)
    items: list[JointItem] = []

    def imagine(item: JointItem) -> Answer:
        items.append(item)
        return serve_one(scene, item)

    result = search(scene, spec, imagine, EXACT, THRESHOLD, 24, judging=JUDGING, head_start=lambda _: None)
    assert result.lead is not None and result.lead.move == result.verdicts[0].move
    lead_items = len(spec.walk_sets())  # the head start's own judgement, at every walk set, samples no risk
    assert all(i.uncertainty is None and i.lead is None for i in items[:lead_items])
    assert all(i.delay == pytest.approx(DELAY + JUDGING) for i in items[:lead_items])
    judged = items[lead_items:]  # the first candidate's verdict is read off the head start's: no item of its own
    assert all(i.uncertainty is not None for i in judged)
    for k, item in enumerate(judged, start=1):
        assert item.lead == result.lead.move and item.delay == pytest.approx(DELAY + JUDGING)
        assert item.lead_for == pytest.approx(JUDGING * k)
    assert [i.move for i in judged] == [v.move for v in result.verdicts[1:]]
    assert result.judged == len(result.verdicts)


def test_the_swerves_of_a_head_start_come_right_after_it() -> None:
    """Trial 178 of the paper's room at seed 2024: the person, walking round the head start, grazes the ball.

    The head start's verdict is in before the second candidate is asked for, so its swerves come second, and
    the first of them, chosen, goes out one judgement sooner than after the stand-off in front.
    """
    trial, planner, scene, spec = recorded_case("paper_experiment1", 2024, 178, 0.55)
    result = search(
        scene, spec, partial(serve_one, scene), EXACT, THRESHOLD, 24, judging=JUDGING, head_start=lambda _: None
    )
    assert result.lead is not None and not result.verdicts[0].safe(THRESHOLD)
    shifted = swerves(scene, spec.dangers[0], result.lead.move, result.verdicts[0])
    assert shifted and result.verdicts[1].move == shifted[0]
    assert result.chosen is not None and result.chosen.move == shifted[0] and result.judged == 2
    assert saved_in_truth(trial, 0.55, planner, DELAY, JUDGING, result)


def test_a_first_candidate_that_walks_someone_into_the_robot_is_no_head_start() -> None:
    """Trial 2 of face-to-face: the first stand-off puts the robot in the person's way."""
    _, _, scene, spec = recorded_case(FACE_TO_FACE, 3, 2, 0.6)
    sent: list[Verdict] = []
    result = search(
        scene, spec, partial(serve_one, scene), EXACT, THRESHOLD, 24, judging=JUDGING, head_start=sent.append
    )
    assert result.verdicts[0].trips(scene.robot_name)
    assert sent == [] and result.lead is None


def test_no_head_start_while_the_robot_drives_a_move() -> None:
    _, _, scene, spec = recorded_case(HURRIED_WALKER, 6, 0, 0.55)
    driving = SearchSpec(spec.dangers, spec.gazes, spec.known, spec.bystanders, RobotMove("slipper", 1.0, -0.5, 0.0))
    sent: list[Verdict] = []
    result = search(
        scene, driving, partial(serve_one, scene), EXACT, THRESHOLD, 3, judging=JUDGING, head_start=sent.append
    )
    assert sent == [] and result.lead is None


def test_no_head_start_when_nothing_is_left_to_judge() -> None:
    """A search whose first candidate is its last is over at once: a head start would only be braked again."""
    _, _, scene, spec = recorded_case(HURRIED_WALKER, 6, 0, 0.55)
    sent: list[Verdict] = []
    imagine = partial(serve_one, scene)
    result = search(scene, spec, imagine, EXACT, THRESHOLD, 1, judging=JUDGING, head_start=sent.append)
    assert len(result.verdicts) == 1 and not result.verdicts[0].safe(THRESHOLD)
    assert sent == [] and result.lead is None and result.halt is None
    assert search(scene, spec, imagine, EXACT, THRESHOLD, 2, judging=JUDGING, head_start=sent.append).lead is not None


def test_a_lead_driven_no_time_is_no_lead_and_a_lead_that_is_the_move_is_driven_on() -> None:
    scene = load_scenario("paper_experiment1").scene()
    walks = [Walk("person", "couch", math.radians(8))]
    ball = scene.obstacle("ball").shape
    move = RobotMove("ball", ball.x + 0.6, ball.y, math.pi)
    other = RobotMove("ball", ball.x - 0.6, ball.y, 0.0)
    direct = imagine_joint(scene, walks, move, delay=0.1)
    assert imagine_joint(scene, walks, move, delay=0.1, lead=other, lead_for=0.0) == direct
    assert imagine_joint(scene, walks, move, delay=0.1, lead=move, lead_for=0.4) == direct
    assert imagine_joint(scene, walks, move, delay=0.1, lead=other, lead_for=0.5) != direct


def test_the_head_start_fields_travel_on_the_wire() -> None:
    _, _, scene, spec = recorded_case(HURRIED_WALKER, 6, 0, 0.55)
    lead = RobotMove("slipper", 1.2, -0.5, 0.0)
    item = JointItem(spec.walk_sets()[0], None, None, 0.1, EXACT, True, {}, lead, 0.3)
    assert item_from_wire(item.to_wire()) == item
    asked = SearchItem(spec, EXACT, THRESHOLD, 24, judging=JUDGING, head_start=True)
    back = item_from_wire(asked.to_wire())
    assert isinstance(back, SearchItem) and back.head_start and back.spec.lead is None
    result = search(
        scene, spec, partial(serve_one, scene), EXACT, THRESHOLD, 24, judging=JUDGING, head_start=lambda _: None
    )
    reply = ImagineReply(1, scene.time, None, 1.0, (Answer(search=result),))
    assert imagine_reply.decode(imagine_reply.encode(reply)).results[0].search == result


def test_a_head_start_ends_with_its_search_when_no_move_is_found() -> None:
    """Trial 0 of face-to-face: no candidate saves the person; the robot brakes where the search ends."""
    trial, planner, scene, spec = recorded_case(FACE_TO_FACE, 3, 0, 0.6)
    sent: list[Verdict] = []
    result = search(
        scene, spec, partial(serve_one, scene), EXACT, THRESHOLD, 24, judging=JUDGING, head_start=sent.append
    )
    assert result.chosen is None and sent == [result.lead] and result.lead is not None
    assert result.halt is not None and result.halt.move is None and not result.halt.trips(scene.robot_name)
    idle = run_idle(trial, planner=planner)
    assert result.judged == len(result.verdicts) + 1
    # Braking was judged at the search's end: it is not to go out sooner, however soon the search truly ends.
    assert result.sets_off == pytest.approx(DELAY + JUDGING * (len(result.verdicts) + 1))
    back = SearchResult.from_fields(Fields(result.to_wire(), "search", ReplyError))
    assert back.sets_off == result.sets_off and back.halt == result.halt
    world = world_at(trial, 0.6 + DELAY + JUDGING, planner)
    assert world.command_robot(result.lead.move)
    world.advance(0.6 + DELAY + JUDGING * (len(result.verdicts) + 1))
    world.command_robot(None)
    assert [c.obstacle for c in world.run(30.0).collisions] == [c.obstacle for c in idle.collisions]
    assert not saved_in_truth(trial, 0.6, planner, DELAY, JUDGING, result)


@pytest.mark.parametrize(
    ("scenario", "seed", "index", "at"),
    [(HURRIED_WALKER, 6, 0, 0.55), (FACE_TO_FACE, 3, 0, 0.6), (THREE_RESIDENTS, 11, 0, 2.0)],
)
def test_an_imagination_that_let_a_fall_happen_tells_where_one_that_stopped_at_it_ends(
    scenario: Path, seed: int, index: int, at: float
) -> None:
    """With three residents, the one that went on sees a later fall and the robot's arrival, both taken back."""
    _, _, scene, spec = recorded_case(scenario, seed, index, at)
    excused = {d.person: d.obstacle for d in spec.dangers}
    move = next(candidates(scene, spec.dangers))
    parted = 0
    for walks in spec.walk_sets():
        stopped = imagine_joint(scene, walks, move, delay=DELAY, until_first_fall=True)
        went_on = imagine_joint(scene, walks, move, delay=DELAY, until_first_fall=True, falling=excused)
        assert not stopped.safe_given({})  # someone falls with this move, at every gaze
        read = went_on.stopped_at_first_fall({})
        assert read is not None
        assert [(w.fine_given({}), w.collision_object, w.collision_point, w.collision_time) for w in read.walks] == [
            (w.fine_given({}), w.collision_object, w.collision_point, w.collision_time) for w in stopped.walks
        ]
        assert read.robot_arrival == stopped.robot_arrival
        parted += read != went_on
    assert parted > 0 or len(scene.people) == 1


def test_the_first_candidate_is_read_off_the_head_start_as_it_would_be_judged() -> None:
    """Over recorded dangers where a head start is sent, with perception's risk sampled round the walks."""
    clear = 0
    for scenario, seed, index, at in [
        (HURRIED_WALKER, 6, 0, 0.55),
        (FACE_TO_FACE, 3, 16, 0.6),
        ("paper_experiment1", 2024, 13, 0.55),  # clear at every gaze: the risk is sampled round the walks read off
        (THREE_RESIDENTS, 11, 0, 2.0),  # a later fall and the robot's arrival taken back
    ]:
        _, _, scene, spec = recorded_case(scenario, seed, index, at)
        sigma = {p.name: 0.04 for p in scene.people} | {o.name: 0.02 for o in scene.obstacles}
        noisy = Uncertainty(0.2, sigma, 16)
        imagine = partial(serve_one, scene)
        first = next(candidates(scene, spec.dangers))
        lead_spec = replace(spec, delay=DELAY + JUDGING)
        lead, answers = judge_lead(lead_spec, first, imagine, noisy, scene.robot_name)
        # harmless where the danger's fall happens: sent, if need be to be braked (see _Judging.harmless_braked)
        assert NoWorse(spec, imagine, noisy, THRESHOLD, scene.robot_name).harmless(lead, made_worse_too=True)
        read = driven_on(scene, lead_spec, first, answers, imagine, noisy)
        judged = judge_move(replace(lead_spec, lead=first, lead_for=JUDGING), first, imagine, noisy, scene.robot_name)
        assert read == judged
        clear += judged.clear and judged.risk > 0.0
    assert clear > 0
