"""Algorithm 1's guesses: the heading gate and the fold of gaze classes, on walks imagined in the paper's room."""

import math
from dataclasses import replace

import pytest

from agents.caregiving.model.geometry import Box, Circle
from agents.caregiving.model.guesses import (
    AHEAD_CLEARANCE,
    AHEAD_STEP,
    Guess,
    guesses,
    heading_error,
    straight_ahead,
    summarise,
    unguessed_walks,
)
from agents.caregiving.model.imagine import Imagination, imagine_person
from agents.caregiving.model.imagine_reply import Answer
from agents.caregiving.model.planner import GridPlanner
from agents.caregiving.model.scenario import RoomSpec, load_scenario
from agents.caregiving.model.scene import Obstacle, PersonState, Scene
from agents.caregiving.model.uncertainty import Risk
from agents.caregiving.model.world_model import Walk
from bridges.experiment.oracle import world_at
from bridges.world.bridge import trial_for

GATE = math.radians(20.0)
THRESHOLD = 0.2


@pytest.fixture(scope="module")
def heading_for_the_couch() -> tuple[Scene, dict[str, Answer]]:
    """Seed 2024's trial 94, half a second in: the person walks to the couch; a walk to the door would hit the ball.

    Their walks to both, imagined at their gaze from the exact scene.
    """
    scenario = load_scenario("paper_experiment1")
    trial = trial_for(scenario, 2024, 94)
    scene = world_at(trial, 0.5, GridPlanner(scenario.scene().bounds)).scene()
    gaze = math.radians(trial.people[0].gaze_deg)
    walks = {t: Answer(imagination=imagine_person(scene, "person", t, gaze)) for t in ("couch", "door")}
    return scene, walks


def walk(answer: Answer) -> Imagination:
    assert answer.imagination is not None
    return answer.imagination


def test_the_walk_to_the_door_sets_off_away_from_the_heading_and_hits_the_ball(heading_for_the_couch) -> None:
    scene, walks = heading_for_the_couch
    heading = scene.person("person").heading
    couch, door = walk(walks["couch"]), walk(walks["door"])
    assert not couch.collided and door.collided and door.collision_object == "ball"
    assert heading_error(couch.path, heading) < math.radians(5.0) < GATE < heading_error(door.path, heading)


def test_the_heading_gate_drops_the_walk_a_walking_person_is_not_on(heading_for_the_couch) -> None:
    scene, walks = heading_for_the_couch
    person = scene.person("person")
    asked = [Walk("person", "couch", 0.1), Walk("person", "door", 0.1)]
    answers = [(walks["couch"], 0.0), (walks["door"], 0.0)]
    walking = guesses(asked, answers, {"person": person.heading}, GATE, THRESHOLD)
    assert [(g.target, g.risky) for g in walking] == [("couch", False)]
    standing = guesses(asked, answers, {}, GATE, THRESHOLD)  # not walking: no heading to go by
    assert [(g.target, g.risky, g.obstacle) for g in standing] == [("couch", False, None), ("door", True, "ball")]


def test_an_unreachable_walk_gets_no_guess(heading_for_the_couch) -> None:
    _, walks = heading_for_the_couch
    unreachable = Answer(imagination=replace(walk(walks["door"]), reachable=False))
    found = guesses([Walk("person", "door", 0.1)], [(unreachable, 0.0)], {}, GATE, THRESHOLD)
    assert found == []


def test_the_fold_reports_the_earliest_danger_brought_forward_by_its_age(heading_for_the_couch) -> None:
    _, walks = heading_for_the_couch
    door = walk(walks["door"])
    assert door.collision_time is not None
    late = replace(door, gaze=0.15, collision_time=door.collision_time + 1.0)
    sampled_only = Answer(imagination=walk(walks["couch"]), risk=Risk(0.3, 0.5, (1.0, 1.0), "ball"))
    folded = summarise("person", "door", [(Answer(imagination=late), 0.0), (walks["door"], 0.25)], THRESHOLD)
    assert folded.nominal and folded.gaze == door.gaze
    assert folded.ttc == pytest.approx(door.collision_time - 0.25)
    grazed_sooner = Answer(imagination=door, risk=Risk(0.9, door.collision_time - 1.0, (0.5, 0.5), "ball"))
    assert summarise("person", "door", [(grazed_sooner, 0.25)], THRESHOLD).ttc == pytest.approx(
        door.collision_time - 1.25
    )
    by_sampling = summarise("person", "couch", [(sampled_only, 0.0)], THRESHOLD)
    assert by_sampling == Guess(
        "person", "couch", True, 0.3, walk(walks["couch"]).path, walk(walks["couch"]).gaze, 0.5, (1.0, 1.0), "ball"
    )
    assert not summarise("person", "couch", [(sampled_only, 0.0)], 0.31).risky


def test_a_fold_of_nothing_is_a_clear_error() -> None:
    with pytest.raises(ValueError, match="no imagined walk"):
        summarise("person", "couch", [], THRESHOLD)


def test_a_walking_person_not_yet_guessed_walks_to_the_targets_not_plainly_aside() -> None:
    def target(name: str, bearing_deg: float) -> Obstacle:
        b = math.radians(bearing_deg)
        return Obstacle(name, "table", Circle(3 * math.cos(b), 3 * math.sin(b), 0.3), 0.7, target=True)

    room = [target("ahead", 5), target("left", 35), target("right", -30), target("aside", 55), target("behind", 180)]
    person = PersonState("p", 0.0, 0.0, 0.0, 0.5, 0.25, 1.6, math.radians(120), math.radians(40), 0.1, 0.2)
    walks = unguessed_walks(person, room)
    assert [w.target for w in walks] == ["ahead", "right", "left"]  # within twice the gate, most nearly ahead first
    assert all(w.person == "p" and w.gaze == pytest.approx(0.15) for w in walks)  # the middle of their gaze range
    turned = replace(person, heading=math.radians(100))
    assert [w.target for w in unguessed_walks(turned, room)] == ["aside"]  # none within: the most nearly ahead
    assert [w.target for w in unguessed_walks(person, room, math.radians(20))] == ["ahead"]  # a narrower gate


def test_a_walking_person_with_no_target_in_view_walks_straight_ahead_to_short_of_what_is_there() -> None:
    """Not imagined standing: along their heading, to where anything (a wall too) comes within the clearance."""
    room = RoomSpec(8.0, 6.0, 2.5, 0.1, ()).wall_obstacles()
    behind = Obstacle("couch", "couch", Circle(-3.0, 0.0, 0.4), 0.8, target=True)
    person = PersonState("p", 0.0, 0.0, 0.0, 0.5, 0.25, 1.6, math.radians(120), math.radians(40), 0.1, 0.2)
    (walk,) = unguessed_walks(person, [*room, behind])
    assert walk.target == "" and walk.toward is not None and walk.gaze == pytest.approx(0.15)
    x, y = walk.toward
    assert y == pytest.approx(0.0)
    assert short_of(4.0, x, 0.25)  # the east wall's inner face
    stool = Obstacle("stool", "stool", Box(1.5, 0.0, 0.2, 0.2), 0.4)
    assert short_of(1.3, straight_ahead(person, [*room, behind, stool])[0], 0.25)
    against = replace(person, x=3.7)  # closer to the wall than the clearance already: they stay where they are
    assert straight_ahead(against, room) == (3.7, 0.0)


def short_of(face: float, x: float, radius: float) -> bool:
    """Whether a walk ending at ``x`` stops at the clearance short of ``face``, to within one step."""
    return -1e-9 <= face - radius - AHEAD_CLEARANCE - x <= AHEAD_STEP + 1e-9
