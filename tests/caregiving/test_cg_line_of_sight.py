"""What the robot's sensors see: segments leaving shapes, and lines of sight over bodies by their heights."""

import math
from dataclasses import replace

import numpy as np
from hypothesis import given, settings
from hypothesis import strategies as st
from recorded_cases import HELD_OUT

from agents.caregiving.model.geometry import Box, Circle, segment_exits, signed_distance
from agents.caregiving.model.scenario import load_scenario
from agents.caregiving.model.scene import PERSON_KIND, Obstacle
from agents.caregiving.model.world_model import World
from bridges.world.line_of_sight import in_view
from bridges.world.sensors import Sensors

WARDROBE_BEDROOM = str(HELD_OUT / "wardrobe_bedroom.yaml")
SENSOR = (-2.0, 0.0, 1.3)  # a robot 1.3 m tall at (-2, 0)

coordinate = st.floats(-3.0, 3.0)
size = st.floats(0.05, 1.5)


@st.composite
def shapes(draw: st.DrawFn) -> Box | Circle:
    x, y = draw(coordinate), draw(coordinate)
    if draw(st.booleans()):
        return Circle(x, y, draw(size))
    return Box(x, y, draw(size), draw(size), draw(st.floats(-math.pi, math.pi)))


@settings(max_examples=200, deadline=None)
@given(shapes(), coordinate, coordinate, st.lists(st.tuples(coordinate, coordinate), min_size=1, max_size=4))
def test_a_segment_leaves_a_shape_where_dense_samples_along_it_last_lie_inside(
    shape: Box | Circle, ox: float, oy: float, ends: list[tuple[float, float]]
) -> None:
    exits = segment_exits(shape, (ox, oy), np.array(ends))
    t = np.linspace(0.0, 1.0, 4001)
    for (ex, ey), exit in zip(ends, exits, strict=True):
        along = np.column_stack((ox + (ex - ox) * t, oy + (ey - oy) * t))
        distance = signed_distance(shape, along)
        inside = t[distance <= 0.0]
        length = math.hypot(ex - ox, ey - oy)
        if inside.size == 0:
            # Dense samples may step over a corner the segment only grazes.
            assert math.isnan(exit) or distance.min() <= 1e-3 * length + 1e-9
            continue
        assert not math.isnan(exit)
        assert abs(exit - inside.max()) * length <= 2e-3 * max(length, 1e-9) + 1e-6


def body(name: str, kind: str, x: float, y: float, height: float, half: tuple[float, float] = (0.1, 0.1)) -> Obstacle:
    return Obstacle(name, kind, Box(x, y, *half), height)


def person(name: str, x: float, y: float, height: float = 1.7) -> Obstacle:
    return Obstacle(name, PERSON_KIND, Circle(x, y, 0.25), height)


BED = body("bed", "bed", 0.0, 0.0, 0.6, (1.0, 0.5))  # 2 m by 1 m, 0.6 m high, between the robot and x > 1


def test_a_bed_hides_a_toy_close_behind_it_but_not_one_far_enough_back_for_the_line_to_clear_it() -> None:
    near = body("near_toy", "toy", 1.3, 0.0, 0.12)
    # From 1.3 m down to the far toy's top 0.12 m, 5.5 m off, the line leaves the bed 3 m along at 0.66 m.
    far = body("far_toy", "toy", 3.5, 0.0, 0.12)
    assert in_view(SENSOR, [BED, near, far]) == {"bed", "far_toy"}


def test_a_standing_person_shows_over_a_bed_and_someone_lying_behind_it_does_not() -> None:
    standing = person("standing", 1.5, 0.0)
    lying = person("lying", 1.5, 0.0, height=0.3)
    assert in_view(SENSOR, [BED, standing]) == {"bed", "standing"}
    assert in_view(SENSOR, [BED, lying]) == {"bed"}


def test_a_wardrobe_hides_someone_behind_it_until_they_step_out_past_its_side() -> None:
    wardrobe = body("wardrobe", "cabinet", 0.0, 0.0, 2.0, (0.3, 0.6))
    assert in_view(SENSOR, [wardrobe, person("behind", 0.8, 0.0)]) == {"wardrobe"}
    # Half of her past the wardrobe's side, as the line from the robot runs: her near side shows.
    assert in_view(SENSOR, [wardrobe, person("stepping_out", 0.8, 0.95)]) == {"wardrobe", "stepping_out"}


def test_a_wall_hides_whatever_its_height_and_a_person_hides_what_is_low_behind_them() -> None:
    low_wall = body("partition", "wall", 0.0, 0.0, 0.5, (0.05, 1.0))
    assert in_view(SENSOR, [low_wall, person("behind", 1.0, 0.0)]) == set()
    toy = body("toy", "toy", 0.0, 0.0, 0.12)
    assert in_view(SENSOR, [person("in_front", -1.0, 0.0), toy]) == {"in_front"}
    assert in_view(SENSOR, [person("beside", -1.0, 0.6), toy]) == {"beside", "toy"}


def test_with_occlusion_the_sensors_see_the_resident_only_once_she_steps_out_from_behind_the_wardrobe() -> None:
    """The held-out bedroom, every frame kept: the resident, behind the wardrobe at first, comes into view as
    she walks out past its end; the basket behind the bed never does; the rest is seen at once. Without
    occlusion, everything is seen at the first frame."""
    s = load_scenario(WARDROBE_BEDROOM)
    assert s.sensors.occlusion
    first: dict[bool, dict[str, float]] = {}
    for occlusion in (True, False):
        sensors = Sensors(replace(s.sensors, dropout=0.0, occlusion=occlusion), np.random.default_rng(0))
        world = World.from_scenario(s)
        seen = first.setdefault(occlusion, {})
        while world.time < 5.0 - 1e-9:
            sensors.observe(world.scene(), world.fallen())
            for d in sensors.ready(world.time):
                seen.setdefault(d.name, d.stamp)
            world.step()
    assert first[False] == dict.fromkeys(["door", "wardrobe", "bed", "basket", "footstool", "resident"], 0.0)
    assert {k: v for k, v in first[True].items() if k != "resident"} == dict.fromkeys(
        ["door", "wardrobe", "bed", "footstool"], 0.0
    )
    assert 1.0 < first[True]["resident"] < 3.0
