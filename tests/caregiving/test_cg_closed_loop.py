"""Algorithm 2 in a closed loop on noisy beliefs, in process: looking again at a danger saves a person.

Seed 2024's trial 13, from the moment the live run first saw its danger, on one drawn sequence of beliefs:
acting on the first look alone, the robot's move fails in the truth; looking again every half second, as the
action agent does, the response replaces it and the person is saved. And on the exact scene with no delay, a
robot that knew the person's gaze saves one the gaze classes lose. In a room of three, a head start left
under way while each danger is searched alone trips nobody, and with false alarms on, the loop acts on a
danger Algorithm 1 sees in someone who falls in no truth; on such a false alarm, a head start and braking held
to the fall just missed leave nobody walking into the robot, or into what they pass, while one that is
harmless only braked still sets the robot off in time. With the assist agent's answer to a fall on, the
robot goes to someone lying where they fell, clear of whoever walks on. A belief that has someone touching
already finds no danger to search, and a move under way that passes someone within the margin round the robot
is doubted once, not braked. Braking that ends a head start goes out when its search judged it, however soon
the search truly ends.
"""

import math
from dataclasses import replace
from pathlib import Path

import pytest
from recorded_cases import HELD_OUT, JUDGING, STACK_SCENARIOS, THRESHOLD

from agents.caregiving.model.planner import GridPlanner
from agents.caregiving.model.scenario import load_scenario
from agents.caregiving.model.scene import Scene
from bridges.experiment.beliefs import Noise
from bridges.experiment.closed_loop import Loop, Setup, closed_loop
from bridges.experiment.oracle import idle_run, world_at
from bridges.experiment.perfect_belief import Gazes, spec_on
from bridges.world.bridge import trial_for

SEED, INDEX, AT, DRAW = 2024, 13, 0.65, 1
START_DELAY = 0.1  # seconds from a look to the robot's start, as bench/bench_closed_loop.py's default


@pytest.fixture(scope="module")
def case() -> tuple:
    scenario = load_scenario("paper_experiment1")
    return trial_for(scenario, SEED, INDEX), GridPlanner(scenario.scene().bounds)


def setup(first_look_only: bool) -> Setup:
    return Setup(
        delay=START_DELAY,
        judging=JUDGING,
        look=0.5,
        retry=0.5,
        first_look_only=first_look_only,
        noise=Noise(),
        threshold=THRESHOLD,
    )


def test_acting_on_the_first_look_alone_loses_the_person(case) -> None:
    trial, planner = case
    loop = closed_loop(trial, AT, planner, (INDEX, DRAW), setup(first_look_only=True))
    assert loop.looks == 1 and loop.commands >= 1
    assert [c.person for c in loop.truth.outcome().collisions] == ["person"]


def test_looking_again_replaces_the_move_and_saves_the_person(case) -> None:
    trial, planner = case
    loop = closed_loop(trial, AT, planner, (INDEX, DRAW), setup(first_look_only=False))
    assert loop.looks > 1 and loop.responses.get("send", 0) >= 2
    assert loop.truth.outcome().collisions == ()


def test_the_same_seed_draws_the_same_loop(case) -> None:
    trial, planner = case
    once, again = (closed_loop(trial, AT, planner, (INDEX, DRAW), setup(False)) for _ in range(2))
    assert (once.looks, once.commands, once.judged, once.responses) == (
        again.looks,
        again.commands,
        again.judged,
        again.responses,
    )


KNOWN_GAZE_SEED, KNOWN_GAZE_INDEX, KNOWN_GAZE_AT = 5, 3, 0.65  # the office series, a run of docs/results/heldout
# Lost at the gaze classes and saved at the true gaze (seed 5's trial 3, whose spec a test below reads, a guard saves at both).
GAZE_LOST_SEED, GAZE_LOST_INDEX, GAZE_LOST_AT = 31, 1, 0.5


def exact_and_at_once(known_gaze: bool) -> Setup:
    """The exact scene, no sampled risk, no delay: the loop judges on the truth but for the person's gaze."""
    return Setup(
        delay=0.0,
        judging=0.0,
        look=0.5,
        retry=0.5,
        first_look_only=False,
        noise=Noise(0.0, 0.0, 0.0, sampled_risk=False),
        threshold=THRESHOLD,
        known_gaze=known_gaze,
    )


@pytest.fixture(scope="module")
def office_case() -> tuple:
    scenario = load_scenario(HELD_OUT / "office_series.yaml")
    return trial_for(scenario, KNOWN_GAZE_SEED, KNOWN_GAZE_INDEX), GridPlanner(scenario.scene().bounds)


def test_a_move_judged_at_the_gaze_classes_can_fail_where_the_true_gaze_saves() -> None:
    scenario = load_scenario(HELD_OUT / "office_series.yaml")
    trial, planner = trial_for(scenario, GAZE_LOST_SEED, GAZE_LOST_INDEX), GridPlanner(scenario.scene().bounds)
    by_class = closed_loop(trial, GAZE_LOST_AT, planner, (GAZE_LOST_INDEX, 0), exact_and_at_once(False))
    known = closed_loop(trial, GAZE_LOST_AT, planner, (GAZE_LOST_INDEX, 0), exact_and_at_once(True))
    assert by_class.commands >= 1 and by_class.truth.outcome().collisions
    assert known.commands >= 1 and known.truth.outcome().collisions == ()


def test_the_true_gaze_alone_is_what_a_known_gaze_spec_judges_at(office_case) -> None:
    trial, planner = office_case
    idle = idle_run(trial, planner)
    now = world_at(trial, KNOWN_GAZE_AT, planner)
    spec = spec_on(now.scene(), idle, now, 0.0, Gazes.TRUE_GAZE)
    assert spec is not None
    assert spec.gazes == {d.person: (idle.walker(d.person).gaze,) for d in spec.dangers}
    by_class = spec_on(now.scene(), idle, now, 0.0)
    assert by_class is not None and len(next(iter(by_class.gazes.values()))) > 1
    any_class = spec_on(now.scene(), idle, now, 0.0, Gazes.ANY_CLASS)
    assert any_class is not None
    assert {p: set(g) for p, g in any_class.gazes.items()} == {p: set(g) for p, g in by_class.gazes.items()}


@pytest.mark.parametrize("gazes", [Gazes.SOONEST, Gazes.CLASSES])
def test_a_danger_already_touching_on_the_belief_is_not_searched(gazes: Gazes) -> None:
    """A belief that has the person 6 cm into the ball (perception's error, at a look close to the touch) finds their
    walk colliding at once: a danger due, which the action agent no longer searches
    (``robot_intentions.dangers_in``) and the simulator refuses on the wire. A look from 10 cm farther back finds it."""
    room = load_scenario("paper_experiment1")
    planner = GridPlanner(room.scene().bounds)
    idle, now = idle_run(room, planner), world_at(room, 0.5, planner)
    ball = next(o.shape for o in now.scene().obstacles if o.name == "ball")
    person = now.scene().person("person")

    def believed(gap: float) -> Scene:
        """The scene now with the person ``gap`` metres short of touching the ball, heading for it."""
        heading = math.atan2(ball.y - person.y, ball.x - person.x)
        back = ball.r + person.radius + gap
        there = person.moved(ball.x - back * math.cos(heading), ball.y - back * math.sin(heading), heading)
        return replace(now.scene(), people=(there,))

    assert spec_on(believed(-0.06), idle, now, 0.05, gazes, ["person"]) is None
    found = spec_on(believed(0.04), idle, now, 0.05, gazes, ["person"])
    assert found is not None and found.dangers[0].time_to_collision > 0.0


def test_a_head_start_under_way_while_each_danger_is_searched_alone_trips_nobody() -> None:
    """Three people in a lounge, seed 5, trial 9, on the exact scene: two walk towards the slipper and no move saves
    both. The search that judges moves for both sends a head start and finds nothing, and each danger is then
    searched alone while the robot drives it. Braked at the end of those searches, where its braking was never
    judged, the robot stood turned into the third person's way, and she walked into it."""
    scenario = load_scenario(HELD_OUT / "three_people_lounge.yaml")
    trial, planner = trial_for(scenario, 5, 9), GridPlanner(scenario.scene().bounds)
    exact = Setup(delay=0.05, judging=0.008, look=0.5, retry=0.5, first_look_only=False, noise=Noise(0.0, 0.0, 0.0))
    loop = closed_loop(trial, 0.6, planner, (9, 0), exact)
    fell = {c.person for c in loop.truth.outcome().collisions}
    assert loop.idle_fallers == {"bo", "cy"} and fell <= loop.idle_fallers


@pytest.mark.parametrize("false_alarms", [False, True])
def test_with_false_alarms_algorithm_1_looks_at_everyone_walking(false_alarms: bool) -> None:
    """Crossing hall, seed 8423, trial 16: nobody falls with the robot idle, and the live run flagged a danger at
    0.6 s. Looking only at who falls idle, the loop finds nothing to act on; looking at everyone, as live, it
    acts on the false alarm, and trips nobody."""
    scenario = load_scenario(HELD_OUT / "crossing_hall.yaml")
    trial, planner = trial_for(scenario, 8423, 16), GridPlanner(scenario.scene().bounds)
    setup = Setup(
        delay=0.05,
        judging=0.008,
        look=0.5,
        retry=0.5,
        first_look_only=False,
        noise=Noise(),
        false_alarms=false_alarms,
    )
    loop = closed_loop(trial, 0.6, planner, (16, 0), setup)
    assert not loop.idle_fallers and (loop.looks > 0) == false_alarms
    assert loop.truth.outcome().collisions == ()


def recorded_loop(scenario: str | Path, seed: int, index: int, at: float, draw: int, false_alarms: bool) -> Loop:
    """The closed loop of a recorded run's trial from ``at``, the run's ``risk_at_time`` as recorded, on the beliefs
    of ``draw``, every error drawn."""
    room = load_scenario(scenario)
    trial, planner = trial_for(room, seed, index), GridPlanner(room.scene().bounds)
    return closed_loop(trial, at, planner, (index, draw), replace(setup(False), false_alarms=false_alarms))


@pytest.mark.parametrize(
    ("scenario", "seed", "index", "at", "draw"),
    [
        (HELD_OUT / "bathroom_basket.yaml", 307, 3, 0.7000000000000001, 0),
        ("paper_experiment1", 90313, 29, 0.5499999999999999, 1),
        (HELD_OUT / "bathroom_basket.yaml", 11, 7, 0.6, 1),
    ],
    ids=["braking in her way", "a head start into the ball", "a graze the basket's size bias explains"],
)
def test_a_head_start_or_braking_that_harms_a_false_alarm_just_missed_is_not_sent(
    scenario: str | Path, seed: int, index: int, at: float, draw: int
) -> None:
    """Nobody falls with the robot idle, and the live run flagged a danger; on the beliefs drawn, the person walks
    into what they pass in the truth, and the first candidate, that obstacle's stand-off, is harmless with that
    fall let happen.

    In the bathroom at seed 307, trial 3, the search finds no move, and braking where it ends left the robot in
    her way once she passed the basket: imagined just missing it, she walks into the robot, with the head start
    as with braking, and neither is sent. In the paper's room at seed 90313, trial 29, imagined just missing the
    ball, the person plans round the robot on its way there and walks into the ball: a fall the robot as it is
    does not bring, which the code before excused because the person falls at the belief's centre too; it sent
    the head start, braked, and the person walked into the ball. In the bathroom at seed 11, trial 7, the
    belief has the person 5.9 cm into the basket, deeper than perception's position error alone explains
    (4.5 cm); the basket held up to a fifth too large explains the rest. The code before imagined no fall just
    missed so deep, sent the head start to the basket's stand-off and braked it in her way.
    """
    loop = recorded_loop(scenario, seed, index, at, draw, false_alarms=True)
    assert not loop.idle_fallers and loop.looks >= 1
    assert loop.truth.outcome().collisions == ()


def test_a_head_start_harmless_only_braked_still_sets_the_robot_off_and_saves_the_person() -> None:
    """The paper's room at seed 77031, trial 44, truly risky, on the beliefs of draw 0: the first candidate, the
    ball's stand-off straight behind it, would walk the person into the ball had they just missed it. Braked once
    the search has judged every candidate, it harms nobody, so it goes out as a head start, and the search
    switches to a stand-off that saves the person. Judged from rest without it, no candidate saves her in time."""
    loop = recorded_loop("paper_experiment1", 77031, 44, 0.5499999999999999, 0, false_alarms=False)
    assert loop.idle_fallers == frozenset({"person"}) and loop.responses.get("send", 0) >= 1
    assert loop.truth.outcome().collisions == ()


def test_a_move_under_way_passing_the_person_within_the_margin_is_doubted_once_and_saves_her() -> None:
    """The paper's room at seed 90311, trial 32, on the exact scene: judged again from where the robot drives, the
    stand-off sent at the first look has the person pass the robot inside the margin round it, with no touch
    imagined. Given up at once, no other move was found and the robot braked, and she walked into the ball; kept
    for one more look, it is replaced by a move that saves her."""
    room = load_scenario("paper_experiment1")
    trial, planner = trial_for(room, 90311, 32), GridPlanner(room.scene().bounds)
    loop = closed_loop(trial, 0.65, planner, (32, 0), replace(setup(False), noise=Noise(0.0, 0.0, 0.0)))
    assert loop.idle_fallers == frozenset({"person"}) and loop.responses.get("keep_doubted", 0) >= 1
    assert loop.truth.outcome().collisions == ()


def test_someone_who_has_fallen_is_no_danger_any_more() -> None:
    """Three people in a lounge, seed 5, trial 9: Bo and then Cy walk into the slipper with the robot idle. Once Bo
    lies where she fell, only Cy's danger is left; the spec of the loop's looks is that of the live pipeline, where
    perception sees Bo lying and Algorithm 1 guesses her no walk."""
    scenario = load_scenario(HELD_OUT / "three_people_lounge.yaml")
    trial, planner = trial_for(scenario, 5, 9), GridPlanner(scenario.scene().bounds)
    idle = idle_run(trial, planner)
    for at, dangers in ((6.0, ["bo", "cy"]), (6.5, ["cy"])):
        now = world_at(trial, at, planner)
        spec = spec_on(now.scene(), idle, now, 0.05)
        assert spec is not None and [d.person for d in spec.dangers] == dangers
        assert now.fallen() == frozenset(set(["bo", "cy"]) - set(dangers))
        assert "bo" not in {w.person for w in spec.bystanders}


@pytest.mark.parametrize("assist", [False, True])
def test_with_assist_the_robot_goes_to_someone_fallen_clear_of_whoever_walks_on(assist: bool) -> None:
    """Ana falls into the ball out of the robot's reach; Ben walks on for four seconds more. With the assist on, the
    first look that finds no danger sends the robot to her, and Ben walks on untouched."""
    scenario = load_scenario(STACK_SCENARIOS / "one_falls_one_walks_on.yaml")
    trial, planner = trial_for(scenario, 0, None), GridPlanner(scenario.scene().bounds)
    exact = Noise(0.0, 0.0, 0.0)
    setup = Setup(delay=0.05, judging=0.008, look=0.5, retry=0.5, first_look_only=False, noise=exact, assist=assist)
    loop = closed_loop(trial, 0.3, planner, (0, 0), setup)
    assert [c.person for c in loop.truth.outcome().collisions] == ["ana"]
    robot, ana, start = loop.truth.scene().robot, loop.truth.walker("ana").state, trial.scene().robot
    assert robot is not None and start is not None
    gained = math.dist((start.x, start.y), (ana.x, ana.y)) - math.dist((robot.x, robot.y), (ana.x, ana.y))
    assert (loop.gone_to, loop.responses.get("go_to", 0), gained > 2.0) == (
        ("ana", 1, True) if assist else (None, 0, False)
    )


def test_braking_that_ends_a_head_start_goes_out_when_judged_however_soon_the_search_truly_ends() -> None:
    """Face to face (held out) at seed 3, trial 0, on the beliefs of draw 0: no move saves the resident, and the
    head start sent at the first look is braked when its search ends. The search imagines each judgement taking
    30 ms, as the action agent does before it has timed one; judgements truly taking 8 ms, the head start goes
    out sooner, but braking goes out when the search was imagined to end, as with judgements that take the 30 ms:
    braked when the search truly ended, the robot would stop short of where braking was judged harmless."""
    room = load_scenario(HELD_OUT / "face_to_face.yaml")
    trial, planner = trial_for(room, 3, 0), GridPlanner(room.scene().bounds)
    untimed = replace(setup(False), delay=0.05, judging=0.03)
    as_estimated = closed_loop(trial, 0.6, planner, (0, 0), untimed)
    sooner = closed_loop(trial, 0.6, planner, (0, 0), replace(untimed, judged_in=0.008))
    (lead, *_), (lead_sooner, *_) = as_estimated.commanded, sooner.commanded
    assert lead[1] == lead_sooner[1] is not None and lead_sooner[0] < lead[0]
    brake = next(at for at, move in as_estimated.commanded if move is None)
    assert next(at for at, move in sooner.commanded if move is None) == pytest.approx(brake)
